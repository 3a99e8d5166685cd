"""io/models.py and io/gltf_extras.py: model files (glTF/GLB, PLY, STL, OBJ, OFF) as durer scenes, rendered."""

from __future__ import annotations

import base64
import json
import struct

import numpy as np
import pytest
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial as TrimeshPBR

import durer
from durer.errors import SceneError
from durer.io.gltf_extras import node_world_matrices, read_gltf_json
from durer.io.models import DEFAULT_SKY, FILE_AMBIENT, srgb_to_linear

RED = (0.8, 0.2, 0.1)
GREEN = (0.1, 0.7, 0.2)


def _geometry() -> tuple[bytes, list, list]:
    """Two quads: a front one in z = 0 facing +z (material 0) and a floor at y = -1 facing +y (material 1).
    Returns the binary buffer, its accessors and its buffer views."""
    front = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
    floor = np.array([[-1, -1, 1], [1, -1, 1], [1, -1, -1], [-1, -1, -1]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint16)
    chunks, views, accessors = b"", [], []
    for pos in (front, floor):
        for data, target in ((idx.tobytes() + b"\0\0", 34963), (pos.tobytes(), 34962)):
            views.append({"buffer": 0, "byteOffset": len(chunks), "byteLength": len(data), "target": target})
            chunks += data
        accessors.append({"bufferView": len(views) - 2, "componentType": 5123, "count": 6, "type": "SCALAR"})
        accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": 4, "type": "VEC3",
                          "min": pos.min(axis=0).tolist(), "max": pos.max(axis=0).tolist()})
    return chunks, accessors, views


def hand_written_gltf() -> tuple[dict, bytes]:
    """A glTF with two cameras (a perspective 'Front' and an orthographic 'Top' under a parent node) and three
    KHR_lights_punctual lights: a directional 'sun' along -z, a 'lamp' point light behind the front quad and a
    'spot' at z = 3 pointing away from it, so that only the sun lights the front quad's centre."""
    data, accessors, views = _geometry()
    s = np.sqrt(0.5)
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 4, 5, 6]}],
        "nodes": [
            {"name": "quads", "mesh": 0},
            {"name": "front-camera", "camera": 0, "translation": [0, 0, 4]},
            {"name": "rig", "translation": [0, 2, 0], "children": [3]},
            {"name": "top-camera", "camera": 1, "translation": [0, 3, 0], "rotation": [-s, 0, 0, s]},
            {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "lamp", "translation": [0, 0, -3], "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "spot", "translation": [0, 0, 3], "rotation": [0, 1, 0, 0],
             "extensions": {"KHR_lights_punctual": {"light": 2}}},
        ],
        "cameras": [
            {"name": "Front", "type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.0, "znear": 0.1}},
            {"name": "Top", "type": "orthographic",
             "orthographic": {"xmag": 1.5, "ymag": 1.0, "znear": 0.1, "zfar": 100}},
        ],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "sun", "type": "directional", "color": [1, 1, 1], "intensity": np.pi},
            {"name": "lamp", "type": "point", "color": [1, 0.5, 0.25], "intensity": 10},
            {"name": "spot", "type": "spot", "color": [1, 1, 1], "intensity": 5,
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
        ]}},
        "materials": [
            {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [*RED, 1], "metallicFactor": 0.0}},
            {"name": "green", "pbrMetallicRoughness": {"baseColorFactor": [*GREEN, 1], "metallicFactor": 0.0}},
        ],
        "meshes": [{"name": "quads", "primitives": [
            {"attributes": {"POSITION": 1}, "indices": 0, "material": 0},
            {"attributes": {"POSITION": 3}, "indices": 2, "material": 1},
        ]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(data)}],
    }
    return gltf, data


