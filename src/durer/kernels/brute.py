"""The lecture's loop, with no acceleration: for every ray, for every object, keep the closest hit with t > t_min.

`closest_of_all` and `any_of_all` are that loop for one ray; the kernels run it for every ray, in parallel. Kept as
the reference every accelerator is tested against, and as `--accel brute` for learners to read and time.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .common import MISS, PLANE, SPHERE, TRIANGLE
from .intersect import intersect_plane, intersect_triangle, sphere_hit_in_object_space


@nb.njit(cache=True)
def closest_of_all(o, d, t_min, t_max, tris, sph_center, sph_radius, sph_w2o, pl_normal, pl_offset):
    """One ray against every primitive: (t, kind, primitive, u, v) of the closest hit in (t_min, t_max), or
    (inf, MISS, -1, 0, 0). Each test is asked only for hits closer than the best so far."""
    best, kind, prim, bu, bv = t_max, MISS, -1, 0.0, 0.0
    for k in range(tris.shape[0]):
        t, u, v = intersect_triangle(o[0], o[1], o[2], d[0], d[1], d[2], tris[k], t_min, best)
        if t < best:
            best, kind, prim, bu, bv = t, TRIANGLE, k, u, v
    for k in range(sph_radius.shape[0]):
        t = sphere_hit_in_object_space(o, d, sph_center[k], sph_radius[k], sph_w2o[k], t_min, best)
        if t < best:
            best, kind, prim = t, SPHERE, k
    for k in range(pl_offset.shape[0]):
        nrm = pl_normal[k]
        t = intersect_plane(o[0], o[1], o[2], d[0], d[1], d[2], nrm[0], nrm[1], nrm[2], pl_offset[k], t_min, best)
        if t < best:
            best, kind, prim = t, PLANE, k
    return (np.inf if kind == MISS else best), kind, prim, bu, bv


@nb.njit(cache=True)
def any_of_all(o, d, t_min, t_max, tris, sph_center, sph_radius, sph_w2o, pl_normal, pl_offset):
    """One ray: is anything hit in (t_min, t_max)? Stops at the first hit (planes, then spheres, then triangles)."""
    for k in range(pl_offset.shape[0]):
        nrm = pl_normal[k]
        if intersect_plane(o[0], o[1], o[2], d[0], d[1], d[2], nrm[0], nrm[1], nrm[2], pl_offset[k],
                           t_min, t_max) < np.inf:
            return True
    for k in range(sph_radius.shape[0]):
        if sphere_hit_in_object_space(o, d, sph_center[k], sph_radius[k], sph_w2o[k], t_min, t_max) < np.inf:
            return True
    for k in range(tris.shape[0]):
        if intersect_triangle(o[0], o[1], o[2], d[0], d[1], d[2], tris[k], t_min, t_max)[0] < np.inf:
            return True
    return False


@nb.njit(cache=True, parallel=True)
def closest_hit_all(origins, directions, t_min, t_max, tris, sph_center, sph_radius, sph_w2o,
                    pl_normal, pl_offset, t_out, kind_out, prim_out, u_out, v_out):
    """Fill t (inf on a miss), kind (MISS, TRIANGLE, SPHERE, PLANE), primitive id and barycentrics of every ray."""
    for i in nb.prange(origins.shape[0]):
        t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = closest_of_all(
            origins[i], directions[i], t_min[i], t_max[i], tris, sph_center, sph_radius, sph_w2o, pl_normal, pl_offset)


@nb.njit(cache=True, parallel=True)
def any_hit_all(origins, directions, t_min, t_max, tris, sph_center, sph_radius, sph_w2o,
                pl_normal, pl_offset, out):
    """out[i] = True when ray i hits anything with t_min < t < t_max."""
    for i in nb.prange(origins.shape[0]):
        out[i] = any_of_all(origins[i], directions[i], t_min[i], t_max[i], tris, sph_center, sph_radius, sph_w2o,
                            pl_normal, pl_offset)
