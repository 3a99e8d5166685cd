"""What trimesh does not read from a glTF file: every camera and the KHR_lights_punctual lights.

The JSON is read directly (a .gltf file, or the JSON chunk of a .glb) and the node hierarchy walked with each node's
`matrix` or translation/rotation/scale, so cameras and lights land in the same world space as trimesh's meshes.

Cameras (glTF looks down its node's -Z with +Y up):
  perspective  -> PerspectiveCamera; durer's angle spans the image's longer side, so with an `aspectRatio` a >= 1
                  it is 2 atan(a tan(yfov / 2)) (yfov spans the height of an image of that shape), else yfov.
  orthographic -> OrthographicCamera of size 2 max(xmag, ymag) (the longer side).
Each keeps the file's aspect ratio (xmag / ymag, or aspectRatio) as `aspect_ratio`: `durer render` without --size
renders 512 pixels on the longer side in that shape.
Lights (glTF's BRDF carries the 1/pi that durer's Phong leaves out, so colours are color * intensity / pi: a white
surface facing a directional light of intensity pi lux renders white):
  directional -> DirectionalLight along the node's -Z; point -> PointLight with inverse-square falloff;
  spot -> SpotLight with glTF's inner/outer cone angles. `range` is ignored (glTF allows a renderer to).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass

import numpy as np

from ..errors import SceneError
from ..scene.cameras import OrthographicCamera, PerspectiveCamera
from ..scene.lights import DirectionalLight, PointLight, SpotLight
from .files import read_bytes


def read_gltf_json(path: str) -> dict:
    """The glTF JSON of a .gltf file or of a .glb's first chunk; SceneError naming the file if it is not one."""
    data = read_bytes(path, "model file")
    if data[:4] == b"glTF":
        if len(data) < 20:
            raise SceneError("truncated .glb file", path)
        length, kind = struct.unpack("<I4s", data[12:20])
        if kind != b"JSON":
            raise SceneError("the .glb's first chunk is not JSON", path)
        data = data[20:20 + length]
    try:
        gltf = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise SceneError(f"not a glTF file ({e})", path) from None
    if not isinstance(gltf, dict):
        raise SceneError("not a glTF file (its JSON is not an object)", path)
    return gltf


def check_node_graph(gltf: dict, path: str) -> None:
    """SceneError naming the node if the node hierarchy is not a set of trees, as glTF requires: a child index
    that names no node, or a node that is its own descendant (trimesh renders such a file silently, some nodes
    missing). Walked with an explicit stack."""
    nodes = gltf.get("nodes", [])
    if not isinstance(nodes, list):
        raise SceneError("malformed glTF: 'nodes' is not a list", path)
    children: list[list[int]] = []
    for i, node in enumerate(nodes):
        kids = node.get("children", []) if isinstance(node, dict) else None
        if not isinstance(kids, list) or not all(isinstance(c, int) and not isinstance(c, bool) for c in kids):
            raise SceneError(f"malformed glTF: node {i}'s children are not a list of node indices", path)
        bad = [c for c in kids if not 0 <= c < len(nodes)]
        if bad:
            raise SceneError(f"malformed glTF: node {i} has child {bad[0]}, but the file has {len(nodes)} nodes",
                             path)
        children.append(kids)
    state = [0] * len(nodes)  # 0 not visited, 1 on the current path, 2 done
    for root in range(len(nodes)):
        if state[root]:
            continue
        stack = [(root, 0)]
        state[root] = 1
        while stack:
            i, k = stack.pop()
            if k == len(children[i]):
                state[i] = 2
                continue
            stack.append((i, k + 1))
            c = children[i][k]
            if state[c] == 1:
                what = "its own child" if c == i else f"a descendant of its child (via node {i})"
                raise SceneError(f"malformed glTF: node {c} is {what}: the node hierarchy has a cycle", path)
            if state[c] == 0:
                state[c] = 1
                stack.append((c, 0))


def _local_matrix(node: dict) -> np.ndarray:
    """A node's 4x4 local transform: its column-major `matrix`, or T @ R @ S."""
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4).T
    x, y, z, w = node.get("rotation", (0.0, 0.0, 0.0, 1.0))
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * np.asarray(node.get("scale", (1.0, 1.0, 1.0)), dtype=np.float64)
    m[:3, 3] = node.get("translation", (0.0, 0.0, 0.0))
    return m