def write_gltf(path, gltf: dict, data: bytes) -> None:
    gltf = json.loads(json.dumps(gltf))
    gltf["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(data).decode()
    path.write_text(json.dumps(gltf, indent=1))


def write_glb(path, gltf: dict, data: bytes) -> None:
    text = json.dumps(gltf).encode()
    text += b" " * (-len(text) % 4)
    data += b"\0" * (-len(data) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(data), b"BIN\0") + data
    path.write_bytes(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


@pytest.fixture(params=["gltf", "glb"])
def model(tmp_path, request):
    gltf, data = hand_written_gltf()
    path = tmp_path / f"quads.{request.param}"
    (write_gltf if request.param == "gltf" else write_glb)(path, gltf, data)
    return path


def test_json_of_gltf_and_glb_agree(tmp_path):
    gltf, data = hand_written_gltf()
    write_gltf(tmp_path / "a.gltf", gltf, data)
    write_glb(tmp_path / "a.glb", gltf, data)
    a, b = read_gltf_json(str(tmp_path / "a.gltf")), read_gltf_json(str(tmp_path / "a.glb"))
    assert a["cameras"] == b["cameras"] == gltf["cameras"]


def test_node_hierarchy_composes_transforms():
    gltf, _ = hand_written_gltf()
    world = dict(node_world_matrices(gltf))
    assert np.allclose(world[3][:3, 3], [0, 5, 0])  # child of a node at y = 2, itself at y = 3
    assert np.allclose(world[3][:3, :3] @ [0, 0, -1], [0, -1, 0])  # -90 degrees about x: looks down


def test_cameras_from_the_json(model):
    scene = durer.load(model)
    cam = scene.camera  # the first by default
    assert isinstance(cam, durer.PerspectiveCamera)
    assert np.allclose(cam.center, [0, 0, 4]) and np.allclose(cam.direction, [0, 0, -1])
    assert cam.angle == pytest.approx(np.degrees(0.8))  # aspect 1: yfov spans either side
    for which in ("Top", 1, "1"):
        top = durer.load(model, camera=which).camera
        assert isinstance(top, durer.OrthographicCamera)
        assert np.allclose(top.center, [0, 5, 0]) and np.allclose(top.direction, [0, -1, 0])
        assert np.allclose(top.up, [0, 0, -1]) and top.size == pytest.approx(3.0)  # 2 * max(xmag, ymag)


def test_unknown_camera_lists_the_cameras(model):
    with pytest.raises(SceneError, match=r"no camera 'Side' in the model \(its cameras: 0 \('Front'\), 1 \('Top'\)\)"):
        durer.load(model, camera="Side")


def test_lights_from_the_json(model):
    scene = durer.load(model)
    sun, lamp, spot = scene.lights
    assert isinstance(sun, durer.DirectionalLight) and np.allclose(sun.direction, [0, 0, -1])
    assert np.allclose(sun.color, [1, 1, 1])  # intensity pi / pi
    assert isinstance(lamp, durer.PointLight) and np.allclose(lamp.position, [0, 0, -3])
    assert np.allclose(lamp.color, np.array([1, 0.5, 0.25]) * 10 / np.pi) and lamp.attenuation == (0, 0, 1)
    assert isinstance(spot, durer.SpotLight) and np.allclose(spot.direction, [0, 0, 1])
    assert spot.inner_angle == pytest.approx(np.degrees(0.2)) and spot.outer_angle == pytest.approx(np.degrees(0.5))
    assert np.allclose(scene.ambient_light, FILE_AMBIENT)


def test_render_through_each_camera_with_the_materials_colours(model):
    scene = durer.load(model)
    r = durer.render(scene, 9, 9)
    # the centre ray runs along -z onto the front quad at t = 4; only the sun lights it there (the lamp is behind,
    # the spot points away): ambient * kd + kd * N.L + ks * N.H^e with N.L = N.H = 1, roughness 1 -> exponent 1,
    # ks = 0.04 * (1 + 8) / 8; trimesh keeps baseColorFactor as 8-bit (linear) values, hence the rounding
    assert r.depth[4, 4] == pytest.approx(4.0)
    expected = np.round(np.array(RED) * 255) / 255 * (1 + FILE_AMBIENT[0]) + 0.04 * 9 / 8
    assert np.allclose(r.color[4, 4], expected, atol=1e-5)

    top = durer.render(durer.load(model, camera="Top"), 8, 8)
    # from y = 5 straight down (image up = -z): the floor at y = -1, green, t = 6; the front quad is edge-on
    assert top.depth[5, 3] == pytest.approx(6.0)
    g = top.color[5, 3]
    assert g[1] > 2 * g[0] and g[1] > 2 * g[2]


def _exported(tmp_path, name: str, mesh: trimesh.Trimesh, transform=None) -> str:
    """The mesh written by trimesh's exporter (in a scene with a node transform, if given)."""
    path = tmp_path / name
    if transform is None:
        mesh.export(path)
    else:
        scene = trimesh.Scene()
        scene.add_geometry(mesh, node_name="model", transform=transform)
        scene.export(path)
    return str(path)


def test_trimesh_export_materials_and_node_transform(tmp_path):
    box = trimesh.creation.box(extents=(1, 1, 1))
    box.visual = trimesh.visual.TextureVisuals(material=TrimeshPBR(baseColorFactor=[0.2, 0.4, 0.8, 1.0],
                                                                   metallicFactor=0.0, roughnessFactor=0.5,
                                                                   emissiveFactor=[0.1, 0.0, 0.0]))
    path = _exported(tmp_path, "box.glb", box, trimesh.transformations.translation_matrix([5, 0, 0]))
    scene = durer.load(path)
    (mat,) = scene.materials
    assert isinstance(mat, durer.PBRMaterial)
    assert np.allclose(mat.base_color, [0.2, 0.4, 0.8], atol=1 / 255)  # linear factor, as stored
    assert mat.metallic == 0 and mat.roughness == 0.5 and np.allclose(mat.emission, [0.1, 0, 0])
    assert np.allclose(mat.diffuse_color, mat.base_color)  # a dielectric keeps its colour as diffuse
    (node,) = scene.group.objects
    assert isinstance(node, durer.Transform) and np.allclose(node.matrix[:3, 3], [5, 0, 0])
    # no camera in the file: framed on the box at x = 5; no lights: the default rig and sky
    assert scene.camera.direction @ (np.array([5, 0, 0]) - scene.camera.center) > 0
    assert len(scene.lights) == 2 and np.allclose(scene.ambient_light, DEFAULT_SKY)
    r = durer.render(scene, 24, 24)
    hit = np.isfinite(r.depth)
    assert hit[12, 12] and (r.color[hit][:, 2] > r.color[hit][:, 0]).all()  # blue everywhere


def test_base_colour_texture_through_uvs(tmp_path):
    texels = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 255]]], np.uint8)
    quad = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], faces=[[0, 1, 2], [0, 2, 3]],
                           visual=trimesh.visual.TextureVisuals(
                               uv=[[0, 0], [1, 0], [1, 1], [0, 1]],
                               material=TrimeshPBR(baseColorTexture=Image.fromarray(texels), metallicFactor=0.0)),
                           process=False)
    scene = durer.load(_exported(tmp_path, "quad.glb", quad))
    (mat,) = scene.materials
    assert mat.texture.shape == (2, 2, 3) and np.allclose(mat.texture, srgb_to_linear(texels / 255.0))
    scene.camera = durer.OrthographicCamera((0.5, 0.5, 5), (0, 0, -1), (0, 1, 0), 1.0)
    scene.lights = None  # flat colour: base colour times the texture, exactly
    r = durer.render(scene, 2, 2)
    # pixel centres land on texel centres (bilinear weights 0 and 1); the image's top row is v = 1
    assert np.allclose(r.color[0, 0], [1, 0, 0]) and np.allclose(r.color[0, 1], [0, 1, 0])
    assert np.allclose(r.color[1, 0], [0, 0, 1]) and np.allclose(r.color[1, 1], [1, 1, 1])
    # between texel centres the lookup is bilinear: the image's centre is the mean of the four texels
    mid = durer.render(scene, 1, 1).color[0, 0]
    assert np.allclose(mid, srgb_to_linear(texels / 255.0).mean(axis=(0, 1)), atol=1e-6)


