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
(accel/caps.py), a second tree that the same ray crosses in the same pass.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..bvh.items import unit_normal
from ..bvh.layout import leaf_range
from ..bvh.single import node_dists4, prefetch_children, ray_setup
from ..common import JIT
from ..intersect import watertight_triangle
from .closest import POINTS_PER_BLOCK
from .winding import away_from, lane_bound, object_point, sphere_winding

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


@nb.njit(**JIT)
def ray_windings(points, tilt, center, t_eps, inst_root, inst_w2o, inst_sign, inst_sphere, bounds, child, leaf_prim,
                 leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, caps, cap_lanes, w_out, unsure, bound, blk0,
                 blk1):
    """w_out[i] = the winding number of point i (blocks blk0..blk1) over all instances: for a mesh instance the
    signed count of one ray's crossings (signed_crossings, along tilt + the unit direction from `center` to the
    point, moved into the instance's object space, times the instance's inst_sign), for a sphere instance 1
    inside, 1/2 on the surface (as winding_numbers_instances). unsure[i] = True when a crossing is not clean
    (module docstring): w_out[i] is then not to be used. `caps`, a second tree's arguments in the same order
    (inst_root .. sph_w2o, then its stack size; no instances: none), is crossed by the same ray and its count
    added (accel/caps.py), and bound[i] = winding.lane_bounds' bound on its winding number from cap_lanes. Every
    mesh instance of the two together must be closed and consistently oriented (the caller checks)."""
    n = points.shape[0]
    c_root, c_w2o, c_sign, _, c_bounds, c_child, c_prim, c_tri, _, _, _, c_stack = caps
    stack = np.empty(max(stack_size, c_stack, 1) * 4, np.int32)
    for i in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK)):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        ax, ay, az = away_from(center, px, py, pz)
        rx, ry, rz = tilt[0] + ax, tilt[1] + ay, tilt[2] + az
        w = 0.0
        bad = False
        for k in range(inst_root.shape[0]):
            s, m = inst_sphere[k], inst_w2o[k]
            ox, oy, oz = object_point(m, px, py, pz)
            if s >= 0:
                w += sphere_winding(ox - sph_center[s, 0], oy - sph_center[s, 1], oz - sph_center[s, 2], sph_radius[s])
                continue
            dx = m[0, 0] * rx + m[0, 1] * ry + m[0, 2] * rz
            dy = m[1, 0] * rx + m[1, 1] * ry + m[1, 2] * rz
            dz = m[2, 0] * rx + m[2, 1] * ry + m[2, 2] * rz
            # from just behind the point, so that a surface through it is met (at |t| <= t_eps: unsure)
            signed, bad = signed_crossings(bounds, child, inst_root[k], leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz,
                                           t_eps, stack)
            if bad:
                break
            w += inst_sign[k] * signed
        if not bad and c_root.shape[0] > 0:
            for k in range(c_root.shape[0]):  # the caps (meshes only), as above
                m = c_w2o[k]
                ox, oy, oz = object_point(m, px, py, pz)
                dx = m[0, 0] * rx + m[0, 1] * ry + m[0, 2] * rz
                dy = m[1, 0] * rx + m[1, 1] * ry + m[1, 2] * rz
                dz = m[2, 0] * rx + m[2, 1] * ry + m[2, 2] * rz
                signed, bad = signed_crossings(c_bounds, c_child, c_root[k], c_prim, c_tri, ox, oy, oz, dx, dy, dz,
                                               t_eps, stack)
                if bad:
                    break
                w += c_sign[k] * signed
            bound[i] = lane_bound(cap_lanes, px, py, pz)
        w_out[i] = w
        unsure[i] = bad
