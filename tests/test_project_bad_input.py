"""Issue 25's bad inputs, each pinned: one clear error (`FILE:LINE:` for files, exit status 2 from the CLI, a
SceneError or ValueError from Python), never a traceback, a hang or an allocation the machine cannot make."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.cli import main
from durer.scene.validate import MAX_NESTING, check_scene

HEADER = """PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }
Background { color 0 0 0 }
Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }
"""
SPHERE = "Sphere { center 0 0 0 radius 1 }"


def run(capsys, *argv: str) -> tuple[int, str]:
    """Exit status and stderr of `durer ARGV` run in this process."""
    code = main([str(a) for a in argv])
    return code, capsys.readouterr().err


def one_line_error(code: int, err: str) -> str:
    """The CLI's error, asserted to be exit status 2 with no traceback; returns the last line."""
    assert code == 2, err
    assert "Traceback" not in err, err
    return err.strip().splitlines()[-1]


# --- nesting and cycles ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("levels, opening", [
    (5000, "Group {{ numObjects 1 "),                       # issue 25: RecursionError at io/course.py:64
    (3000, "Transform {{ Translate 0 0 0 "),                # ... and :70
])
def test_deep_nesting_in_a_course_scene_is_a_scene_error(tmp_path, capsys, levels, opening):
    body = "Group { numObjects 1 " + opening.format() * levels + SPHERE + " }" * levels + " }"
    path = tmp_path / "deep.txt"
    path.write_text(HEADER + body)
    with pytest.raises(durer.SceneError, match=f"nested more than {MAX_NESTING} levels deep") as e:
        durer.load(path)
    assert e.value.line == 4 and e.value.path == str(path)
    line = one_line_error(*run(capsys, "render", path, "-o", tmp_path / "o.png", "--size", 8, 8, "-q"))
    assert line.startswith(f"{path}:4: ")
    assert not (tmp_path / "o.png").exists()


def test_nesting_up_to_the_limit_renders(tmp_path):
    body = "Group { numObjects 1 " * MAX_NESTING + SPHERE + " }" * MAX_NESTING
    path = tmp_path / "deep.txt"
    path.write_text(HEADER + body)
    result = durer.render(durer.load(path), 8, 8)
    assert np.isfinite(result.depth[4, 4]) and result.color[4, 4, 0] > 0


def test_a_chain_of_thousands_of_textures_is_walked_without_recursion(tmp_path):
    n = 3000  # texture k blends k + 1 and the last Phong material: the old recursive check overflowed
    mats = "".join(f"Checkerboard {{ materialIndex {k + 1} materialIndex {n} }}\n" for k in range(n))
    text = HEADER.replace("Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }",
                          f"Materials {{ numMaterials {n + 1}\n{mats}PhongMaterial {{ diffuseColor 1 0 0 }} }}")
    path = tmp_path / "chain.txt"
    path.write_text(text + f"Group {{ numObjects 1 {SPHERE} }}")
    assert len(durer.load(path).materials) == n + 1
    cyclic = text.replace(f"Checkerboard {{ materialIndex {n} materialIndex {n} }}",
                          f"Checkerboard {{ materialIndex 0 materialIndex {n} }}")
    path.write_text(cyclic + f"Group {{ numObjects 1 {SPHERE} }}")
    with pytest.raises(durer.SceneError, match="blends itself"):
        durer.load(path)


def _python_scene(group: durer.Group) -> durer.Scene:
    return durer.Scene(camera=durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 40), group=group)


def test_a_group_that_contains_itself_is_a_value_error():
    inner = durer.Group([durer.Sphere((0, 0, 0), 1, material=0)])
    outer = durer.Group([inner, durer.Transform(np.eye(4), inner)])  # shared, not a cycle: fine
    check_scene(_python_scene(outer))
    inner.objects.append(outer)
    with pytest.raises(ValueError, match=r"scene.group.objects\[0\].objects\[1\]: a Group that contains itself"):
        durer.render(_python_scene(outer), 8, 8)


def test_deep_nesting_from_python_is_a_value_error():
    obj: object = durer.Sphere((0, 0, 0), 1, material=0)
    for _ in range(5000):
        obj = durer.Group([durer.Transform(np.eye(4), obj)])
    with pytest.raises(ValueError, match=f"nested more than {MAX_NESTING} levels deep"):
        durer.render(_python_scene(obj), 8, 8)


# --- sizes and values checked before work starts -------------------------------------------------------------
EXAMPLE = str(__import__("pathlib").Path(__file__).resolve().parents[1] / "examples" / "spheres.txt")


@pytest.fixture
def no_render(monkeypatch):
    """Fail the test if a render starts: these mistakes must be caught before it."""
    import durer.rendering.renderer as renderer

    def refuse(*args, **kwargs):
        raise AssertionError("rendered before the mistake was reported")

    monkeypatch.setattr(renderer, "render", refuse)
    monkeypatch.setattr(renderer, "make_context", refuse)


