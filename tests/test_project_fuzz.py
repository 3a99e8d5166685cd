"""Fuzzing (issue 25): valid course scenes, meshes and command lines, mutated by hypothesis; each must end in
success or one clean error (SceneError naming the file and a line inside it, ValueError, exit status 2 with one
message), never a traceback, a hang or an unchecked allocation.

Bounded and derandomized by default (about a minute in all); `--hypothesis-profile=fuzz` (tests/conftest.py) runs
thousands of random examples per test. Cases found are pinned in tests/test_project_bad_input.py or with @example.
"""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import durer
from durer.cli import main

pytestmark = pytest.mark.slow  # hundreds of mutated inputs

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
COURSE_SCENES = [EXAMPLES / "spheres.txt", EXAMPLES / "fisheye.txt", EXAMPLES / "panorama.txt"]
CUBE = (EXAMPLES / "cube.obj").read_text()


def budget(default: int):
    """Settings of one fuzz test: `default` derandomized examples, unless a profile asks for more (fuzz)."""
    longer = settings.default.max_examples > 100
    return settings(max_examples=settings.default.max_examples if longer else default, derandomize=not longer,
                    deadline=None, database=None if not longer else settings.default.database,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                           HealthCheck.data_too_large])


# tokens a mutation puts in: numbers at the edges of float range, braces, every keyword of the format
ODD = ["0", "-1", "1", "2", "1e308", "-1e308", "1e-320", "nan", "inf", "-inf", "3.5", "99999999999", "{", "}",
       "x", "Group", "Transform", "Sphere", "Plane", "Triangle", "TriangleMesh", "numObjects", "MaterialIndex",
       "Materials", "numMaterials", "PhongMaterial", "Checkerboard", "materialIndex", "Lights", "numLights",
       "PointLight", "Scale", "Translate", "Matrix", "Rotate", "XRotate", "UniformScale", "obj_file", "cube.obj",
       "center", "radius", "angle", "size", "OrthographicCamera", "Background", "color"]


@st.composite
def mutated_scene(draw) -> tuple[str, str]:
    """(file name, text): a bundled course scene with 1-4 token-level edits (delete, insert, replace, repeat a
    block's opening many times, cut the file short)."""
    source = draw(st.sampled_from(COURSE_SCENES))
    tokens = source.read_text().replace("{", " { ").replace("}", " } ").split()
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["delete", "insert", "replace", "replace", "nest", "cut"]))
        i = draw(st.integers(0, len(tokens) - 1))
        if kind == "delete":
            del tokens[i]
        elif kind == "insert":
            tokens.insert(i, draw(st.sampled_from(ODD)))
        elif kind == "replace":
            tokens[i] = draw(st.sampled_from(ODD))
        elif kind == "nest":
            depth = draw(st.sampled_from([2, 50, 300, 3000]))
            tokens[i:i] = ["Group", "{", "numObjects", "1"] * depth
        else:
            tokens = tokens[:i]
        if not tokens:
            tokens = ["}"]
    return source.name, " ".join(tokens)


def _check_scene_error(e: durer.SceneError, path: Path, lines: int) -> None:
    assert e.path is not None and Path(e.path).name in (path.name, "cube.obj"), str(e)
    assert e.line is None or 1 <= e.line <= max(lines, 1), str(e)
    assert "\n" not in str(e)


@pytest.mark.slow
@budget(250)
@given(case=mutated_scene())
@example(case=("deep.txt", (EXAMPLES / "spheres.txt").read_text().replace(
    "Group {", "Group { numObjects 1 Group {" * 5000, 1)))                       # issue 25: RecursionError
def test_mutated_course_scenes_load_and_render_or_say_why(tmp_path_factory, case):
    folder = tmp_path_factory.mktemp("scene")
    shutil.copy(EXAMPLES / "cube.obj", folder / "cube.obj")
    path = folder / case[0]
    path.write_text(case[1])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)  # reading a file must not leak NumPy warnings
            scene = durer.load(path)
    except durer.SceneError as e:
        _check_scene_error(e, path, case[1].count("\n") + 1)
        return
    try:
        result = durer.render(scene, 4, 3, shadows=True, bounces=1)
    except ValueError as e:  # a Python-level check of the scene (materials, values)
        assert "\n" not in str(e)
        return
    assert result.color.shape == (3, 4, 3)


