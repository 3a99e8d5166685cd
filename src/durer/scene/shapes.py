"""Shape descriptions: Sphere, Disk, Cylinder, Plane, Triangle, TriangleMesh. Plain data; the maths lives in
kernels/."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .values import finite_triple


def _vec3(v, what: str = "vector") -> np.ndarray:
    """A finite float64 3-vector, or a ValueError naming what was wrong."""
    return finite_triple(v, what)


@dataclass
class Sphere:
    """All points at distance `radius` from `center`."""

    center: np.ndarray
    radius: float
    material: int = 0

    def __post_init__(self):
        self.center = _vec3(self.center, "sphere center")
        self.radius = float(self.radius)
        if not (self.radius > 0 and np.isfinite(self.radius)):
            raise ValueError(f"sphere radius must be positive, got {self.radius}")


@dataclass
class Disk:
    """Mitsuba's disk: the unit disk x^2 + y^2 <= 1 of the plane z = 0, normal +z; a Transform places and sizes
    it. Texture coordinates (r, phi / 2 pi), as Mitsuba's."""

    material: int = 0


@dataclass
class Cylinder:
    """Mitsuba's cylinder: the open tube (no caps) of `radius` around the segment p0 -> p1, normals outward.
    Texture coordinates (phi / 2 pi, fraction of the way from p0 to p1), as Mitsuba's."""

    p0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    p1: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    radius: float = 1.0
    material: int = 0

    def __post_init__(self):
        self.p0, self.p1 = _vec3(self.p0, "cylinder p0"), _vec3(self.p1, "cylinder p1")
        self.radius = float(self.radius)
        if not (self.radius > 0 and np.isfinite(self.radius)):
            raise ValueError(f"cylinder radius must be positive, got {self.radius}")
        if not np.linalg.norm(self.p1 - self.p0) > 0:
            raise ValueError("cylinder p0 and p1 must differ")

    def object_matrix(self) -> np.ndarray:
        """The 4x4 matrix from the unit cylinder (radius 1, z from 0 to 1) to this one, with Mitsuba's frame
        about the axis (coordinate_system of the axis direction), so that texture coordinates agree."""
        axis = self.p1 - self.p0
        length = float(np.linalg.norm(axis))
        z = axis / length
        sign = 1.0 if z[2] >= 0 else -1.0  # Duff et al.'s orthonormal basis, as Mitsuba's coordinate_system
        a = -1.0 / (sign + z[2])
        b = z[0] * z[1] * a
        x = np.array([1.0 + sign * z[0] * z[0] * a, sign * b, -sign * z[0]])
        y = np.array([b, sign + z[1] * z[1] * a, -z[1]])
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x * self.radius, y * self.radius, axis, self.p0
        return m


@dataclass
class Plane:
    """The infinite plane of points P with dot(P, normal) = offset (the normal need not be unit length)."""

    normal: np.ndarray
    offset: float
    material: int = 0

    def __post_init__(self):
        self.normal = _vec3(self.normal, "plane normal")
        self.offset = float(self.offset)
        if not np.isfinite(self.offset):
            raise ValueError(f"plane offset must be finite, got {self.offset}")
        if not self.normal.any():
            raise ValueError("plane normal has zero length")
        biggest = float(np.abs(self.normal).max())
        if not 1e-150 < biggest < 1e150:  # n.P = offset, scaled together so that |n| neither overflows nor vanishes
            self.normal, self.offset = self.normal / biggest, self.offset / biggest


@dataclass
class Triangle:
    """A triangle; counter-clockwise vertex order (seen from the front) gives the front-facing normal."""

    vertex0: np.ndarray
    vertex1: np.ndarray
    vertex2: np.ndarray
    material: int = 0

    def __post_init__(self):
        self.vertex0, self.vertex1, self.vertex2 = (
            _vec3(v, f"triangle vertex{i}") for i, v in enumerate((self.vertex0, self.vertex1, self.vertex2)))


@dataclass
class TriangleMesh:
    """Indexed triangles: `vertices` (V,3) float, `faces` (F,3) int, 0-based; optional texture coordinates
    `uvs` (V,2), one per vertex, for image textures (PBRMaterial.texture), and optional vertex `normals` (V,3),
    interpolated across each triangle for smooth shading (without them, triangles shade flat), and optional vertex
    `colors` (V,3), linear RGB, interpolated across each triangle and multiplying the material's diffuse colour."""

    vertices: np.ndarray
    faces: np.ndarray
    material: int = 0
    source: str | None = field(default=None, compare=False)
    uvs: np.ndarray | None = field(default=None, compare=False)
    normals: np.ndarray | None = field(default=None, compare=False)
    colors: np.ndarray | None = field(default=None, compare=False)

    def __post_init__(self):
        try:
            self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64)
            self.faces = np.ascontiguousarray(self.faces, dtype=np.int64)
        except (TypeError, ValueError) as e:
            raise ValueError(f"mesh vertices must be numbers and faces integers: {e}") from None
        if self.vertices.ndim != 2 or self.vertices.shape[1] != 3:
            raise ValueError(f"mesh vertices must be a (V, 3) array, got shape {self.vertices.shape}")
        if self.faces.size == 0:
            self.faces = self.faces.reshape(0, 3)
        if self.faces.ndim != 2 or self.faces.shape[1] != 3:
            raise ValueError(f"mesh faces must be an (F, 3) array of vertex indices, got shape {self.faces.shape}")
        if not np.isfinite(self.vertices).all():
            raise ValueError("mesh vertices must be finite (found NaN or infinity)")
        if self.faces.size and (self.faces.min() < 0 or self.faces.max() >= len(self.vertices)):
            raise ValueError(
                f"face index out of range: mesh has {len(self.vertices)} vertices, "
                f"faces use {self.faces.min()}..{self.faces.max()}"
            )
        if self.uvs is not None:
            self.uvs = np.ascontiguousarray(self.uvs, dtype=np.float64)
            if self.uvs.shape != (len(self.vertices), 2) or not np.isfinite(self.uvs).all():
                raise ValueError(f"mesh uvs must be finite, one (u, v) pair per vertex: expected "
                                 f"({len(self.vertices)}, 2), got {self.uvs.shape}")
        if self.normals is not None:
            self.normals = np.ascontiguousarray(self.normals, dtype=np.float64)
            if self.normals.shape != self.vertices.shape or not np.isfinite(self.normals).all():
                raise ValueError(f"mesh normals must be finite, one per vertex: expected {self.vertices.shape}, "
                                 f"got {self.normals.shape}")
        if self.colors is not None:
            self.colors = np.ascontiguousarray(self.colors, dtype=np.float64)
            if self.colors.shape != self.vertices.shape or not np.isfinite(self.colors).all():
                raise ValueError(f"mesh colors must be finite RGB, one per vertex: expected {self.vertices.shape}, "
                                 f"got {self.colors.shape}")
