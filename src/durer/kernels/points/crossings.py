"""Winding numbers of closed meshes from one ray (Numba): the signed crossing count, and when it cannot be trusted.

For a closed, consistently oriented mesh (every edge used as often in one direction as in the other) the generalized
winding number of a point off the surface is an integer: the number of times a ray from the point leaves through the
surface minus the times it enters (Jacobson et al. 2013, sec. 3). One ray per point then gives what the winding rule
of kernels/points/winding.py gives, at the cost of a parity test, where the ray crosses the surface cleanly. It may
not where it touches an edge or a vertex (there the count rests on the watertight test's tie-break and on rounding),
runs along a triangle, or starts on the surface; a point whose ray comes closer than EDGE_MARGIN (barycentric) to an
edge, whose direction is within GRAZE of a triangle's plane, or which lies within `t_eps` of a surface it meets (the
ray starts t_eps behind the point to find it), is marked unsure, and the caller evaluates the winding rule there
(accel/distance.py). A point exactly on an edge or a vertex where the surface folds away from its ray meets no
crossing there and keeps the ray's answer: on the surface the winding number is not an integer and the winding
rule's value there is rounding noise (tests/test_kernels_points_crossings.py). An open mesh is closed by a cap
(accel/caps.py), a second tree that the same ray crosses in the same pass. The points' rays are walked in
packets by kernels/points/crossing_packets.py, which falls back on this one-ray walk.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..bvh.items import unit_normal
from ..bvh.layout import leaf_range
from ..bvh.single import node_dists4, prefetch_children, ray_setup
from ..common import JIT
from ..intersect import watertight_triangle

EDGE_MARGIN = 1e-6  # barycentric distance to an edge below which a crossing is not trusted
GRAZE = 1e-6        # |cos| between the ray and a triangle's normal below which a crossing is not trusted


@nb.njit(**JIT, inline="always")
def signed_crossings(bounds, child, root, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_eps, stack):
    """(the signed count of the ray's crossings of the tree at `root`, whether one of them is not clean): + where
    the ray leaves through a triangle's counter-clockwise side. The ray starts t_eps (in world units) behind the
    point. Every hit single.blas_all would find (the same watertight test), none stored: a hit's side and its
    grazing test come from the triangle's unit normal, computed from the leaf's vertices as the mesh's stored
    normals are (items.unit_normal, the same bits), so no random read of a normals array; the walk stops at the
    first crossing that is not clean, or at a sphere slot (not a mesh's part). The queued walk of
    kernels/bvh/queued.py, written out."""
    dl = np.sqrt(dx * dx + dy * dy + dz * dz)
    t_min = -t_eps / dl
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    stack[0] = root
    sp = 1
    signed = 0.0
    while sp > 0:
        sp -= 1
        node = stack[sp]
        if node >= 0:
            prefetch_children(bounds, leaf_tri, child, node)
            d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, np.inf)
            stack[sp] = child[node, 0]
            sp += np.int64(d0 < np.inf)
            stack[sp] = child[node, 1]
            sp += np.int64(d1 < np.inf)
            stack[sp] = child[node, 2]
            sp += np.int64(d2 < np.inf)
            stack[sp] = child[node, 3]
            sp += np.int64(d3 < np.inf)
            continue
        first, end = leaf_range(node)
        for j in range(first, end):
            if leaf_prim[j] < 0:  # a sphere slot: cannot happen in a mesh's tree; be safe
                return signed, True
            t, u, v = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, np.inf)
            if t == np.inf:
                continue
            b = j * 9
            x0, y0, z0 = np.float64(leaf_tri[b]), np.float64(leaf_tri[b + 1]), np.float64(leaf_tri[b + 2])
            nx, ny, nz = unit_normal(np.float64(leaf_tri[b + 3]) - x0, np.float64(leaf_tri[b + 4]) - y0,
                                     np.float64(leaf_tri[b + 5]) - z0, np.float64(leaf_tri[b + 6]) - x0,
                                     np.float64(leaf_tri[b + 7]) - y0, np.float64(leaf_tri[b + 8]) - z0)
            c = (dx * nx + dy * ny + dz * nz) / dl
            if min(u, min(v, 1.0 - u - v)) < EDGE_MARGIN or abs(c) < GRAZE or abs(t) * dl <= t_eps:
                return signed, True
            signed += 1.0 if c > 0.0 else -1.0
    return signed, False