@st.composite
def mutated_obj(draw) -> str:
    """The bundled cube.obj with some face indices or coordinates replaced (0, out of range, negative, NaN) and
    lines cut short or doubled."""
    lines = CUBE.splitlines()
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        parts = lines[i].split()
        kind = draw(st.sampled_from(["value", "value", "cut", "double"]))
        if kind == "value" and len(parts) > 1:
            k = draw(st.integers(1, len(parts) - 1))
            parts[k] = draw(st.sampled_from(["0", "-1", "-9", "9", "100", "nan", "inf", "1e308", "x", "1/1/1",
                                             "-0", "3"]))
            lines[i] = " ".join(parts)
        elif kind == "cut":
            lines[i] = " ".join(parts[:draw(st.integers(0, max(0, len(parts) - 1)))])
        else:
            lines.insert(i, lines[i])
    return "\n".join(lines) + "\n"


@budget(300)
@given(text=mutated_obj())
@example(text="v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")                                 # issue 25: accepted
def test_mutated_obj_files_load_or_say_why(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("obj") / "mesh.obj"
    path.write_text(text)
    for load in (durer.load, lambda p: durer.load(_course_scene_naming(p))):  # trimesh, and the course's reader
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", RuntimeWarning)
                scene = load(path)
        except durer.SceneError as e:
            _check_scene_error(e, path, text.count("\n") + 1)
            continue
        except ValueError as e:  # a shape's own check (non-finite vertices) from Python
            assert "\n" not in str(e)
            continue
        meshes = _meshes(scene.group)
        assert meshes
        for m in meshes:
            assert m.faces.min() >= 0 and m.faces.max() < len(m.vertices)


def _course_scene_naming(mesh: Path) -> Path:
    scene = mesh.with_name("scene.txt")
    scene.write_text("OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 3 }\n"
                     "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
                     f"Group {{ numObjects 1 TriangleMesh {{ obj_file {mesh.name} }} }}\n")
    return scene


def _meshes(obj) -> list:
    out, stack = [], [obj]
    while stack:
        o = stack.pop()
        if isinstance(o, durer.Group):
            stack.extend(o.objects)
        elif isinstance(o, durer.Transform):
            stack.append(o.object)
        elif isinstance(o, durer.TriangleMesh):
            out.append(o)
    return out


@budget(200)
@given(faces=st.lists(st.tuples(*[st.integers(-3, 6)] * 3), min_size=1, max_size=4),
       nodes=st.lists(st.lists(st.integers(-1, 4), max_size=3), min_size=1, max_size=4))
@example(faces=[(0, 1, 7)], nodes=[[]])                                                    # issue 25: PLY
@example(faces=[(0, 1, 2)], nodes=[[0]])                                                   # issue 25: glTF cycle
def test_ply_faces_and_gltf_node_graphs_load_or_say_why(tmp_path_factory, faces, nodes):
    from test_project_bad_input import PLY_HEAD, _gltf

    folder = tmp_path_factory.mktemp("model")
    ply = folder / "mesh.ply"
    ply.write_text(PLY_HEAD.replace("element face 1", f"element face {len(faces)}")
                   + "".join(f"3 {a} {b} {c}\n" for a, b, c in faces))
    ok = all(0 <= i < 3 for f in faces for i in f)
    try:
        scene = durer.load(ply)
        assert ok and len(_meshes(scene.group)[0].faces) == len(faces)
    except durer.SceneError as e:
        assert not ok and str(e).startswith(f"{ply}: face "), str(e)
    gltf = _gltf(folder, [{"mesh": 0, "children": kids} for kids in nodes])
    try:
        durer.load(gltf)
    except durer.SceneError as e:
        assert str(e).startswith(f"{gltf}: malformed glTF: node "), str(e)


# --- command lines ----------------------------------------------------------------------------------------------
VALUES = ["0", "1", "2", "4", "-1", "1e9", "nan", "inf", "x", "", "99999999"]
RENDER_FLAGS: dict[str, int] = {"--size": 2, "--samples": 1, "--bounces": 1, "--weight": 1, "--filter": 1,
                                "--seed": 1, "--max-depth": 1, "--depth": 3, "--threads": 1, "--sampler": 1,
                                "--integrator": 1, "--accel": 1, "--camera": 1, "--normals": 1, "--shadows": 0,
                                "--no-shade-back": 0, "--linear": 0, "--mesh-path": 1}
COURSE_FLAGS: dict[str, int] = {"-size": 2, "-bounces": 1, "-weight": 1, "-grid": 3, "-jittered_samples": 1,
                                "-random_samples": 1, "-uniform_samples": 1, "-box_filter": 1, "-tent_filter": 1,
                                "-gaussian_filter": 1, "-render_samples": 2, "-render_filter": 2, "-depth": 3,
                                "-normals": 1, "-shadows": 0, "-shade_back": 0, "-visualize_grid": 0, "-stats": 0,
                                "-threads": 1}
SPECIAL = {"--filter": ["box:inf", "gaussian:200", "tent:0.5", "gaussian", "box:x", "cubic"],
           "--sampler": ["uniform", "random", "jittered", "sobol"], "--integrator": ["path", "whitted", "raycast"],
           "--accel": ["bvh", "brute", "grid"], "--camera": ["0", "top"]}
OUTPUTS = ["o.png", "o.tga", "o.jpg", "o.hdr", "o.npy", "o.webp", "missing/o.png", "o"]


@st.composite
def command_line(draw) -> list[str]:
    """A `durer render` or `durer raycast` command line on the bundled example: some flags, each with values
    drawn from odd ones (or the flag's own choices), and an output whose name may be wrong."""
    course = draw(st.booleans())
    flags = COURSE_FLAGS if course else RENDER_FLAGS
    argv = ["raycast", "-input", "{scene}"] if course else ["render", "{scene}"]
    out = draw(st.sampled_from(OUTPUTS))
    argv += ["-output" if course else "-o", out]
    size = ["-size" if course else "--size", str(draw(st.integers(1, 6))), str(draw(st.integers(1, 6)))]
    argv += size
    for flag in draw(st.lists(st.sampled_from(sorted(flags)), max_size=4)):
        argv.append(flag)
        for _ in range(flags[flag]):
            choices = SPECIAL.get(flag, VALUES + OUTPUTS[:3])
            argv.append(draw(st.sampled_from(choices)))
    if draw(st.booleans()):
        argv += size  # give the size last, so that odd --size values above do not make the render large
    return argv


@budget(300)
@given(argv=command_line())
@example(argv=["render", "{scene}", "-o", "o.png", "--filter", "box:inf"])                 # issue 25
@example(argv=["raycast", "-input", "{scene}", "-size", "4", "4", "-output", "o.tga", "-grid", "1000", "1000",
               "1000"])                                                                    # issue 25
@example(argv=["raycast", "-input", "{scene}", "-size", "4", "4", "-render_samples", "s.tga", "100000"])
@example(argv=["render", "{scene}", "-o", "o.png", "--size", "4", "4", "--depth", "10", "1", "d.png"])
def test_mutated_command_lines_succeed_or_exit_2_with_one_message(tmp_path_factory, monkeypatch, capsys, argv):
    folder = tmp_path_factory.mktemp("cli")
    monkeypatch.chdir(folder)
    shutil.copy(EXAMPLES / "spheres.txt", folder / "spheres.txt")
    shutil.copy(EXAMPLES / "cube.obj", folder / "cube.obj")
    argv = [a.format(scene="spheres.txt") for a in argv]
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # NumPy warnings must not leak onto stderr either
        code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if code == 0:
        return
    assert code == 2, err
    lines = [line for line in err.strip().splitlines() if not line.startswith("durer: compiling")]
    assert lines and len(lines) <= 2, err  # the usage line and the message, or the message alone
    assert not any(p.name.startswith(".durer-") for p in folder.iterdir())  # no temporary file left behind


def test_profiles_are_registered():
    assert settings.get_profile("fuzz").max_examples >= 1000
    assert settings.get_profile("ci").derandomize
    assert np.isfinite(settings.get_profile("fuzz").max_examples)
