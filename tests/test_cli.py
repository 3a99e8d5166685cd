"""The `durer` command: course and modern flags, one-line errors with exit status 2, no partial outputs."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from durer.cli import main

SCENE = """\
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }
Background { color 0 0 0 }
Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }
Group {
    numObjects 1
    MaterialIndex 0
    Sphere { center 0 0 0 radius 1 }
}
"""


@pytest.fixture
def scene(tmp_path):
    p = tmp_path / "scene.txt"
    p.write_text(SCENE)
    return p


def run(argv, capsys):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_course_command_writes_all_images(scene, tmp_path, capsys):
    out, depth, normals = tmp_path / "o.tga", tmp_path / "d.tga", tmp_path / "n.ppm"
    code, _, err = run(["raycast", "-input", str(scene), "-size", "20", "10", "-output", str(out),
                        "-depth", "9", "10", str(depth), "-normals", str(normals)], capsys)
    assert code == 0, err
    img = np.asarray(Image.open(out))
    assert img.shape == (10, 20, 3) and img[5, 10].tolist() == [255, 0, 0] and img[0, 0].tolist() == [0, 0, 0]
    # size 5 spans the longer side (20 px): the pixel centre next to the image centre is 0.125 from the axis
    assert np.asarray(Image.open(depth))[5, 10, 0] == int(np.sqrt(1 - 2 * 0.125**2) * 255)
    assert np.asarray(Image.open(normals))[5, 10, 2] == int(np.sqrt(1 - 2 * 0.125**2) * 255)


def test_course_depth_accepts_negative_numbers(scene, tmp_path, capsys):
    code, _, err = run(["raycast", "-input", str(scene), "-size", "4", "4", "-depth", "-2", "2", str(tmp_path / "d.png")],
                       capsys)
    assert code == 0, err


def test_render_command(scene, tmp_path, capsys):
    out = tmp_path / "o.png"
    code, _, err = run(["render", str(scene), "-o", str(out), "--size", "16", "8", "--quiet",
                        "--depth", "9", "10", str(tmp_path / "d.npy"), "--normals", str(tmp_path / "n.npy")], capsys)
    assert code == 0, err
    assert np.asarray(Image.open(out)).shape == (8, 16, 3)
    assert np.load(tmp_path / "d.npy").shape == (8, 16)
    assert np.load(tmp_path / "n.npy").shape == (8, 16, 3)
    assert err == ""


def test_render_help_documents_every_option(capsys):
    with pytest.raises(SystemExit) as e:
        main(["render", "--help"])
    assert e.value.code == 0
    text = capsys.readouterr().out
    for option in ("--output", "--size", "--depth", "--normals", "--quiet", "--shadows", "--bounces", "--weight",
                   "--samples", "--filter", "--seed", "--shade-back", "--mesh-path", "--linear", "--accel"):
        assert option in text


BAD_FLAGS = [
    ["raycast", "-size", "10", "10", "-output", "x.tga"],                          # no -input
    ["raycast", "-input", "SCENE", "-size", "10", "-output", "x.tga"],             # -size needs two numbers
    ["raycast", "-input", "SCENE", "-size", "10", "0", "-output", "x.tga"],        # zero height
    ["raycast", "-input", "SCENE", "-size", "a", "10", "-output", "x.tga"],
    ["raycast", "-input", "SCENE", "-size", "10", "10", "-output", "x.tga", "-bogus"],
    ["raycast", "-input", "SCENE", "-size", "10", "10"],                            # nothing to write
    ["raycast", "-input", "SCENE", "-size", "10", "10", "-output", "x.webp"],      # unknown format
    ["raycast", "-input", "SCENE", "-size", "10", "10", "-depth", "1", "x", "d.tga"],
    ["raycast", "-input", "SCENE", "-size", "10", "10", "-output", "x.tga", "-bounces", "-1"],
    ["raycast", "-input", "SCENE", "-size", "10", "10", "-output", "x.tga", "-visualize_grid"],
    ["raycast", "-input", "SCENE", "-size", "10", "10", "-output", "x.tga", "-box_filter", "1", "-tent_filter", "1"],
    ["render", "SCENE"],                                                            # no -o
    ["render", "SCENE", "-o", "x.png", "--filter", "sinc"],
    ["render", "SCENE", "-o", "x.png", "--filter", "gaussian:-1"],
    ["render", "SCENE", "-o", "x.png", "--size", "10"],
    ["render", "SCENE", "-o", "x.png", "--accel", "kdtree"],
    ["frobnicate"],
    [],
]


@pytest.mark.parametrize("argv", BAD_FLAGS, ids=[" ".join(a[1:]) or "(none)" for a in BAD_FLAGS])
def test_bad_flags_exit_2_with_one_message(argv, scene, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    argv = [str(scene) if a == "SCENE" else a for a in argv]
    code, _, err = run(argv, capsys)
    assert code == 2
    assert "Traceback" not in err and err.strip()
    if argv and argv[0] in ("raycast", "render"):
        usage, message = err.rstrip("\n").split("\n")
        assert usage.startswith(f"usage: durer {argv[0]} ")
        assert message.startswith(f"durer {argv[0]}: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.txt"]  # nothing written


def test_bad_scene_is_one_line_and_existing_output_untouched(scene, tmp_path, capsys):
    scene.write_text(SCENE.replace("radius 1", "radius -1"))
    out = tmp_path / "o.tga"
    out.write_bytes(b"previous render")
    code, _, err = run(["raycast", "-input", str(scene), "-size", "10", "10", "-output", str(out)], capsys)
    assert code == 2
    assert err == f"{scene}:7: sphere radius must be positive, got -1\n"
    assert out.read_bytes() == b"previous render"


def test_real_process_exit_code_and_no_traceback(scene, tmp_path):
    scene.write_text(SCENE.replace("numObjects 1", "numObjects x"))
    p = subprocess.run([sys.executable, "-m", "durer", "raycast", "-input", str(scene), "-size", "4", "4",
                        "-output", str(tmp_path / "o.tga")], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2
    assert p.stderr == f"{scene}:5: expected an integer for numObjects, got 'x'\n"
    assert not (tmp_path / "o.tga").exists()


def test_gui_flags_are_accepted_and_ignored(scene, tmp_path, capsys):
    code, _, err = run(["raycast", "-input", str(scene), "-size", "4", "4", "-output", str(tmp_path / "o.tga"),
                        "-gui", "-tessellation", "10", "5", "-gouraud"], capsys)
    assert code == 0
    lines = [line for line in err.splitlines() if "compiling the kernels" not in line]  # a cold cache says so too
    assert len(lines) == 1 and "ignored" in lines[0]


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("durer ")


def test_render_with_the_lecture_loop_gives_the_same_image(scene, tmp_path, capsys):
    """--accel brute runs kernels/brute.py (every ray against every object): the same pixels as the BVH."""
    for accel in ("bvh", "brute"):
        code, _, err = run(["render", str(scene), "-o", str(tmp_path / f"{accel}.png"), "--size", "24", "16",
                            "--accel", accel, "-q"], capsys)
        assert code == 0, err
    bvh = np.asarray(Image.open(tmp_path / "bvh.png"))
    assert bvh.max() > 0
    np.testing.assert_array_equal(np.asarray(Image.open(tmp_path / "brute.png")), bvh)


# --- issue 13: model files and the first hour --------------------------------------------------------------------
@pytest.fixture
def model(tmp_path):
    from test_io_models import hand_written_gltf, write_glb

    path = tmp_path / "quads.glb"
    write_glb(path, *hand_written_gltf())
    return path


def test_render_a_model_through_a_named_camera(model, tmp_path, capsys):
    front, top = tmp_path / "front.npy", tmp_path / "top.npy"
    assert run(["render", str(model), "-o", str(tmp_path / "f.png"), "--size", "9", "9", "-q",
                "--depth", "0", "1", str(front)], capsys)[0] == 0
    assert run(["render", str(model), "-o", str(tmp_path / "t.png"), "--size", "8", "8", "-q", "--camera", "Top",
                "--depth", "0", "1", str(top)], capsys)[0] == 0
    assert np.load(front)[4, 4] == pytest.approx(4.0) and np.load(top)[5, 3] == pytest.approx(6.0)


def test_unknown_camera_is_one_line(model, tmp_path, capsys):
    code, _, err = run(["render", str(model), "-o", str(tmp_path / "o.png"), "--camera", "Side"], capsys)
    assert code == 2
    assert err == f"{model}: no camera 'Side' in the model (its cameras: 0 ('Front'), 1 ('Top'))\n"
    assert not (tmp_path / "o.png").exists()


def test_shade_back_is_on_for_render_unless_turned_off(tmp_path, capsys):
    import trimesh

    ball = trimesh.creation.icosphere(subdivisions=1)
    ball.faces = ball.faces[:, ::-1]  # inward-facing, as the Stanford bunny
    ball.export(tmp_path / "ball.ply")
    for flag, lit in (([], True), (["--no-shade-back"], False)):
        out = tmp_path / "o.npy"
        assert run(["render", str(tmp_path / "ball.ply"), "-o", str(out), "--size", "16", "16", "-q", *flag],
                   capsys)[0] == 0
        assert bool(np.load(out)[8, 8].min() > 0.2) is lit


def test_unreadable_model_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"glTF\x02\x00\x00\x00" + bytes(range(256)))
    code, _, err = run(["render", str(bad), "-o", str(tmp_path / "o.png")], capsys)
    assert code == 2 and err.count("\n") == 1 and err.startswith(f"{bad}: ") and "Traceback" not in err


def test_huge_size_is_one_line_before_anything(scene, tmp_path, capsys):
    out = tmp_path / "o.png"
    code, _, err = run(["render", str(scene), "-o", str(out), "--size", "100000", "100000"], capsys)
    assert code == 2 and err.count("\n") == 1
    assert err.startswith("durer: a 100000 x 100000 image with 1 sample(s) per pixel would need about 1.3 TB")
    assert not out.exists()


@pytest.mark.parametrize("command", ["render", "raycast"])
def test_missing_folder_and_folder_in_the_way_are_found_before_rendering(command, scene, tmp_path, capsys,
                                                                         monkeypatch):
    from durer.rendering import renderer

    monkeypatch.setattr(renderer, "render", lambda *a, **k: pytest.fail("rendered before checking the output"))
    (tmp_path / "o.png").mkdir()
    for out, reason in ((tmp_path / "o.png", "it is a folder"),
                        (tmp_path / "nodir" / "x.png", f"folder '{tmp_path / 'nodir'}' does not exist")):
        argv = (["render", str(scene), "-o", str(out)] if command == "render"
                else ["raycast", "-input", str(scene), "-size", "4", "4", "-output", str(out)])
        code, _, err = run(argv, capsys)
        assert code == 2 and err == f"durer: cannot write '{out}': {reason}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o.png", "scene.txt"]


@pytest.mark.skipif(not hasattr(__import__("os"), "geteuid") or __import__("os").geteuid() == 0,
                    reason="root may write anywhere, so a read-only folder cannot be tested as root")
def test_read_only_folder_is_found_before_rendering(scene, tmp_path, capsys):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        code, _, err = run(["render", str(scene), "-o", str(folder / "o.png")], capsys)
    finally:
        folder.chmod(0o755)
    assert code == 2 and err == f"durer: cannot write '{folder / 'o.png'}': no permission to write in folder '{folder}'\n"
    assert list(folder.iterdir()) == []


def test_write_errors_name_the_users_path(scene, tmp_path, capsys, monkeypatch):
    import durer.io.images as images

    def refuse(src, dst):
        raise PermissionError(13, "Permission denied", src)

    monkeypatch.setattr(images.os, "replace", refuse)
    out = tmp_path / "o.png"
    code, _, err = run(["render", str(scene), "-o", str(out), "--size", "4", "4", "-q"], capsys)
    assert code == 2 and err == f"durer: cannot write '{out}': Permission denied\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.txt"]  # the temporary file is gone too


def test_compile_notice_on_a_cold_start(scene, tmp_path, capsys, monkeypatch):
    from durer.rendering import kernel_cache

    monkeypatch.setattr(kernel_cache, "module_cached", lambda module: False)
    code, _, err = run(["render", str(scene), "-o", str(tmp_path / "o.png"), "--size", "4", "4"], capsys)
    assert code == 0 and err.splitlines()[0].startswith("durer: compiling the kernels of the BVH (about 15 s")


@pytest.mark.parametrize("argv", [["-h"], ["render", "-h"], ["raycast", "-h"]])
def test_closed_pipe_ends_quietly(argv):
    p = subprocess.Popen([sys.executable, "-m", "durer", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()  # the reader is gone before durer writes: `durer -h | head -0`
    err = p.stderr.read().decode()
    p.stderr.close()
    assert p.wait(timeout=60) == 0
    assert err == ""


def test_default_size_follows_the_gltf_cameras_aspect(tmp_path, capsys):
    from conftest import REPO

    out = tmp_path / "o.png"
    assert run(["render", str(REPO / "examples" / "spotlights.gltf"), "-o", str(out), "-q"], capsys)[0] == 0
    assert Image.open(out).size == (512, 384)  # the file's camera: aspectRatio 4/3
