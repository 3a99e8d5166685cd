"""The course scene parser: what it builds, and every error path as `file:line: message`."""

from __future__ import annotations

import numpy as np
import pytest

from durer import OrthographicCamera, PerspectiveCamera, PhongMaterial, SceneError, Sphere, Transform, load
from durer.scene.textures import Marble

GOOD = """\
PerspectiveCamera {
    center 0 0 10
    direction 0 0 -1
    up 0 1 0
    angle 30
}
Lights {
    numLights 1
    DirectionalLight { direction 0 0 -1 color 1 1 1 }
}
Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }
Materials {
    numMaterials 2
    Material { diffuseColor 1 0 0 }
    PhongMaterial { diffuseColor 0 1 0 specularColor 1 1 1 exponent 20 }
}
Group {
    numObjects 2
    MaterialIndex 1
    Sphere { center 0 0 0 radius 1 }
    Transform {
        Translate 1 0 0
        Group {
            numObjects 1
            Plane { normal 0 1 0 offset -1 }
        }
    }
}
"""


def write(tmp_path, text, name="scene.txt"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_good_scene(tmp_path):
    s = load(write(tmp_path, GOOD))
    assert isinstance(s.camera, PerspectiveCamera) and s.camera.angle == 30
    np.testing.assert_allclose(s.background_color, [0.1, 0.2, 0.3])
    np.testing.assert_allclose(s.ambient_light, [0.2, 0.2, 0.2])
    assert len(s.lights) == 1 and len(s.materials) == 2
    assert isinstance(s.materials[1], PhongMaterial) and s.materials[1].exponent == 20
    sphere, transform = s.group.objects
    assert isinstance(sphere, Sphere) and sphere.material == 1
    assert isinstance(transform, Transform)
    # MaterialIndex carries into nested groups, as the course's parser does
    assert transform.object.objects[0].material == 1


def test_no_lights_block_means_flat_shading(tmp_path):
    text = GOOD.replace("""Lights {
    numLights 1
    DirectionalLight { direction 0 0 -1 color 1 1 1 }
}
""", "")
    assert load(write(tmp_path, text)).lights is None


def test_crlf_and_one_line_blocks(tmp_path):
    s = load(write(tmp_path, GOOD.replace("\n", "\r\n")))
    assert len(s.group.objects) == 2


def test_texture_material_with_transform(tmp_path):
    text = GOOD.replace("numMaterials 2", "numMaterials 3").replace(
        "    PhongMaterial { diffuseColor 0 1 0 specularColor 1 1 1 exponent 20 }\n",
        "    PhongMaterial { diffuseColor 0 1 0 specularColor 1 1 1 exponent 20 }\n"
        "    Marble { Transform { UniformScale 2 } materialIndex 0 materialIndex 1 octaves 3 frequency 2 amplitude 4 }\n")
    m = load(write(tmp_path, text)).materials[2]
    assert isinstance(m, Marble) and (m.material1, m.material2, m.octaves) == (0, 1, 3)
    np.testing.assert_allclose(np.diag(m.matrix), [2, 2, 2, 1])


def test_orthographic_camera(tmp_path):
    text = GOOD.replace("PerspectiveCamera", "OrthographicCamera").replace("angle 30", "size 5")
    cam = load(write(tmp_path, text)).camera
    assert isinstance(cam, OrthographicCamera) and cam.size == 5


def find(needle: str, text: str = GOOD) -> int:
    """1-based number of the first line of `text` containing `needle`."""
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


# (description, replace this, with that, expected line (by the text on it, or a number), message fragment)
ERRORS = [
    ("unknown top-level keyword", "Background {", "Backgroud {", "Backgroud", "unknown keyword 'Backgroud'"),
    ("unknown object keyword", "Sphere {", "Spere {", "Spere", "unknown keyword 'Spere'"),
    ("misspelt field", "radius 1", "radious 1", "radious", "unknown field 'radious' in Sphere"),
    ("missing field", "radius 1 ", " ", "Sphere {", "Sphere is missing 'radius'"),
    ("field given twice", "radius 1", "radius 1 radius 2", "radius", "given twice"),
    ("not a number", "radius 1", "radius one", "radius", "expected a number for radius, got 'one'"),
    ("not an integer count", "numObjects 2", "numObjects two", "numObjects", "expected an integer for numObjects"),
    ("too few objects", "numObjects 2", "numObjects 3", "Group {", "declares numObjects 3 but has 2"),
    ("too many objects", "numObjects 2", "numObjects 1", "Transform {", "declares numObjects 1 but has more"),
    ("too few materials", "numMaterials 2", "numMaterials 3", "Materials {", "declares numMaterials 3 but has 2"),
    ("too many lights", "numLights 1", "numLights 0", "DirectionalLight", "declares numLights 0 but has more"),
    ("material index out of range", "MaterialIndex 1", "MaterialIndex 2", "MaterialIndex", "MaterialIndex 2 out of range"),
    ("negative radius", "radius 1", "radius -1", "radius", "radius must be positive"),
    ("zero radius", "radius 1", "radius 0", "radius", "radius must be positive"),
    ("zero direction", "direction 0 0 -1\n    up", "direction 0 0 0\n    up", "direction 0 0", "zero length"),
    ("up parallel to direction", "up 0 1 0", "up 0 0 2", "up 0", "parallel"),
    ("bad camera angle", "angle 30", "angle 0", "angle", "angle"),
    ("zero plane normal", "normal 0 1 0", "normal 0 0 0", "normal", "plane normal has zero length"),
    ("zero light direction", "direction 0 0 -1 color", "direction 0 0 0 color", "DirectionalLight", "zero length"),
    ("unknown transformation", "Translate 1 0 0", "Translat 1 0 0", "Translat", "unknown keyword 'Translat' in Transform"),
    ("singular transform", "Translate 1 0 0", "Scale 1 0 1", "Scale 1 0 1", "singular"),
    ("second camera", "Background {", "OrthographicCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 size 1 }\nBackground {",
     "OrthographicCamera", "second camera block"),
    ("brace expected", "Sphere {", "Sphere", "Sphere", "expected '{' after Sphere"),
]


@pytest.mark.parametrize("desc, old, new, where, message", ERRORS, ids=[e[0] for e in ERRORS])
def test_error_paths(tmp_path, desc, old, new, where, message):
    assert old in GOOD
    text = GOOD.replace(old, new, 1)
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as e:
        load(path)
    err = e.value
    assert message in err.message
    assert err.path == str(path)
    expected_line = find(where, text)
    assert err.line == expected_line, str(err)
    assert str(err).startswith(f"{path}:{expected_line}: ")


def test_unbalanced_braces_at_end_of_file(tmp_path):
    path = write(tmp_path, GOOD.rstrip().rstrip("}"))
    with pytest.raises(SceneError, match=r"unexpected end of file: 'Group \{' opened at line \d+ is not closed"):
        load(path)


def test_extra_closing_brace(tmp_path):
    path = write(tmp_path, GOOD + "}\n")
    with pytest.raises(SceneError, match=r"unexpected '\}'") as e:
        load(path)
    assert e.value.line == len(GOOD.splitlines()) + 1


def test_no_camera_and_no_group(tmp_path):
    with pytest.raises(SceneError, match="no camera"):
        load(write(tmp_path, GOOD.split("Lights {")[0].replace("PerspectiveCamera", "Lights") and
                   "Background { color 0 0 0 }\nGroup { numObjects 0 }\n"))
    with pytest.raises(SceneError, match="no Group"):
        load(write(tmp_path, GOOD.split("Group {")[0]))


def test_missing_scene_file(tmp_path):
    with pytest.raises(SceneError, match="cannot read scene file") as e:
        load(tmp_path / "nope.txt")
    assert e.value.line is None


def test_missing_mesh_file(tmp_path):
    path = write(tmp_path, GOOD.replace("Sphere { center 0 0 0 radius 1 }", "TriangleMesh { obj_file nope.obj }"))
    with pytest.raises(SceneError, match="mesh file 'nope.obj' not found") as e:
        load(path)
    assert e.value.line == find("Sphere {")


def test_mesh_found_next_to_the_scene_then_on_the_mesh_path(tmp_path, monkeypatch):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    text = GOOD.replace("Sphere { center 0 0 0 radius 1 }", "TriangleMesh { obj_file tri.obj }")
    s = load(write(tmp_path, text))
    assert s.group.objects[0].faces.tolist() == [[0, 1, 2]]
    other = tmp_path / "elsewhere"
    other.mkdir()
    monkeypatch.chdir(other)
    (other / "scene.txt").write_text(text)
    with pytest.raises(SceneError):
        load(other / "scene.txt", mesh_path=[])
    assert load(other / "scene.txt", mesh_path=[str(tmp_path)]).group.objects[0].faces.shape == (1, 3)


def test_bad_face_index_in_mesh(tmp_path):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 4\n")
    path = write(tmp_path, GOOD.replace("Sphere { center 0 0 0 radius 1 }", "TriangleMesh { obj_file bad.obj }"))
    with pytest.raises(SceneError) as e:
        load(path)
    assert str(e.value) == f"{tmp_path / 'bad.obj'}:5: face index 4 out of range (the file has 3 vertices before this line)"


def test_texture_cycle_and_range(tmp_path):
    text = GOOD.replace("numMaterials 2", "numMaterials 3").replace(
        "    Material { diffuseColor 1 0 0 }\n",
        "    Material { diffuseColor 1 0 0 }\n    Checkerboard { materialIndex 1 materialIndex 0 }\n").replace(
        "    PhongMaterial { diffuseColor 0 1 0 specularColor 1 1 1 exponent 20 }\n",
        "    Noise { materialIndex 0 materialIndex 1 octaves 2 }\n")
    with pytest.raises(SceneError, match="cycle"):
        load(write(tmp_path, text))
    text2 = GOOD.replace("    Material { diffuseColor 1 0 0 }\n",
                         "    Checkerboard { materialIndex 0 materialIndex 7 }\n")
    with pytest.raises(SceneError, match="materialIndex 7 out of range"):
        load(write(tmp_path, text2))
