"""Every command line of course assignments 3 (Phong) and 4 (shadows, reflection, refraction), run through
`durer raycast`, against the reference images.

Tolerance (issue 4): the fraction of pixels whose largest channel difference is at most 2/255. Assignment 3
matches on every pixel. In assignment 4 a handful of pixels (at most 27 of 40000, in 4_06f) differ where a ray
grazes a triangle edge or a sphere's silhouette: the course computed in float32, durer in float64, so such rays
may hit the other triangle or miss. The test demands 99.9%, well above the issue's 99%.

output4_05 is the exception: the handout rendered it after moving the camera in the -gui preview (its window
screenshot gui4_05_1.png shows the same view), so the scene file's camera cannot reproduce it. The test checks
it with the camera recovered from the reference image instead (`GUI_CAMERA_4_05`): five numbers fitted to the
image make 99.88% of its pixels match, total internal reflection inside the index-4 bar included.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from conftest import COURSE, needs_course
from PIL import Image

pytestmark = needs_course

if COURSE.is_dir():
    from course_report import compare, course_lines, run_line

    ALL_LINES = course_lines([3, 4])
else:
    ALL_LINES = []
# three 4_14 lines only open the course's OpenGL preview (-gui, no -output): there is no image to compare
LINES = [line for line in ALL_LINES if line.outputs]

MOVED_CAMERA = {"output4_05"}


def _min_fraction(assignment: int) -> float:
    return 1.0 if assignment == 3 else 0.999


@pytest.mark.parametrize("line", LINES, ids=lambda l: " ".join(l.argv[1:2] + l.outputs[:1]))
def test_course_line_matches_reference(line, tmp_path):
    code, err, written, _ = run_line(line, str(tmp_path))
    assert code == 0, err
    checked = 0
    for name, path in written.items():
        ref = line.reference(name)
        assert os.path.exists(path)
        if not ref.exists() or ref.stem in MOVED_CAMERA:
            continue
        fraction, mean, largest = compare(path, ref)
        assert fraction >= _min_fraction(line.assignment), (
            f"{name}: {fraction:.4%} of pixels within 2/255 (largest diff {largest}, mean {mean:.3f})")
        checked += 1
    if not any(line.reference(n).stem in MOVED_CAMERA for n in written):
        assert checked, "no reference image for this line"


def test_all_lines_found():
    assert len(ALL_LINES) == 15 + 30
    assert len(LINES) == 15 + 27


# The -gui camera of output4_05, recovered by fitting durer's render to the reference image (Nelder-Mead on the
# mean absolute difference, from a coarse search over blurred images): the course's GUI
# rotates the camera about the world origin (yaw about `up`, then pitch about the horizontal axis), then dollies
# along the view direction and trucks sideways/up. Values: yaw, pitch (degrees), dolly, truck x, truck y.
GUI_CAMERA_4_05 = (60.724, -14.608, 2.9507, 0.5503, -0.6499)


def gui_camera(yaw_deg: float, pitch_deg: float, dolly: float, dx: float, dy: float):
    """The scene4_05 camera moved as the course's GUI moves it."""
    from durer import PerspectiveCamera

    def rotation(axis, angle):
        x, y, z = axis / np.linalg.norm(axis)
        c, s = np.cos(angle), np.sin(angle)
        k = 1 - c
        return np.array([[c + x * x * k, x * y * k - z * s, x * z * k + y * s],
                         [y * x * k + z * s, c + y * y * k, y * z * k - x * s],
                         [z * x * k - y * s, z * y * k + x * s, c + z * z * k]])

    up = np.array([0.0, 1.0, 0.0])
    center = np.array([0.0, 1.5, 7.0])
    direction = np.array([0.0, -0.2, -1.0]) / np.linalg.norm([0.0, -0.2, -1.0])
    horizontal = np.cross(direction, up)
    r = rotation(up, np.radians(yaw_deg)) @ rotation(horizontal, np.radians(pitch_deg))
    center, direction = r @ center, r @ direction
    horizontal = np.cross(direction, up)
    horizontal /= np.linalg.norm(horizontal)
    screen_up = np.cross(horizontal, direction)
    center = center + dolly * direction + dx * horizontal + dy * screen_up
    return PerspectiveCamera(center=center, direction=direction, up=up, angle=45)


def test_output4_05_with_the_gui_camera(tmp_path):
    import durer

    folder = COURSE / "assignment4"
    scene = durer.load(folder / "scene4_05_transparent_bar.txt")
    scene.camera = gui_camera(*GUI_CAMERA_4_05)
    result = durer.render(scene, 200, 200, shadows=True, bounces=10, weight=0.01, shade_back=True)
    out = tmp_path / "output4_05.png"
    result.save(out, course=True)
    fraction, mean, largest = compare(str(out), folder / "reference" / "output4_05.png")
    assert fraction >= 0.995, f"{fraction:.4%} within 2/255 (mean {mean:.3f}, largest {largest})"
    mine = np.asarray(Image.open(out).convert("RGB")).astype(int)
    assert mine.max() > 200  # the bright cyan top of the bar is there
