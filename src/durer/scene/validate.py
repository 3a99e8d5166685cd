"""Checks of a Python-built Scene before it is compiled, so that a mistake is a ValueError naming the object
(`scene.group.objects[2] (Sphere): material 3 out of range ...`) rather than an IndexError deep in shading."""

from __future__ import annotations

from .bsdfs import BSDF, Surface
from .cameras import FisheyeCamera, OrthographicCamera, PanoramaCamera, PerspectiveCamera
from .graph import Group, Scene, Transform
from .lights import DirectionalLight, PointLight, SpotLight
from .materials import PhongMaterial
from .shapes import Cylinder, Disk, Plane, Sphere, Triangle, TriangleMesh
from .textures import Checkerboard, Marble, Noise, Wood

CAMERAS = (OrthographicCamera, PerspectiveCamera, FisheyeCamera, PanoramaCamera)
LIGHTS = (DirectionalLight, PointLight, SpotLight)
SHAPES = (Sphere, Disk, Cylinder, Plane, Triangle, TriangleMesh)
TEXTURES = (Checkerboard, Noise, Marble, Wood)
PHYSICAL = (Surface, *BSDF.__args__)  # the path tracer's materials (scene/bsdfs.py)
# Groups and Transforms inside each other, at most: the compiler walks the tree recursively (accel/compile.py), and
# no real scene comes near it (the course's deepest is 4); deeper is a SceneError (files) or ValueError (Python)
MAX_NESTING = 200


def _names(types: tuple) -> str:
    return ", ".join(t.__name__ for t in types)


def check_scene(scene: Scene) -> None:
    """Raise ValueError naming the first wrong object: types of the camera, lights, materials and objects, and
    every material index (shapes' and textures') within `scene.materials`; a Group or Transform that contains
    itself, and nesting deeper than MAX_NESTING."""
    if not isinstance(scene, Scene):
        raise ValueError(f"expected a durer.Scene, got {type(scene).__name__}")
    if not isinstance(scene.camera, CAMERAS):
        raise ValueError(f"scene.camera: expected one of {_names(CAMERAS)}, got {type(scene.camera).__name__}")
    for i, light in enumerate(scene.lights or []):
        if not isinstance(light, LIGHTS):
            raise ValueError(f"scene.lights[{i}]: expected one of {_names(LIGHTS)}, got {type(light).__name__}")
    n = len(scene.materials)
    if not n:
        raise ValueError("scene.materials is empty: every shape needs a material")

    def index(value, where: str) -> None:
        if isinstance(value, bool) or not isinstance(value, (int,)) and not hasattr(value, "__index__"):
            raise ValueError(f"{where}: material must be an integer index, got {value!r}")
        if not 0 <= int(value) < n:
            raise ValueError(f"{where}: material {int(value)} out of range (the scene has {n} materials, "
                             f"0..{n - 1})")

    for i, mat in enumerate(scene.materials):
        where = f"scene.materials[{i}] ({type(mat).__name__})"
        if isinstance(mat, TEXTURES):
            index(mat.material1, where + " material1")
            index(mat.material2, where + " material2")
        elif not isinstance(mat, (PhongMaterial, *PHYSICAL)):
            raise ValueError(f"scene.materials[{i}]: expected a PhongMaterial, a solid texture ({_names(TEXTURES)}) "
                             f"or a physically based material ({_names(PHYSICAL)}), got {type(mat).__name__}")

    # (object, where, the ids of the Groups and Transforms above it): a shared subtree is fine, a cycle is not
    stack: list[tuple[object, str, tuple[int, ...]]] = [(scene.group, "scene.group", ())]
    while stack:
        obj, where, above = stack.pop()
        if isinstance(obj, (Group, Transform)):
            if id(obj) in above:
                raise ValueError(f"{where}: a {type(obj).__name__} that contains itself (a cycle in the scene tree)")
            if len(above) >= MAX_NESTING:
                raise ValueError(f"scene.group: Groups and Transforms nested more than {MAX_NESTING} levels deep")
            above = above + (id(obj),)
        if isinstance(obj, Group):
            if not isinstance(obj.objects, (list, tuple)):
                raise ValueError(f"{where}.objects: expected a list, got {type(obj.objects).__name__}")
            stack.extend((child, f"{where}.objects[{k}]", above)
                         for k, child in reversed(list(enumerate(obj.objects))))
        elif isinstance(obj, Transform):
            stack.append((obj.object, f"{where}.object", above))
        elif isinstance(obj, SHAPES):
            index(obj.material, f"{where} ({type(obj).__name__})")
        else:
            raise ValueError(f"{where}: expected a Group, Transform or one of {_names(SHAPES)}, got "
                             f"{type(obj).__name__}")