@pytest.mark.parametrize("argv, message", [
    (["render", EXAMPLE, "-o", "{tmp}/o.png", "--filter", "box:inf"],               # issue 25: OverflowError
     "box filter radius inf is too wide: at most 16 pixels"),
    (["render", EXAMPLE, "-o", "{tmp}/o.png", "--filter", "gaussian:200", "--integrator", "path"],  # ran > 60 s
     "gaussian filter sigma 200 is too wide: at most 8 pixels"),
    (["render", EXAMPLE, "-o", "{tmp}/o.png", "--filter", "tent:nan"], "--filter: the width must be positive"),
    (["raycast", "-input", EXAMPLE, "-size", "32", "32", "-output", "{tmp}/o.png", "-gaussian_filter", "9"],
     "gaussian filter sigma 9 is too wide"),
    (["raycast", "-input", EXAMPLE, "-size", "32", "32", "-output", "{tmp}/o.png", "-grid", "1000", "1000", "1000"],
     "grid 1000 x 1000 x 1000 has 1,000,000,000 cells: at most 16,777,216"),   # issue 25: 16.7 GB in 40 s
    (["raycast", "-input", EXAMPLE, "-size", "32", "32", "-render_samples", "{tmp}/s.png", "100000"],  # 14 TiB
     "-render_samples ZOOM: a 32x32 image zoomed 100000 times would be 3200000x3200000 pixels; at most 16384"),
    (["raycast", "-input", EXAMPLE, "-size", "32", "32", "-render_filter", "{tmp}/s.png", "600"],
     "-render_filter ZOOM: a 32x32 image zoomed 600 times"),
    (["render", EXAMPLE, "-o", "{tmp}/o.png", "--depth", "10", "1", "{tmp}/d.png"],    # issue 25: near > far
     "--depth: NEAR (10) must be less than FAR (1)"),
    (["raycast", "-input", EXAMPLE, "-size", "8", "8", "-depth", "3", "3", "{tmp}/d.png"],
     "-depth: NEAR (3) must be less than FAR (3)"),
    (["render", EXAMPLE, "-o", "{tmp}/o.png", "--size", "200000", "200000"], "would need about"),
    (["raycast", "-input", EXAMPLE, "-size", "200000", "200000", "-output", "{tmp}/o.tga"], "would need about"),
    (["raycast", "-input", EXAMPLE, "-size", "20000", "20", "-render_filter", "{tmp}/s.png", "1"],
     "would be 20000x20 pixels; at most 16384 a side (use a smaller -size)"),
])
def test_sizes_and_values_are_checked_before_rendering(tmp_path, capsys, no_render, argv, message):
    line = one_line_error(*run(capsys, *(a.format(tmp=tmp_path) for a in argv)))
    assert message in line
    assert not list(tmp_path.iterdir())


def test_python_api_checks_the_same_sizes():
    scene = durer.load(EXAMPLE)
    with pytest.raises(ValueError, match="gaussian filter sigma 200 is too wide"):
        durer.render(scene, 32, 32, filter="gaussian:200", integrator="path")
    with pytest.raises(ValueError, match="grid 1000 x 1000 x 1000 has 1,000,000,000 cells"):
        durer.render(scene, 32, 32, grid=(1000, 1000, 1000))
    from durer.accel.compile import compile_scene
    from durer.accel.grid import GridAccelerator

    with pytest.raises(ValueError, match="at most 16,777,216"):
        GridAccelerator(compile_scene(scene), (4096, 4096, 2))


def test_widest_filter_allowed_renders(tmp_path):
    result = durer.render(durer.load(EXAMPLE), 8, 8, samples=4, filter="gaussian:8")
    assert result.color.shape == (8, 8, 3) and np.isfinite(result.color).all()


def test_exr_without_openexr_is_refused_before_rendering(tmp_path, capsys, monkeypatch, no_render):
    monkeypatch.setitem(__import__("sys").modules, "OpenEXR", None)  # `import OpenEXR` now raises ImportError
    line = one_line_error(*run(capsys, "render", EXAMPLE, "-o", tmp_path / "out.exr"))
    assert "writing .exr needs the openexr package" in line
    line = one_line_error(*run(capsys, "render", EXAMPLE, "-o", tmp_path / "o.png", "--normals", tmp_path / "n.exr"))
    assert "openexr" in line
    assert not list(tmp_path.iterdir())


# --- malformed mesh data that trimesh lets through ------------------------------------------------------------
PLY_HEAD = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n")


