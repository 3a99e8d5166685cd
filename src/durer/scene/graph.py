"""The scene description: Group, Transform and Scene. Plain data, no maths (see compile.py)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .lights import DirectionalLight, PointLight
from .materials import PhongMaterial
from .shapes import Cylinder, Disk, Plane, Sphere, Triangle, TriangleMesh


@dataclass
class Group:
    """A list of objects intersected together (the course's Group)."""

    objects: list = field(default_factory=list)


@dataclass
class Transform:
    """An object seen through the affine `matrix` (4x4, object space to world space)."""

    matrix: np.ndarray
    object: object

    def __post_init__(self):
        try:
            self.matrix = np.asarray(self.matrix, dtype=np.float64).reshape(4, 4)
        except (TypeError, ValueError):
            raise ValueError(f"transform matrix must be 4x4 numbers, got {np.shape(self.matrix)}") from None
        if not np.isfinite(self.matrix).all():
            raise ValueError("transform matrix must be finite")
        if abs(np.linalg.det(self.matrix[:3, :3])) < 1e-300:
            raise ValueError("transform matrix is singular")


Object3D = Group | Transform | Sphere | Disk | Cylinder | Plane | Triangle | TriangleMesh
Light = DirectionalLight | PointLight


@dataclass
class Scene:
    """Everything a render needs: a camera, the background, lights, materials and the root group.

    Shapes refer to materials by index into `materials`.
    """

    camera: object
    group: Group
    materials: list = field(default_factory=lambda: [PhongMaterial()])
    lights: list | None = None  # None: no lights at all, objects show their flat colour (assignment 1)
    background_color: np.ndarray = (0.0, 0.0, 0.0)
    ambient_light: np.ndarray = (0.0, 0.0, 0.0)
    source: str | None = None
    # Path tracer additions (Mitsuba scenes): light from escaping rays (lights.ConstantEnvironment), whether light
    # colours are radiometric (Mitsuba: point intensity W/sr, directional irradiance) rather than the course's
    # (scaled by pi so a diffuse surface looks as in the ray caster, rendering/emitters.py), and the render's
    # defaults the scene carries (integrator, max_depth, rr_depth, hide_emitters, samples, filter, filter_radius,
    # filter_b, filter_c, width, height), which explicit render options override.
    environment: object | None = None
    radiometric_lights: bool = False
    render_defaults: dict = field(default_factory=dict)

    def __post_init__(self):
        self.background_color = np.asarray(self.background_color, dtype=np.float64).reshape(3)
        self.ambient_light = np.asarray(self.ambient_light, dtype=np.float64).reshape(3)
