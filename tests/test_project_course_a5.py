"""The course's grid lines against the reference images: every command line of assignment 5, and the lines of
assignment 6 that draw the grid (-visualize_grid) or only add -grid to the plain ray caster.

Tolerance (issue 4): at least 99% of pixels with every channel within 2/255 of the reference. These match on
all pixels but at most one: in output5_06 and output5_09 a single ray crosses two cell faces less than 1e-6 of a
cell apart, and the course's single precision took them in the other order (another face, or a neighbour cell).
The test allows 2 pixels in 40000. output5_03's reference was rendered after turning the camera in the course's
OpenGL preview (-gui; its screenshot gui5_03_1.png shows the same view), so the scene file's camera cannot
reproduce it: it is checked with the camera recovered from the image instead (GUI_CAMERA_5_03).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import COURSE, needs_course

pytestmark = needs_course

GUI_CAMERA = {"output5_03.tga"}  # reference rendered from a camera moved in the -gui preview


def _grid_lines():
    if not COURSE.is_dir():
        return []
    from course_report import course_lines

    lines = [line for line in course_lines([5]) if line.outputs and not set(line.outputs) & GUI_CAMERA]
    for line in course_lines([6]):
        shading_only = not {"-shadows", "-bounces"} & set(line.argv)
        if "-visualize_grid" in line.argv or ("-grid" in line.argv and shading_only):
            lines.append(line)
    return lines


LINES = _grid_lines()


def _reference(line, name):
    """The reference image of one output; assignment 6 shows one image for runs differing only by -grid/-stats
    (output6_01a_b.png for output6_01a and output6_01b)."""
    ref = line.reference(name)
    if ref.exists():
        return ref
    stem = ref.stem
    for candidate in ref.parent.glob(f"{stem[:-1]}*.png"):
        if stem[-1] in candidate.stem[len(stem) - 1:].split("_"):
            return candidate
    return None


@pytest.mark.parametrize("line", LINES, ids=lambda line: line.outputs[0])
def test_grid_line_matches_reference(line, tmp_path):
    from course_report import compare, run_line

    code, err, written, _ = run_line(line, str(tmp_path))
    assert code == 0, err
    for name, path in written.items():
        ref = _reference(line, name)
        assert ref is not None, f"no reference image for {name}"
        fraction, _, largest = compare(path, ref)
        assert fraction >= 1.0 - 2 / 40000, (f"{name}: {fraction:.4%} of pixels within 2/255 of {ref.name} "
                                             f"(largest diff {largest})")
    if "-stats" in line.argv:
        assert "RAY TRACING STATISTICS" in err and "num grid cells" in err


def test_lines_found():
    """14 lines of assignment 5 with an output (output5_03 is checked on its own), 11 -visualize_grid and 7 plain
    -grid lines of assignment 6."""
    names = [line.outputs[0] for line in LINES]
    assert len([n for n in names if n.startswith("output5")]) == 14
    assert len([line for line in LINES if "-visualize_grid" in line.argv and line.assignment == 6]) == 11
    assert {f"output6_{k:02d}b.tga" for k in (1, 2, 3, 4, 8, 9, 10)} <= set(names)


def test_stats_summary_counts_the_grid(tmp_path):
    """-stats with -grid: the course's summary with 40000 eye rays, the 10x10x10 grid and the cells walked."""
    from course_report import course_lines, run_line

    line = next(line for line in course_lines([6]) if line.outputs == ["output6_01b.tga"])
    code, err, _, _ = run_line(line, str(tmp_path))
    assert code == 0
    assert "num non-shadow rays        40000" in err and "num grid cells             1000 (10x10x10)" in err
    cells = int(err.split("total cells traversed")[1].split()[0])
    assert 20000 < cells < 40000 * 10


# The -gui camera of output5_03, recovered by fitting durer's render to the reference image (a coarse search,
# then Nelder-Mead on the mean absolute difference of blurred, then sharp images): the scene's orthographic
# camera turned about the world origin, yaw about `up` then pitch about the horizontal axis, in degrees; the
# fitted truck and zoom came out as none (size 5 as in the scene file).
GUI_CAMERA_5_03 = (12.32, -16.61)


def gui_camera(yaw_deg: float, pitch_deg: float):
    """scene5_03's camera turned as the course's GUI turns it."""
    from durer.scene.cameras import OrthographicCamera
    from durer.scene.transforms import rotate

    up = np.array([0.0, 1.0, 0.0])
    center, direction = np.array([0.0, 3.0, 10.0]), np.array([0.0, 0.0, -1.0])
    r = rotate(up, yaw_deg)[:3, :3] @ rotate(np.cross(direction, up), pitch_deg)[:3, :3]
    return OrthographicCamera(center=r @ center, direction=r @ direction, up=up, size=5)


def test_output5_03_with_the_gui_camera(tmp_path):
    from course_report import compare

    import durer

    folder = COURSE / "assignment5"
    scene = durer.load(folder / "scene5_03_offcenter_spheres.txt")
    scene.camera = gui_camera(*GUI_CAMERA_5_03)
    out = tmp_path / "output5_03.png"
    durer.render(scene, 200, 200, grid=(20, 20, 20), visualize_grid=True).save(out, course=True)
    fraction, mean, largest = compare(str(out), folder / "reference" / "output5_03.png")
    assert fraction >= 0.999, f"{fraction:.4%} within 2/255 (mean {mean:.3f}, largest {largest})"