@pytest.mark.parametrize("shape", [(48, 32), (32, 48), (40, 40)])
def test_camera_less_model_is_framed(tmp_path, shape):
    box = trimesh.creation.box(extents=(2.0, 1.0, 0.5))
    box.apply_translation([10, 5, -3])
    scene = durer.load(_exported(tmp_path, "box.stl", box))
    r = durer.render(scene, *shape)
    hit = np.isfinite(r.depth)
    assert not (hit[0].any() or hit[-1].any() or hit[:, 0].any() or hit[:, -1].any())  # all of it inside
    assert hit.mean() > 0.15  # and it fills a good part of the image


@pytest.mark.parametrize("ext", ["ply", "stl", "obj", "off"])
def test_inward_facing_mesh_is_lit(tmp_path, ext):
    ball = trimesh.creation.icosphere(subdivisions=1)
    ball.faces = ball.faces[:, ::-1]  # faces pointing inwards, as the Stanford bunny's
    scene = durer.load(_exported(tmp_path, f"ball.{ext}", ball))
    assert isinstance(scene.camera, durer.PerspectiveCamera)
    lit = durer.render(scene, 16, 16, shade_back=True)
    dark = durer.render(scene, 16, 16, shade_back=False)
    assert lit.color[8, 8].min() > 0.2  # grey and lit by the default rig
    assert np.allclose(dark.color[8, 8], 0)  # the course's rule, when asked for


