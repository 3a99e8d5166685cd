"""Generate the example models in examples/ (small glTF files with a camera and lights, made for durer, so no
licence question), and optionally render them for the README's gallery.

    python tools/make_examples.py            # writes examples/*.gltf
    python tools/make_examples.py --render   # and docs/images/models/*.png (small, for the README)

trimesh builds and exports the meshes and materials (buffers embedded as base64, one file each; vertex normals only
for the smooth sphere, so boxes and cones stay flat); the cameras and KHR_lights_punctual lights, which trimesh's
exporter does not write, are added to the JSON here.
"""

from __future__ import annotations

import argparse
import io
import json
import math
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image
from trimesh.visual.material import PBRMaterial

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
IMAGES = REPO / "docs" / "images" / "models"


def _material(color, metallic=0.0, roughness=0.5, emissive=None, texture=None, name=""):
    return PBRMaterial(name=name, baseColorFactor=[*color, 1.0], metallicFactor=metallic, roughnessFactor=roughness,
                       emissiveFactor=emissive, baseColorTexture=texture)


def _with(mesh: trimesh.Trimesh, material: PBRMaterial, uv=None) -> trimesh.Trimesh:
    mesh.visual = trimesh.visual.TextureVisuals(uv=uv, material=material)
    return mesh


def _look_at(eye, target, up=(0.0, 1.0, 0.0)) -> list[float]:
    """A glTF node matrix (column-major) whose -Z looks from `eye` at `target`."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    back = eye - target
    back /= np.linalg.norm(back)
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = right, np.cross(back, right), back, eye
    return [round(float(x), 6) for x in m.T.reshape(-1)]


def _gltf(scene: trimesh.Scene, cameras: list[dict], lights: list[dict]) -> dict:
    """trimesh's glTF of the scene, with cameras and KHR_lights_punctual lights added as root nodes.

    cameras: {"name", "eye", "target", and "yfov" (degrees) or "ymag"}; lights: {"name", "type", "color",
    "intensity", "eye", "target", optional "inner"/"outer" (degrees) for spots}."""
    files = trimesh.exchange.gltf.export_gltf(scene, embed_buffers=True)  # normals only where computed
    gltf = json.loads(files["model.gltf"])
    gltf.pop("cameras", None)  # trimesh writes its default camera; ours replace it
    for n in gltf["nodes"]:
        n.pop("camera", None)
    roots = gltf["scenes"][0]["nodes"]
    gltf["cameras"] = []
    for c in cameras:
        if "ymag" in c:
            gltf["cameras"].append({"name": c["name"], "type": "orthographic", "orthographic": {
                "xmag": c["ymag"] * c.get("aspect", 1.0), "ymag": c["ymag"], "znear": 0.01, "zfar": 100.0}})
        else:
            gltf["cameras"].append({"name": c["name"], "type": "perspective", "perspective": {
                "yfov": math.radians(c["yfov"]), "aspectRatio": c.get("aspect", 1.0), "znear": 0.05}})
        roots.append(len(gltf["nodes"]))
        gltf["nodes"].append({"name": c["name"], "camera": len(gltf["cameras"]) - 1,
                              "matrix": _look_at(c["eye"], c["target"])})
    defs = []
    for light in lights:
        d = {"name": light["name"], "type": light["type"], "color": light["color"], "intensity": light["intensity"]}
        if light["type"] == "spot":
            d["spot"] = {"innerConeAngle": math.radians(light["inner"]), "outerConeAngle": math.radians(light["outer"])}
        defs.append(d)
        roots.append(len(gltf["nodes"]))
        gltf["nodes"].append({"name": light["name"], "matrix": _look_at(light["eye"], light["target"]),
                              "extensions": {"KHR_lights_punctual": {"light": len(defs) - 1}}})
    if defs:
        gltf.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": defs}
        gltf["extensionsUsed"] = sorted(set(gltf.get("extensionsUsed", [])) | {"KHR_lights_punctual"})
    gltf.pop("extras", None)
    gltf["asset"]["generator"] = "durer tools/make_examples.py (trimesh)"
    return gltf


def _checker(n: int = 8, texels: int = 8) -> Image.Image:
    """An n x n checker texture of two warm colours, `texels` pixels a cell (crisp under bilinear lookup)."""
    cells = ((np.indices((n * texels, n * texels)) // texels).sum(axis=0) % 2).astype(bool)
    rgb = np.where(cells[..., None], [230, 200, 150], [120, 60, 40]).astype(np.uint8)
    return Image.fromarray(rgb, mode="RGB")


def _place(mesh: trimesh.Trimesh, translation) -> trimesh.Trimesh:
    mesh.apply_translation(translation)
    return mesh


def still_life() -> dict:
    """Three shapes on a textured slab: a copper metal sphere, a blue box, a glowing cone; a sun, a fill point
    light, and two cameras (a perspective three-quarter view and an orthographic view from above)."""
    s = trimesh.Scene()
    slab = trimesh.creation.box(extents=(4.0, 0.2, 3.0))
    uv = np.c_[(slab.vertices[:, 0] + 2) / 4, (slab.vertices[:, 2] + 1.5) / 3]
    s.add_geometry(_with(slab, _material((1, 1, 1), 0.0, 0.9, texture=_checker(), name="slab"), uv),
                   node_name="slab", transform=trimesh.transformations.translation_matrix((0, -0.1, 0)))
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.6)
    assert sphere.vertex_normals.shape == sphere.vertices.shape  # computed now, so exported: shaded smooth
    s.add_geometry(_with(sphere, _material((0.95, 0.64, 0.54), 1.0, 0.35, name="copper")), node_name="sphere",
                   transform=trimesh.transformations.translation_matrix((-0.9, 0.6, 0.2)))
    box = trimesh.creation.box(extents=(0.8, 0.8, 0.8))
    rot = trimesh.transformations.rotation_matrix(math.radians(30), (0, 1, 0))
    rot[:3, 3] = (0.7, 0.4, -0.4)
    s.add_geometry(_with(box, _material((0.15, 0.3, 0.8), 0.0, 0.4, name="blue")), node_name="box", transform=rot)
    cone = trimesh.creation.cone(radius=0.35, height=0.9, sections=24)
    cone.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (1, 0, 0)))
    s.add_geometry(_with(cone, _material((0.9, 0.8, 0.2), 0.0, 0.6, emissive=(0.25, 0.2, 0.0), name="glow")),
                   node_name="cone", transform=trimesh.transformations.translation_matrix((0.9, 0.0, 0.9)))
    return _gltf(s, [
        {"name": "three-quarter", "eye": (3.2, 2.6, 4.2), "target": (0, 0.3, 0), "yfov": 38, "aspect": 4 / 3},
        {"name": "top", "eye": (0, 6, 0.001), "target": (0, 0, 0), "ymag": 1.7, "aspect": 4 / 3},
    ], [
        {"name": "sun", "type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 2.6,
         "eye": (-2, 5, 3), "target": (0, 0, 0)},
        {"name": "fill", "type": "point", "color": [0.6, 0.7, 1.0], "intensity": 12.0,
         "eye": (3, 2, -2), "target": (0, 0, 0)},
    ])


def spotlights() -> dict:
    """A grey torus-like ring of boxes on a floor under three coloured spot lights."""
    s = trimesh.Scene()
    floor = trimesh.creation.box(extents=(6.0, 0.1, 6.0))
    s.add_geometry(_with(floor, _material((0.8, 0.8, 0.8), 0.0, 0.8, name="floor")), node_name="floor",
                   transform=trimesh.transformations.translation_matrix((0, -0.05, 0)))
    post = _with(trimesh.creation.cylinder(radius=0.15, height=1.0, sections=16),
                 _material((0.85, 0.85, 0.85), 0.0, 0.5, name="post"))
    post.apply_transform(trimesh.transformations.rotation_matrix(-math.pi / 2, (1, 0, 0)))
    for k in range(6):  # one mesh, six nodes: durer stores it once (instancing)
        a = 2 * math.pi * k / 6
        s.add_geometry(post, geom_name="post", node_name=f"post{k}",
                       transform=trimesh.transformations.translation_matrix((1.3 * math.cos(a), 0.5,
                                                                             1.3 * math.sin(a))))
    lights = []
    for name, color, x in (("red", [1, 0.2, 0.2], -1.2), ("green", [0.2, 1, 0.3], 0.0), ("blue", [0.3, 0.4, 1], 1.2)):
        lights.append({"name": name, "type": "spot", "color": color, "intensity": 60.0, "inner": 12, "outer": 22,
                       "eye": (x, 4, 1.0), "target": (x * 0.8, 0, 0)})
    return _gltf(s, [{"name": "view", "eye": (0, 3.4, 5.0), "target": (0, 0.2, 0), "yfov": 40, "aspect": 4 / 3}],
                 lights)


MODELS = {"still_life.gltf": still_life, "spotlights.gltf": spotlights}


def write_models() -> list[Path]:
    """Write every example model; returns their paths."""
    EXAMPLES.mkdir(exist_ok=True)
    paths = []
    for name, make in MODELS.items():
        path = EXAMPLES / name
        path.write_text(json.dumps(make(), separators=(",", ":")) + "\n")
        paths.append(path)
    return paths


def render_gallery(paths: list[Path], size=(320, 240)) -> None:
    """Render each model (and the fisheye/panorama scenes) to a small PNG for the README."""
    import durer

    IMAGES.mkdir(parents=True, exist_ok=True)
    for path in paths:
        result = durer.render(durer.load(path), *size, shadows=True, samples=4)
        buffer = io.BytesIO()
        Image.fromarray(result.to_srgb8()).save(buffer, format="PNG", optimize=True)
        (IMAGES / (path.stem + ".png")).write_bytes(buffer.getvalue())
    for scene, shape in (("fisheye.txt", (240, 240)), ("panorama.txt", (400, 200))):
        result = durer.render(durer.load(EXAMPLES / scene), *shape, shadows=True, samples=4)
        Image.fromarray(result.to_srgb8()).save(IMAGES / (Path(scene).stem + ".png"), optimize=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--render", action="store_true", help="also render docs/images/models/*.png")
    args = parser.parse_args()
    paths = write_models()
    for p in paths:
        print(f"wrote {p.relative_to(REPO)} ({p.stat().st_size / 1000:.1f} KB)")
    if args.render:
        render_gallery(paths)


if __name__ == "__main__":
    main()
