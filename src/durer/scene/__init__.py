"""The scene description: plain data that says what is in the world, with no intersection maths.

`graph` holds the Scene and its object tree (Group, Transform), `shapes` the primitives, `materials` and `textures`
how surfaces look, `lights` the lights, `cameras` how rays leave the eye, `transforms` the course's 4x4 matrices.
"""

from .cameras import FisheyeCamera, OrthographicCamera, PanoramaCamera, PerspectiveCamera
from .graph import Group, Scene, Transform
from .lights import DirectionalLight, PointLight
from .materials import Material, PhongMaterial
from .shapes import Cylinder, Disk, Plane, Sphere, Triangle, TriangleMesh
from .textures import Checkerboard, Marble, Noise, Wood

__all__ = [
    "Checkerboard", "Cylinder", "DirectionalLight", "Disk", "FisheyeCamera", "Group", "Marble", "Material", "Noise",
    "OrthographicCamera", "PanoramaCamera", "PerspectiveCamera", "PhongMaterial", "Plane", "PointLight", "Scene",
    "Sphere", "Transform", "Triangle", "TriangleMesh", "Wood",
]