@pytest.mark.parametrize("text, message", [
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", ":4: face index 0 out of range"),       # issue 25: rendered
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n", ":5: face index 9 out of range"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\n  f 1 2 -4\n", ":4: face index -4 out of range"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", ":4: face index is not an integer: 'x'"),
])
def test_obj_face_indices_are_checked(tmp_path, capsys, text, message):
    path = tmp_path / "bad.obj"
    path.write_text(text)
    with pytest.raises(durer.SceneError, match=message.split(": ", 1)[1]):
        durer.load(path)
    line = one_line_error(*run(capsys, "render", path, "-o", tmp_path / "o.png", "-q"))
    assert line.startswith(f"{path}{message}")


def test_obj_faces_may_name_vertices_given_later_and_count_back(tmp_path):
    path = tmp_path / "ok.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\nf -3 -2 -1\n")
    assert len(durer.load(path).group.objects[0].faces) == 2


def test_ply_faces_out_of_range_are_a_scene_error(tmp_path, capsys):
    path = tmp_path / "bad.ply"
    path.write_text(PLY_HEAD + "3 0 1 7\n")                                          # issue 25: accepted
    message = "face 0 uses vertices [0, 1, 7], but the mesh has 3 vertices (0..2)"
    line = one_line_error(*run(capsys, "render", path, "-o", tmp_path / "o.png", "-q"))
    assert line == f"{path}: {message}"
    scene = tmp_path / "scene.txt"  # the same mesh named by a course scene
    scene.write_text(HEADER + "Group { numObjects 1 TriangleMesh { obj_file bad.ply } }\n")
    with pytest.raises(durer.SceneError, match=r"face 0 uses vertices \[0, 1, 7\]"):
        durer.load(scene)
    ok = tmp_path / "ok.ply"
    ok.write_text(PLY_HEAD + "3 0 1 2\n")
    assert len(durer.load(ok).group.objects[0].faces) == 1


