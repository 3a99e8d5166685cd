"""Closest-hit and any-hit over every primitive, parallel over rays: the lecture's loop, with no acceleration.

Kept as the reference the accelerators are tested against, and used for scenes too small to need one.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .intersect import intersect_plane, intersect_triangle, sphere_hit_in_object_space
from .layout import PLANE, SPHERE, TRIANGLE


@nb.njit(cache=True, parallel=True)
def closest_hit_all(origins, directions, t_min, t_max, tris, sph_center, sph_radius, sph_w2o,
                    pl_normal, pl_offset, t_out, kind_out, prim_out, u_out, v_out):
    """Fill t (inf on a miss), kind (0 miss, 1 triangle, 2 sphere, 3 plane), primitive id and barycentrics."""
    n = origins.shape[0]
    for i in nb.prange(n):
        o = origins[i]
        d = directions[i]
        lo = t_min[i]
        best = t_max[i]
        kind = 0
        prim = -1
        bu = 0.0
        bv = 0.0
        for k in range(tris.shape[0]):
            t, u, v = intersect_triangle(o[0], o[1], o[2], d[0], d[1], d[2], tris[k], lo, best)
            if t < best:
                best, kind, prim, bu, bv = t, TRIANGLE, k, u, v
        for k in range(sph_radius.shape[0]):
            t = sphere_hit_in_object_space(o, d, sph_center[k], sph_radius[k], sph_w2o[k], lo, best)
            if t < best:
                best, kind, prim = t, SPHERE, k
        for k in range(pl_offset.shape[0]):
            nrm = pl_normal[k]
            t = intersect_plane(o[0], o[1], o[2], d[0], d[1], d[2], nrm[0], nrm[1], nrm[2], pl_offset[k], lo, best)
            if t < best:
                best, kind, prim = t, PLANE, k
        if kind == 0:
            t_out[i] = np.inf
        else:
            t_out[i] = best
        kind_out[i] = kind
        prim_out[i] = prim
        u_out[i] = bu
        v_out[i] = bv


@nb.njit(cache=True, parallel=True)
def any_hit_all(origins, directions, t_min, t_max, tris, sph_center, sph_radius, sph_w2o,
                pl_normal, pl_offset, out):
    """out[i] = True when ray i hits anything with t_min < t < t_max; stops at the first hit found."""
    n = origins.shape[0]
    for i in nb.prange(n):
        o = origins[i]
        d = directions[i]
        lo = t_min[i]
        hi = t_max[i]
        hit = False
        for k in range(pl_offset.shape[0]):
            nrm = pl_normal[k]
            if intersect_plane(o[0], o[1], o[2], d[0], d[1], d[2], nrm[0], nrm[1], nrm[2], pl_offset[k],
                               lo, hi) < np.inf:
                hit = True
                break
        if not hit:
            for k in range(sph_radius.shape[0]):
                if sphere_hit_in_object_space(o, d, sph_center[k], sph_radius[k], sph_w2o[k], lo, hi) < np.inf:
                    hit = True
                    break
        if not hit:
            for k in range(tris.shape[0]):
                t, _, _ = intersect_triangle(o[0], o[1], o[2], d[0], d[1], d[2], tris[k], lo, hi)
                if t < np.inf:
                    hit = True
                    break
        out[i] = hit
