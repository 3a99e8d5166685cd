"""Hit records for a batch of rays, the Accelerator protocol every accelerator meets, and what a hit means for
the surface (normals, materials)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..kernels.common import CYLINDER_CODE, DISK_CODE, MISS, PLANE, SPHERE, TRIANGLE
from .compile import CompiledScene


@dataclass
class Hits:
    """The closest hit of each ray: t (inf on a miss), kind (MISS, TRIANGLE, SPHERE or PLANE of kernels/bvh/layout.py),
    prim (index within its kind, -1 on a miss) and barycentrics u, v (triangles only)."""

    t: np.ndarray
    kind: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return self.kind != MISS

    @classmethod
    def empty(cls, n: int) -> Hits:
        return cls(np.empty(n), np.empty(n, np.int8), np.empty(n, np.int32), np.empty(n), np.empty(n))


def per_ray(value, n: int) -> np.ndarray:
    """A scalar or (n,) interval bound as a contiguous, writable float64 (n,) array. Always writable: Numba
    compiles (and caches) a kernel once per argument type, and a read-only array is another type."""
    a = np.asarray(value, dtype=np.float64)
    if a.shape == (n,) and a.flags.c_contiguous and a.flags.writeable:
        return a
    return np.array(np.broadcast_to(a, (n,)))


def ray_arrays(origins, directions, t_min, t_max) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A query's rays as the kernels take them: origins and directions (N, 3) contiguous float64, and per-ray
    t_min and t_max (per_ray)."""
    n = len(origins)
    return (np.ascontiguousarray(origins, dtype=np.float64), np.ascontiguousarray(directions, dtype=np.float64),
            per_ray(t_min, n), per_ray(t_max, n))


class QueriedOnly:
    """Base of the accelerators that integrators reach only through closest_hit / any_hit: no tree of theirs is
    walked inside a fused kernel (brute force and the grid have none; counted rays must all pass the counter)."""

    def kernel_tree(self) -> None:
        """None (the Accelerator protocol): integrators use closest_hit / any_hit."""
        return None


class Accelerator(Protocol):
    """What integrators ask of a scene's geometry: BruteForce, BVHAccelerator and GridAccelerator answer it.

    Rays are origins and directions (N, 3); t_min and t_max are scalars or (N,) arrays, and a hit counts when
    t_min < t < t_max. `width` > 0 says the rays are an image that wide, row by row (an accelerator may use it to
    trace 4 x 4 tiles together, or ignore it). Every accelerator returns the same t to the bit for the same ray.
    """

    name: str
    cs: CompiledScene

    def closest_hit(self, origins: np.ndarray, directions: np.ndarray, t_min=0.0, t_max=np.inf,
                    width: int = 0) -> Hits:
        """The closest hit of each ray."""
        ...

    def any_hit(self, origins: np.ndarray, directions: np.ndarray, t_min=0.0, t_max=np.inf,
                width: int = 0) -> np.ndarray:
        """(N,) bool: does the ray hit anything in (t_min, t_max)? May stop at the first hit found."""
        ...

    def kernel_tree(self) -> tuple | None:
        """The accelerator as the positional arrays of the one-level BVH walk that fused kernels call inside their
        own loops (kernels/bvh/trace.py order: node bounds, children, leaf primitives, leaf triangles, sphere
        centres, radii, world-to-object matrices, plane normals, offsets, stack size), or None when its queries
        must go through closest_hit / any_hit (brute force, the grid, counters, instanced meshes). Integrators
        with a fused kernel (rendering/path.py) use it when given, and the queries otherwise: same hits."""
        ...


def geometric_normals(cs: CompiledScene, hits: Hits, points: np.ndarray) -> np.ndarray:
    """Unit world-space normals (N,3) at the hit points, as the surface defines them (not flipped to the ray).

    Triangles: (v1 - v0) x (v2 - v0); spheres: the object-space radial direction through the inverse transpose
    (disks: object +z, cylinders: (x, y, 0) outward); planes: their normal. Misses get (0, 0, 0).
    """
    n = np.zeros((len(hits.t), 3))
    m = hits.kind == TRIANGLE
    if m.any():
        tri = cs.triangle(hits.prim[m])
        n[m] = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    m = hits.kind == SPHERE
    if m.any():
        k = hits.prim[m]
        w2o = cs.sphere_world_to_object[k]
        p_obj = np.einsum("nij,nj->ni", w2o[:, :, :3], points[m]) + w2o[:, :, 3]
        n_obj = p_obj - cs.sphere_center[k]
        code = cs.sphere_radius[k]
        n_obj[code == CYLINDER_CODE, 2] = 0.0
        n_obj[code == DISK_CODE] = (0.0, 0.0, 1.0)
        n[m] = np.einsum("nij,nj->ni", cs.sphere_normal_matrix[k], n_obj)
    m = hits.kind == PLANE
    if m.any():
        n[m] = cs.plane_normal[hits.prim[m]]
    length = np.linalg.norm(n, axis=1, keepdims=True)
    np.divide(n, length, out=n, where=length > 0)
    return n


def hit_materials(cs: CompiledScene, hits: Hits) -> np.ndarray:
    """Material index of each hit (-1 on a miss)."""
    mat = np.full(len(hits.t), -1, dtype=np.int32)
    m = hits.kind == TRIANGLE
    if m.any():
        mat[m] = cs.triangle_materials(hits.prim[m])
    for kind, table in ((SPHERE, cs.sphere_material), (PLANE, cs.plane_material)):
        m = hits.kind == kind
        if m.any():
            mat[m] = table[hits.prim[m]]
    return mat


def object_kind(cs: CompiledScene, kind: int, prim: int) -> str:
    """The name of what a hit struck: "triangle", "sphere", "disk", "cylinder" or "plane" ("" for a miss). Disks and
    cylinders are hits of kind SPHERE, told apart by their slot's radius code (DISK_CODE, CYLINDER_CODE)."""
    if kind == SPHERE:
        code = cs.sphere_radius[prim]
        return "disk" if code == DISK_CODE else "cylinder" if code == CYLINDER_CODE else "sphere"
    return {TRIANGLE: "triangle", PLANE: "plane"}.get(kind, "")
