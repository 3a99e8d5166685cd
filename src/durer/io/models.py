"""Model files (glTF/GLB, PLY, STL, OBJ, OFF and everything else trimesh reads) -> a durer Scene.

trimesh reads the meshes, the scene graph's node transforms and the materials; gltf_extras.py reads what trimesh
does not (every glTF camera, KHR_lights_punctual lights). Each geometry becomes one TriangleMesh (with its UVs when
it has a texture, and with the file's vertex normals for smooth shading when it gives them), placed by a Transform
per node that uses it, so a mesh used by several nodes is stored once.

Materials (scene/materials.py PBRMaterial documents how they are shaded):
  glTF metallic-roughness -> PBRMaterial.from_pbr(baseColorFactor, metallicFactor, roughnessFactor, emissiveFactor,
                             baseColorTexture decoded from sRGB to linear); absent factors take glTF's defaults
                             (metallic 1, roughness 1), as the specification says.
  OBJ/MTL materials       -> trimesh's own conversion to metallic-roughness, then the same.
  colours per vertex      -> interpolated across each triangle (TriangleMesh.colors) on a white dielectric
                             (sRGB in PLY, OFF and OBJ files; linear in glTF's COLOR_0)
  colours per face         -> their most common colour, dielectric.
  no colour at all        -> a light grey dielectric.
A model without a camera gets `frame_sphere` on its bounding sphere (re-framed by the renderer for the image's
shape); a model without lights gets a default rig (DEFAULT_RIG): a key and a fill light from the camera's side and
a soft sky as ambient light.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import SceneError
from ..scene.cameras import frame_sphere, orthonormal_basis
from ..scene.graph import Group, Scene, Transform
from ..scene.lights import DirectionalLight
from ..scene.materials import PBRMaterial
from ..scene.shapes import TriangleMesh
from .gltf_extras import check_node_graph, pick_camera, read_cameras, read_gltf_json, read_lights
from .obj import check_obj_faces

GLTF = (".gltf", ".glb")
BACKGROUND = (0.06, 0.07, 0.09)  # linear: a dark blue-grey, so light and dark models both stand out
DEFAULT_GREY = (0.7, 0.7, 0.7)
# (direction relative to the camera: right, up, towards the viewer), colour; and the sky's ambient light
DEFAULT_RIG = (((-0.6, 0.8, 0.5), (0.85, 0.82, 0.78)), ((0.7, 0.2, 0.6), (0.25, 0.27, 0.3)))
DEFAULT_SKY = (0.18, 0.19, 0.22)
FILE_AMBIENT = (0.03, 0.03, 0.03)  # with the file's own lights: just enough to see what they leave dark


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] -> linear (IEC 61966-2-1)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _trimesh_load(path: str):
    """trimesh's scene of a file, or SceneError naming the file (trimesh raises many kinds of errors). What trimesh
    lets through is checked here: OBJ face indices (0, or past the vertices read so far: `check_obj_faces`), a
    glTF node hierarchy with a cycle, faces whose indices lie outside their mesh's vertices (PLY, OFF) and
    vertices that are not finite."""
    import trimesh

    if not os.path.isfile(path):
        raise SceneError("model file not found" if not os.path.exists(path) else "model path is not a file", path)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".obj":
        check_obj_faces(path)
    elif ext in GLTF:
        try:
            gltf = read_gltf_json(path)
        except SceneError:
            gltf = None  # not glTF at all: trimesh's own message says why
        if gltf is not None:
            check_node_graph(gltf, path)
    try:
        tm = trimesh.load(path, force="scene", process=False)
    except Exception as e:  # noqa: BLE001  (trimesh's readers raise anything from KeyError to struct.error)
        raise SceneError(f"cannot read model: {type(e).__name__}: {e}".splitlines()[0], path) from None
    for name, geom in tm.geometry.items():
        faces = np.asarray(getattr(geom, "faces", np.zeros((0, 3), np.int64)))
        vertices = np.asarray(getattr(geom, "vertices", np.zeros((0, 3))))
        if len(faces) and not np.isfinite(vertices).all():
            k = int(np.flatnonzero(~np.isfinite(vertices).all(axis=1))[0])
            raise SceneError(f"vertex {k}{f' (mesh {name!r})' if len(tm.geometry) > 1 else ''} is not finite: "
                             f"{vertices[k].tolist()}", path)
        if len(faces) and (faces.min() < 0 or faces.max() >= len(geom.vertices)):
            k = int(np.flatnonzero(((faces < 0) | (faces >= len(geom.vertices))).any(axis=1))[0])
            what = f" (mesh {name!r})" if len(tm.geometry) > 1 else ""
            raise SceneError(f"face {k}{what} uses vertices {faces[k].tolist()}, but the mesh has "
                             f"{len(geom.vertices)} vertices (0..{len(geom.vertices) - 1})", path)
    return tm


def _material(geom, gltf: bool) -> PBRMaterial:
    """The durer material of one trimesh geometry (see the module docstring)."""
    from trimesh.visual.material import PBRMaterial as TrimeshPBR
    from trimesh.visual.material import SimpleMaterial

    visual = geom.visual
    mat = getattr(visual, "material", None)
    if isinstance(mat, SimpleMaterial):
        mat = mat.to_pbr()
        gltf = False
    if isinstance(mat, TrimeshPBR):
        factor = np.ones(4) if mat.baseColorFactor is None else np.asarray(mat.baseColorFactor) / 255.0
        texture = None
        if mat.baseColorTexture is not None and getattr(visual, "uv", None) is not None:
            rgb = np.asarray(mat.baseColorTexture.convert("RGB"), dtype=np.float64) / 255.0
            texture = srgb_to_linear(rgb).astype(np.float32)
        default = 1.0 if gltf else 0.0
        metallic = default if mat.metallicFactor is None else float(mat.metallicFactor)
        roughness = 1.0 if mat.roughnessFactor is None else float(mat.roughnessFactor)
        emission = np.zeros(3) if mat.emissiveFactor is None else np.asarray(mat.emissiveFactor, float).reshape(3)
        return PBRMaterial.from_pbr(factor[:3], float(np.clip(metallic, 0, 1)), float(np.clip(roughness, 0, 1)),
                                    emission, texture, name=str(getattr(mat, "name", "") or ""))
    if _vertex_colors(geom, gltf) is not None:
        return PBRMaterial.from_pbr((1.0, 1.0, 1.0), 0.0, 0.6)  # white, tinted by the colours
    if getattr(visual, "kind", None) in ("face", "vertex"):
        rgb = np.asarray(visual.main_color[:3], dtype=np.float64) / 255.0
        return PBRMaterial.from_pbr(rgb if gltf else srgb_to_linear(rgb), 0.0, 0.6)
    return PBRMaterial.from_pbr(DEFAULT_GREY, 0.0, 0.6)


def _vertex_colors(geom, gltf: bool) -> np.ndarray | None:
    """Linear per-vertex colours (V,3) of a mesh coloured per vertex, unless they are all one colour (then the
    material carries it). glTF's COLOR_0 is linear already; PLY, OFF and OBJ colours are sRGB."""
    visual = geom.visual
    if getattr(visual, "kind", None) != "vertex":
        return None
    rgb = np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
    if len(rgb) != len(geom.vertices) or np.ptp(rgb, axis=0).max() == 0:
        return None
    return rgb if gltf else srgb_to_linear(rgb)