def test_not_a_model_is_a_scene_error(tmp_path):
    bad = tmp_path / "bad.glb"
    bad.write_bytes(b"\x00\x01garbage" * 10)
    with pytest.raises(SceneError, match=r"bad\.glb: cannot read model"):
        durer.load(bad)
    with pytest.raises(SceneError, match="model file not found"):
        durer.load(tmp_path / "missing.ply")


def test_course_triangle_mesh_reads_any_format(tmp_path):
    ball = trimesh.creation.icosphere(subdivisions=1)
    ball.export(tmp_path / "ball.ply")
    (tmp_path / "s.txt").write_text(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }\n"
        "Background { color 0 0 0 }\nMaterials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n"
        "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file ball.ply } }\n")
    scene = durer.load(tmp_path / "s.txt")
    (mesh,) = scene.group.objects
    assert np.allclose(mesh.vertices, ball.vertices) and np.array_equal(mesh.faces, ball.faces)


def test_missing_mesh_names_where_it_looked_and_the_variable(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("DURER_MESH_PATH", raising=False)
    (tmp_path / "s.txt").write_text(
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }\n"
        "Background { color 0 0 0 }\nMaterials { numMaterials 1 Material { diffuseColor 1 1 1 } }\n"
        "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file nowhere.ply } }\n")
    with pytest.raises(SceneError) as e:
        durer.load(tmp_path / "s.txt")
    message = str(e.value)
    assert message.startswith(f"{tmp_path / 's.txt'}:4: mesh file 'nowhere.ply' not found")
    assert str(tmp_path) in message and "DURER_MESH_PATH" in message and "--mesh-path" in message
    assert "\n" not in message


def test_example_models_have_cameras_and_lights():
    from conftest import REPO

    for name in ("still_life.gltf", "spotlights.gltf"):
        path = REPO / "examples" / name
        assert path.stat().st_size < 20_000
        gltf = read_gltf_json(str(path))
        assert gltf["cameras"] and gltf["extensions"]["KHR_lights_punctual"]["lights"]
        scene = durer.load(path)
        assert not hasattr(scene.camera, "frame")  # the file's own camera, not a framed one


