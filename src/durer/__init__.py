"""durer: a ray casting and ray tracing renderer for Python, named after Duerer's ray casting machine.

    scene = durer.load("scene.txt")
    result = durer.render(scene, 200, 200)
    result.save("out.png")
"""

from __future__ import annotations

import os

from .cameras import FisheyeCamera, OrthographicCamera, PanoramaCamera, PerspectiveCamera
from .errors import DurerError, SceneError, UsageError
from .lights import DirectionalLight, PointLight
from .materials import Material, PhongMaterial
from .render import RenderResult, render
from .scene import Group, Scene, Transform
from .shapes import Plane, Sphere, Triangle, TriangleMesh
from .textures import Checkerboard, Marble, Noise, Wood

__version__ = "0.1.0"


def __getattr__(name: str):
    """Import the query API on first use: the renderer and the CLI do not need it, and it costs start-up time."""
    if name == "RaycastingScene":
        from .query import RaycastingScene

        return RaycastingScene
    raise AttributeError(f"module 'durer' has no attribute {name!r}")


def load(path: str | os.PathLike, mesh_path: list[str] | None = None) -> Scene:
    """Read a scene file (the MIT 6.837 format); mesh files are looked up next to it, in the working
    directory, then in `mesh_path` and $DURER_MESH_PATH. Raises SceneError with file and line on a mistake."""
    from .io.course import load_course_scene

    return load_course_scene(path, mesh_path)


__all__ = [
    "Checkerboard", "DirectionalLight", "DurerError", "FisheyeCamera", "Group", "Marble", "Material", "Noise",
    "OrthographicCamera", "PanoramaCamera", "PerspectiveCamera", "PhongMaterial", "Plane", "PointLight",
    "RaycastingScene", "RenderResult", "Scene", "SceneError", "Sphere", "Transform", "Triangle", "TriangleMesh",
    "UsageError", "Wood", "load", "render",
]