def _gltf(tmp_path, nodes: list[dict]) -> str:
    """A glTF file of one triangle (embedded buffer) drawn by node 0, with the given node list."""
    import base64
    import json

    data = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0], np.float32).tobytes() + np.array([0, 1, 2], np.uint16).tobytes()
    gltf = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": nodes,
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
            "buffers": [{"byteLength": len(data),
                         "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
            "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                            {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 1, 0]},
                          {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]}
    path = tmp_path / "model.gltf"
    path.write_text(json.dumps(gltf))
    return str(path)


@pytest.mark.parametrize("nodes, message", [
    ([{"mesh": 0, "children": [0]}], "node 0 is its own child: the node hierarchy has a cycle"),  # issue 25
    ([{"mesh": 0, "children": [1]}, {"children": [2]}, {"children": [0]}],
     "node 0 is a descendant of its child (via node 2): the node hierarchy has a cycle"),
    ([{"mesh": 0, "children": [5]}], "node 0 has child 5, but the file has 1 nodes"),
    ([{"mesh": 0, "children": "1"}], "node 0's children are not a list of node indices"),
])
def test_gltf_node_cycles_are_a_scene_error(tmp_path, capsys, nodes, message):
    path = _gltf(tmp_path, nodes)
    line = one_line_error(*run(capsys, "render", path, "-o", tmp_path / "o.png", "-q"))
    assert line == f"{path}: malformed glTF: {message}"


def test_a_gltf_tree_loads(tmp_path):
    path = _gltf(tmp_path, [{"mesh": 0, "children": [1, 2]}, {"mesh": 0}, {"children": [3]}, {"mesh": 0}])
    assert len(durer.load(path).group.objects) == 3


# --- values that made NumPy warn on stderr --------------------------------------------------------------------
def test_a_negative_phong_exponent_is_refused(tmp_path, capsys):
    path = tmp_path / "neg.txt"
    path.write_text(HEADER.replace("diffuseColor 1 0 0", "diffuseColor 1 0 0\nexponent -5") + f"Group {{ numObjects 1 {SPHERE} }}")
    line = one_line_error(*run(capsys, "render", path, "-o", tmp_path / "o.png", "--shadows"))
    assert line == f"{path}:4: exponent must not be negative, got -5"
    with pytest.raises(ValueError, match="PhongMaterial exponent must be finite and not negative, got -5"):
        durer.PhongMaterial(exponent=-5)


def test_a_sphere_scaled_past_float_range_renders_without_warnings(tmp_path):
    path = tmp_path / "huge.txt"
    path.write_text(HEADER + "Group { numObjects 1 Transform { Scale 1e200 1 1 " + SPHERE + " } }")
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error", RuntimeWarning)
        result = durer.render(durer.load(path), 8, 8)
    assert np.isfinite(result.depth).any()


@pytest.mark.parametrize("old, new", [
    ("direction 0 -0.28 -1", "direction 1e308 -0.28 -1"),       # camera direction: norm overflowed in cameras.py
    ("up 0 1 0", "up 0 1e308 0"),
    ("direction 0.6 -1 -0.4", "direction 1e308 -1 -0.4"),      # a light's direction
    ("normal 0 1 0", "normal 0 1e308 0"),                      # a plane's normal (course.py's zero check)
    ("direction 0 -0.28 -1", "direction 0 -1e-320 -5e-321"),       # subnormal: still a direction
])
def test_huge_and_tiny_directions_load_without_warnings(tmp_path, old, new):
    text = open(EXAMPLE).read()
    assert old in text
    path = tmp_path / "scene.txt"
    path.write_text(text.replace(old, new, 1))
    (tmp_path / "cube.obj").write_text(open(EXAMPLE.replace("spheres.txt", "cube.obj")).read())
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error", RuntimeWarning)
        scene = durer.load(path)
        durer.render(scene, 4, 3, shadows=True)
    direction = scene.camera.direction
    assert np.isclose(np.linalg.norm(direction), 1.0)


@pytest.mark.parametrize("vertex, message", [("v 1e308 0 0", "the model's coordinates overflow"),
                                             ("v nan 0 0", "vertex 1 is not finite: [nan, 0.0, 0.0]")])
def test_model_vertices_out_of_float_range_are_a_scene_error(tmp_path, capsys, vertex, message):
    path = tmp_path / "big.obj"
    path.write_text(f"v 0 0 0\n{vertex}\nv 0 1e308 0\nf 1 2 3\n")
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error", RuntimeWarning)
        line = one_line_error(*run(capsys, "render", path, "-o", tmp_path / "o.png", "--size", 4, 4))
    assert line.startswith(f"{path}: {message}")


def test_the_missing_mesh_hint_names_a_flag_every_command_takes(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv("DURER_MESH_PATH", raising=False)
    meshes = tmp_path / "meshes"
    meshes.mkdir()
    (meshes / "cube.obj").write_text(open(EXAMPLE.replace("spheres.txt", "cube.obj")).read())
    scene = tmp_path / "scene.txt"
    scene.write_text(HEADER + "Group { numObjects 1 TriangleMesh { obj_file cube.obj } }\n")
    line = one_line_error(*run(capsys, "raycast", "-input", scene, "-size", 8, 8, "-output", tmp_path / "o.tga"))
    assert line.startswith(f"{scene}:4: mesh file 'cube.obj' not found") and "--mesh-path DIR" in line
    for argv in (["raycast", "-input", scene, "-size", 8, 8, "-output", tmp_path / "o.tga", "--mesh-path", meshes],
                 ["render", scene, "-o", tmp_path / "o.png", "--size", 8, 8, "--mesh-path", meshes, "-q"],
                 ["explain", scene, "--pixel", 4, 4, "--size", 8, 8, "--mesh-path", meshes]):
        code, err = run(capsys, *argv)
        assert code == 0, err


def test_radiance_beyond_float32_is_inf_without_a_warning(tmp_path):
    path = tmp_path / "bright.txt"
    path.write_text(HEADER + "Lights { numLights 1 PointLight { position 0 0 5 color 1 1 1 attenuation 0 0 1e-300 } }\n"
                    + f"Group {{ numObjects 1 {SPHERE} }}")
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error", RuntimeWarning)
        result = durer.render(durer.load(path), 8, 8)
    assert np.isinf(result.color[4, 4, 0]) and result.color.dtype == np.float32


# --- the query API (issue 25: Python calls that ended in NumPy's or trimesh's exceptions, or were accepted) ------
@pytest.mark.parametrize("call, message", [
    (lambda S: S.create_rays_pinhole(fov_deg=60, center=(0, 0, 0), eye=(0, 0, 5), up=(0, 1, 0), width_px=100000,
                                     height_px=100000), r"100000 x 100000 rays would take 240.0 GB"),
    (lambda S: S.create_rays_pinhole(fov_deg=60, center=(0, 0, 0), eye=(0, 0, 5), up=(0, 1, 0), width_px=2.7,
                                     height_px=3), r"width_px must be a positive whole number of pixels, got 2.7"),
    (lambda S: S().add_mesh("/etc/passwd"), r"cannot read mesh file '/etc/passwd'"),
    (lambda S: S().add_sphere((0, 0, 0), [1, 2]), r"radius must be one positive number, got \[1, 2\]"),
    (lambda S: S().test_occlusions(np.zeros((2, 6), np.float32), 2.0, 1.0), r"the t range is empty: t_min 2.0 > t_max 1.0"),
    (lambda S: S().compute_occupancy(np.zeros((2, 3)), nsamples=0, method="parity"), r"nsamples must be at least 1"),
])
def test_query_api_mistakes_are_one_clear_value_error(call, message):
    import durer

    with pytest.raises(ValueError, match=message):
        call(durer.RaycastingScene)