def _file_normals(geom) -> np.ndarray | None:
    """The vertex normals the file gave (glTF NORMAL, OBJ vn, PLY nx ny nz), or None: trimesh would otherwise
    compute smooth ones from shared vertices, rounding off every box (glTF asks for flat shading then)."""
    cache = getattr(getattr(geom, "_cache", None), "cache", {})
    if "vertex_normals" not in cache:
        return None
    normals = np.asarray(geom.vertex_normals, dtype=np.float64)
    return normals if normals.shape == geom.vertices.shape and np.isfinite(normals).all() else None


def load_model(path: str | os.PathLike, mesh_path: list[str] | None = None, camera: str | int | None = None) -> Scene:
    """Read a model file into a Scene (see the module docstring); `camera` picks a glTF camera by name or index
    (the first by default). Raises SceneError naming the file on a mistake. `mesh_path` is unused (models carry
    their meshes); it is there so every reader has the same signature (io/loaders.py)."""
    import trimesh

    path = os.fspath(path)
    tm = _trimesh_load(path)
    is_gltf = os.path.splitext(path)[1].lower() in GLTF
    objects: list = []
    materials: list = []
    meshes: dict[str, TriangleMesh] = {}
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    placed: list[tuple[np.ndarray, np.ndarray]] = []
    for node in tm.graph.nodes_geometry:
        matrix, name = tm.graph[node]
        geom = tm.geometry.get(name)
        if not isinstance(geom, trimesh.Trimesh) or not len(geom.faces):
            continue  # point clouds and lines have nothing to hit
        matrix = np.asarray(matrix, dtype=np.float64)
        if not abs(np.linalg.det(matrix[:3, :3])) > 1e-300:
            continue  # a node scaled to nothing draws nothing
        if name not in meshes:
            materials.append(_material(geom, is_gltf))
            tex = materials[-1].texture is not None
            meshes[name] = TriangleMesh(np.asarray(geom.vertices), np.asarray(geom.faces), len(materials) - 1,
                                        source=f"{path}#{name}", uvs=np.asarray(geom.visual.uv) if tex else None,
                                        normals=_file_normals(geom), colors=_vertex_colors(geom, is_gltf))
        mesh = meshes[name]
        world = mesh.vertices @ matrix[:3, :3].T + matrix[:3, 3]
        lo, hi = np.minimum(lo, world.min(axis=0)), np.maximum(hi, world.max(axis=0))
        placed.append((world, matrix))
        objects.append(mesh if np.allclose(matrix, np.eye(4)) else Transform(matrix, mesh))
    if not objects:
        raise SceneError("the model has no triangles", path)
    center = (lo + hi) / 2
    with np.errstate(over="ignore", invalid="ignore"):  # coordinates near 1e308: reported below, not warned
        radius = max(float(np.linalg.norm(w - center, axis=1).max()) for w, _ in placed)
    if not np.isfinite(radius):
        raise SceneError("the model's coordinates overflow (its extent is beyond 1e154 or not finite)", path)

    gltf = read_gltf_json(path) if is_gltf else {}
    cameras = _malformed_is_scene_error(read_cameras, gltf, path) if is_gltf else []
    if camera is not None:
        cam = pick_camera(cameras, camera, path)
    elif cameras:
        cam = cameras[0].camera
    else:
        cam = frame_sphere(center, radius)
    lights = _malformed_is_scene_error(read_lights, gltf, path) if is_gltf else []
    ambient = FILE_AMBIENT
    if not lights:
        lights, ambient = default_rig(cam), DEFAULT_SKY
    return Scene(camera=cam, group=Group(objects), materials=materials, lights=lights,
                 background_color=BACKGROUND, ambient_light=ambient, source=path)