def test_binary_file_of_unknown_type_is_named_not_quoted(tmp_path):
    bad = tmp_path / "model.fbx"
    bad.write_bytes(b"Kaydara FBX Binary  \x00\x1a\x00\xe8\x1c\x00\x00" + bytes(range(256)))
    with pytest.raises(SceneError) as e:
        durer.load(bad)
    assert str(e.value) == (f"{bad}: not a MIT 6.837 scene file (binary data); model files durer reads end in "
                            ".glb .gltf .obj .off .ply .stl")


def test_vertex_normals_only_when_the_file_has_them(tmp_path):
    ball = trimesh.creation.icosphere(subdivisions=1)
    with_normals = tmp_path / "smooth.glb"
    scene = trimesh.Scene()
    scene.add_geometry(ball)
    with_normals.write_bytes(trimesh.exchange.gltf.export_glb(scene, include_normals=True))
    (mesh,) = durer.load(with_normals).group.objects
    assert np.allclose(mesh.normals, ball.vertices / np.linalg.norm(ball.vertices, axis=1, keepdims=True), atol=1e-6)
    box = trimesh.creation.box()
    (flat,) = durer.load(_exported(tmp_path, "box.glb", box)).group.objects
    assert flat.normals is None  # glTF without NORMAL: flat shading, as the specification asks
    r = durer.render(durer.load(with_normals), 32, 32)
    hit = np.isfinite(r.depth)
    # smooth: neighbouring lit pixels differ little (a faceted ball jumps at every edge)
    jumps = np.abs(np.diff(r.color[:, :, 0], axis=1))[hit[:, 1:] & hit[:, :-1]]
    assert jumps.max() < 0.12


@pytest.mark.parametrize(("damage", "message"), [
    (lambda g: g.update(extensions={"KHR_lights_punctual": []}),      # a list where an object belongs
     "malformed glTF (AttributeError: 'list' object has no attribute 'get')"),
    (lambda g: g["nodes"][4]["extensions"]["KHR_lights_punctual"].update(light=7), None),  # no such light: skipped
    (lambda g: g["scenes"][0].update(nodes=[0, 1, 99]), "cannot read model: IndexError"),  # trimesh refuses it
    (lambda g: g["cameras"][0].pop("perspective"), "camera 0 ('Front') is malformed: 'perspective'"),
    (lambda g: g["nodes"][1].update(rotation=[0, 0, 1]), "cannot read model: ValueError"),  # three numbers
])
def test_malformed_gltf_json_is_one_line_naming_the_file(tmp_path, damage, message):
    gltf, data = hand_written_gltf()
    damage(gltf)
    path = tmp_path / "bad.gltf"
    write_gltf(path, gltf, data)
    if message is None:
        assert len(durer.load(path).lights) == 2
        return
    with pytest.raises(SceneError) as e:
        durer.load(path)
    assert str(e.value).startswith(f"{path}: {message}") and "\n" not in str(e.value)


def test_vertex_colours_are_interpolated(tmp_path):
    quad = trimesh.Trimesh(vertices=[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], faces=[[0, 1, 2], [0, 2, 3]],
                           vertex_colors=[[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [255, 255, 255, 255]],
                           process=False)
    path = _exported(tmp_path, "quad.ply", quad)
    scene = durer.load(path)
    (mesh,) = scene.group.objects
    assert np.allclose(mesh.colors, [[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])  # sRGB 0/255 are linear 0/1
    scene.camera = durer.OrthographicCamera((0.5, 0.5, 5), (0, 0, -1), (0, 1, 0), 1.0)
    scene.lights = None  # flat: white material times the interpolated colour
    r = durer.render(scene, 2, 2)
    # pixel (row 1, col 0) is the point (0.25, 0.25): on triangle 0-2-3, weights 0.75 v0, 0.25 v2, 0 v3
    assert np.allclose(r.color[1, 0], [0.75, 0, 0.25])
    # pixel (row 0, col 1) is (0.75, 0.75) on triangle 0-1-2: weights 0.25 v0, 0 v1, 0.75 v2
    assert np.allclose(r.color[0, 1], [0.25, 0, 0.75])
