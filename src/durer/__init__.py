"""durer: a ray casting and ray tracing renderer for Python, named after Duerer's ray casting machine.

    scene = durer.load("scene.txt")
    result = durer.render(scene, 200, 200)
    result.save("out.png")
"""

from __future__ import annotations

import os
import sys

from .errors import DurerError, SceneError, UsageError
from .options import thread_count
from .rendering.renderer import RenderResult
from .rendering.renderer import render as _render
from .scene import transforms
from .scene.cameras import FisheyeCamera, OrthographicCamera, PanoramaCamera, PerspectiveCamera
from .scene.graph import Group, Scene, Transform
from .scene.lights import DirectionalLight, PointLight, SpotLight
from .scene.materials import Material, PBRMaterial, PhongMaterial
from .scene.shapes import Cylinder, Disk, Plane, Sphere, Triangle, TriangleMesh
from .scene.textures import Checkerboard, Marble, Noise, Wood

__version__ = "0.1.0"


def __getattr__(name: str):
    """Import the query API on first use: the renderer and the CLI do not need it, and it costs start-up time."""
    if name == "RaycastingScene":
        from .query import RaycastingScene

        return RaycastingScene
    if name == "preview":  # the live view (preview/): durer.preview(scene) serves it, inline in Jupyter
        from .preview import show  # imports the package durer.preview, which is callable: preview(...) is show(...)

        return sys.modules[show.__module__]
    raise AttributeError(f"module 'durer' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def render(scene: Scene, width: int | None = None, height: int | None = None, *, nthreads: int | None = None,
           **kwargs) -> RenderResult:
    """Render `scene` at width x height (rendering/renderer.render: keyword arguments are RenderOptions fields,
    `options=`, `quiet=`) on `nthreads` threads (0 or None: every core), as `--threads N` does."""
    with thread_count(nthreads):
        return _render(scene, width, height, **kwargs)


def drop_build(scene: Scene | None = None) -> None:
    """Free the compiled build (bundle, tables, BVH) that render keeps for `scene` while it is unchanged, or for
    every scene (None); the next render rebuilds it (rendering/builds.py: what counts as a change)."""
    from .rendering.builds import drop

    drop(scene)


def load(path: str | os.PathLike, mesh_path: list[str] | None = None, camera: str | int | None = None) -> Scene:
    """Read a scene file, by its extension (io/loaders.py): model files (.glb .gltf .obj .ply .stl .off) through
    trimesh, anything else as a MIT 6.837 scene, whose mesh files are looked up next to it, in the working
    directory, then in `mesh_path` and $DURER_MESH_PATH. `camera` picks a glTF file's camera by name or index (the
    first by default). Raises SceneError with file (and line) on a mistake."""
    from .io.loaders import load_scene

    scene = load_scene(path, mesh_path)
    if camera is not None:
        from .io.models import model_camera

        scene.camera = model_camera(path, camera)
    return scene


def load_dict(scene: dict, mesh_path: list[str] | None = None) -> Scene:
    """Build a scene from a Python dict with the structure of Mitsuba 3's mi.load_dict (io/mitsuba.py's subset),
    without importing Mitsuba. Raises SceneError naming the culprit."""
    from .io.mitsuba import load_dict as _load_dict

    return _load_dict(scene, mesh_path)


__all__ = [
    "Checkerboard", "Cylinder", "DirectionalLight", "Disk", "DurerError", "FisheyeCamera", "Group", "Marble",
    "Material", "Noise", "OrthographicCamera", "PBRMaterial", "PanoramaCamera", "PerspectiveCamera", "PhongMaterial",
    "Plane", "PointLight", "RaycastingScene", "RenderResult", "Scene", "SceneError", "Sphere", "SpotLight",
    "Transform", "Triangle", "TriangleMesh", "UsageError", "Wood", "drop_build", "load", "load_dict", "preview",
    "render", "transforms",
]
