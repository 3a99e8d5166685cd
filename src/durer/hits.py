"""Hit records for a batch of rays, and the accelerator interface every ray query goes through."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .compile import PLANE, SPHERE, TRIANGLE, CompiledScene
from .kernels.brute import any_hit_all, closest_hit_all


@dataclass
class Hits:
    """The closest hit of each ray: t (inf on a miss), kind (0 miss, 1 triangle, 2 sphere, 3 plane),
    prim (index within its kind, -1 on a miss) and barycentrics u, v (triangles only)."""

    t: np.ndarray
    kind: np.ndarray
    prim: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        return self.kind != 0

    @classmethod
    def empty(cls, n: int) -> Hits:
        return cls(np.empty(n), np.empty(n, np.int8), np.empty(n, np.int32), np.empty(n), np.empty(n))


def _per_ray(value, n: int) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    return np.ascontiguousarray(np.broadcast_to(a, (n,)))


class BruteForce:
    """Tests every ray against every primitive; the reference that accelerators must agree with."""

    name = "brute"

    def __init__(self, cs: CompiledScene):
        self.cs = cs

    def _geometry(self):
        cs = self.cs.flat  # instances flattened (same triangle ids)
        return (cs.triangles, cs.sphere_center, cs.sphere_radius, cs.sphere_world_to_object,
                cs.plane_normal, cs.plane_offset)

    def closest_hit(self, origins, directions, t_min=0.0, t_max=np.inf) -> Hits:
        n = len(origins)
        h = Hits.empty(n)
        closest_hit_all(np.ascontiguousarray(origins, dtype=np.float64),
                        np.ascontiguousarray(directions, dtype=np.float64),
                        _per_ray(t_min, n), _per_ray(t_max, n), *self._geometry(), h.t, h.kind, h.prim, h.u, h.v)
        return h

    def any_hit(self, origins, directions, t_min=0.0, t_max=np.inf) -> np.ndarray:
        n = len(origins)
        out = np.empty(n, dtype=np.bool_)
        any_hit_all(np.ascontiguousarray(origins, dtype=np.float64),
                    np.ascontiguousarray(directions, dtype=np.float64),
                    _per_ray(t_min, n), _per_ray(t_max, n), *self._geometry(), out)
        return out


def geometric_normals(cs: CompiledScene, hits: Hits, points: np.ndarray) -> np.ndarray:
    """Unit world-space normals (N,3) at the hit points, as the surface defines them (not flipped to the ray).

    Triangles: (v1 - v0) x (v2 - v0); spheres: the object-space radial direction through the inverse transpose;
    planes: their normal. Misses get (0, 0, 0).
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