def node_world_matrices(gltf: dict) -> list[tuple[int, np.ndarray]]:
    """(node index, world matrix) of every node of the default scene, parents before children."""
    nodes = gltf.get("nodes", [])
    scenes = gltf.get("scenes")
    if scenes:
        roots = scenes[gltf.get("scene", 0)].get("nodes", [])
    else:  # no scene: every node that is nobody's child
        children = {c for n in nodes for c in n.get("children", [])}
        roots = [i for i in range(len(nodes)) if i not in children]
    out: list[tuple[int, np.ndarray]] = []
    stack = [(i, np.eye(4)) for i in reversed(roots)]
    seen: set[int] = set()
    while stack:
        i, parent = stack.pop()
        if i in seen or not 0 <= i < len(nodes):  # a malformed file: skip cycles and dangling indices
            continue
        seen.add(i)
        world = parent @ _local_matrix(nodes[i])
        out.append((i, world))
        stack.extend((c, world) for c in reversed(nodes[i].get("children", [])))
    return out


@dataclass
class GltfCamera:
    """One camera of a glTF file: its index in `cameras`, a name, and the durer camera at its first node."""

    index: int
    name: str
    camera: object


def _frame(world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre, view direction (-Z) and up (+Y) of a node's world matrix."""
    return world[:3, 3], world[:3, :3] @ np.array([0.0, 0.0, -1.0]), world[:3, :3] @ np.array([0.0, 1.0, 0.0])


def read_cameras(gltf: dict, path: str) -> list[GltfCamera]:
    """Every camera of the file placed by a node of the default scene, in the order of the file's `cameras`."""
    defs = gltf.get("cameras", [])
    nodes = gltf.get("nodes", [])
    placed: dict[int, tuple[int, np.ndarray]] = {}
    for i, world in node_world_matrices(gltf):
        c = nodes[i].get("camera")
        if isinstance(c, int) and 0 <= c < len(defs) and c not in placed:
            placed[c] = (i, world)
    out = []
    for c in sorted(placed):
        node, world = placed[c]
        d = defs[c]
        name = d.get("name") or nodes[node].get("name") or f"camera{c}"
        center, direction, up = _frame(world)
        try:
            if d.get("type") == "orthographic":
                o = d["orthographic"]
                cam = OrthographicCamera(center, direction, up, 2.0 * max(float(o["xmag"]), float(o["ymag"])))
                cam.aspect_ratio = float(o["xmag"]) / float(o["ymag"])
            else:
                p = d["perspective"]
                yfov = float(p["yfov"])
                aspect = float(p.get("aspectRatio", 1.0))
                angle = 2.0 * np.arctan(aspect * np.tan(yfov / 2.0)) if aspect >= 1 else yfov
                cam = PerspectiveCamera(center, direction, up, np.degrees(angle))
                if "aspectRatio" in p:
                    cam.aspect_ratio = aspect
        except (KeyError, TypeError, ValueError) as e:
            raise SceneError(f"camera {c} ({name!r}) is malformed: {e}", path) from None
        out.append(GltfCamera(c, name, cam))
    return out


def pick_camera(cameras: list[GltfCamera], which: str | int, path: str) -> object:
    """The camera named `which`, or at index `which` (an int or a string of digits); SceneError listing them."""
    text = str(which)
    for cam in cameras:
        if cam.name == text or (text.isdigit() and cam.index == int(text)):
            return cam.camera
    have = ", ".join(f"{c.index} ({c.name!r})" for c in cameras) or "none"
    raise SceneError(f"no camera {text!r} in the model (its cameras: {have})", path)


def read_lights(gltf: dict, path: str) -> list:
    """The KHR_lights_punctual lights placed by nodes of the default scene, as durer lights (see the module)."""
    defs = gltf.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    nodes = gltf.get("nodes", [])
    out = []
    for i, world in node_world_matrices(gltf):
        ref = nodes[i].get("extensions", {}).get("KHR_lights_punctual", {}).get("light")
        if not isinstance(ref, int) or not 0 <= ref < len(defs):
            continue
        d = defs[ref]
        center, direction, _ = _frame(world)
        try:
            color = np.asarray(d.get("color", (1.0, 1.0, 1.0)), dtype=np.float64) * float(d.get("intensity", 1.0))
            color = color / np.pi
            kind = d.get("type")
            if kind == "directional":
                out.append(DirectionalLight(direction, color))
            elif kind == "point":
                out.append(PointLight(center, color, (0.0, 0.0, 1.0)))
            elif kind == "spot":
                spot = d.get("spot", {})
                outer = np.degrees(float(spot.get("outerConeAngle", np.pi / 4)))
                inner = min(np.degrees(float(spot.get("innerConeAngle", 0.0))), outer * 0.999)
                out.append(SpotLight(center, direction, color, inner, outer, (0.0, 0.0, 1.0)))
            else:
                raise ValueError(f"unknown light type {kind!r}")
        except (TypeError, ValueError) as e:
            raise SceneError(f"light {ref} ({d.get('name', '')!r}) is malformed: {e}", path) from None
    return out