def default_rig(camera) -> list[DirectionalLight]:
    """DEFAULT_RIG's lights, placed relative to the camera (a key light from the upper left, a dim fill)."""
    d, u, h = orthonormal_basis(camera.direction, camera.up)
    return [DirectionalLight(-(x * h + y * u - z * d), color) for (x, y, z), color in DEFAULT_RIG]


def model_camera(path: str | os.PathLike, which: str | int) -> object:
    """The camera `which` (name or index) of a glTF file; SceneError listing its cameras if there is none such."""
    path = os.fspath(path)
    if os.path.splitext(path)[1].lower() not in GLTF:
        raise SceneError(f"only glTF files have cameras to choose (asked for camera {which!r})", path)
    return pick_camera(_malformed_is_scene_error(read_cameras, read_gltf_json(path), path), which, path)


def _malformed_is_scene_error(read, gltf: dict, path: str):
    """read(gltf, path), with a glTF whose JSON has the wrong shape (a list for an object, a bad index) reported as
    a SceneError naming the file rather than a traceback."""
    try:
        return read(gltf, path)
    except (KeyError, TypeError, AttributeError, IndexError, ValueError) as e:
        raise SceneError(f"malformed glTF ({type(e).__name__}: {e})", path) from None


def read_mesh(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V,3) and faces (F,3) of every triangle in a model file, its node transforms applied (for the course
    scenes' `TriangleMesh { obj_file X }` with X a PLY, STL, glTF, ... file)."""
    import trimesh

    tm = _trimesh_load(path)
    vs, fs, n = [], [], 0
    for node in tm.graph.nodes_geometry:
        matrix, name = tm.graph[node]
        geom = tm.geometry.get(name)
        if isinstance(geom, trimesh.Trimesh) and len(geom.faces):
            vs.append(np.asarray(geom.vertices) @ matrix[:3, :3].T + matrix[:3, 3])
            fs.append(np.asarray(geom.faces) + n)
            n += len(geom.vertices)
    if not fs:
        raise SceneError("mesh file has no triangles", path)
    return np.concatenate(vs), np.concatenate(fs)
