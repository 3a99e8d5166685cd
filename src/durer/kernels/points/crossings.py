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

from ..bvh.single import blas_all
from ..common import JIT, TRIANGLE
from .closest import POINTS_PER_BLOCK
from .winding import away_from, lane_bound, object_point, sphere_winding

EDGE_MARGIN = 1e-6  # barycentric distance to an edge below which a crossing is not trusted
GRAZE = 1e-6        # |cos| between the ray and a triangle's normal below which a crossing is not trusted
MAX_HITS = 64       # crossings kept per ray for the checks; a ray with more marks its point unsure


@nb.njit(**JIT)
def ray_windings(points, tilt, center, t_eps, inst_root, inst_w2o, inst_sign, inst_sphere, inst_shape, tri_off,
                 normals, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, caps,
                 cap_lanes, w_out, unsure, bound, blk0, blk1):
    """w_out[i] = the winding number of point i (blocks blk0..blk1) over all instances: for a mesh instance the
    signed count of one ray's crossings (along tilt + the unit direction from `center` to the point, moved into
    the instance's object space: + where it leaves through the triangle's counter-clockwise side, times the
    instance's inst_sign), for a sphere instance 1 inside, 1/2 on the surface (as winding_numbers_instances).
    unsure[i] = True when a crossing is not clean (module docstring): w_out[i] is then not to be used. `caps`, a
    second tree's arguments in the same order (inst_root .. sph_w2o, then its stack size; no instances: none),
    is crossed by the same ray and its count added (accel/caps.py), and bound[i] = winding.lane_bounds' bound on
    its winding number from cap_lanes. Every mesh instance of the two together must be closed and consistently
    oriented (the caller checks)."""
    n = points.shape[0]
    (c_root, c_w2o, c_sign, _, c_shape, c_off, c_normals, c_bounds, c_child, c_prim, c_tri, c_center, c_radius,
     c_sw2o, c_stack) = caps
    stack = np.empty(max(stack_size, c_stack, 1) * 4, np.int32)
    h_t, h_u, h_v = np.empty(MAX_HITS), np.empty(MAX_HITS), np.empty(MAX_HITS)
    h_p, h_k = np.empty(MAX_HITS, np.int32), np.empty(MAX_HITS, np.int8)
    for i in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK)):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        ax, ay, az = away_from(center, px, py, pz)
        rx, ry, rz = tilt[0] + ax, tilt[1] + ay, tilt[2] + az
        w = 0.0
        bad = False
        for k in range(inst_root.shape[0]):  # each tree written out: an inlined helper cost 1.27x
            s, m = inst_sphere[k], inst_w2o[k]
            ox, oy, oz = object_point(m, px, py, pz)
            if s >= 0:
                w += sphere_winding(ox - sph_center[s, 0], oy - sph_center[s, 1], oz - sph_center[s, 2], sph_radius[s])
                continue
            dx = m[0, 0] * rx + m[0, 1] * ry + m[0, 2] * rz
            dy = m[1, 0] * rx + m[1, 1] * ry + m[1, 2] * rz
            dz = m[2, 0] * rx + m[2, 1] * ry + m[2, 2] * rz
            dl = np.sqrt(dx * dx + dy * dy + dz * dz)
            # from just behind the point, so that a surface through it is met (at |t| <= t_eps: unsure)
            count = blas_all(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                             ox, oy, oz, dx, dy, dz, -t_eps / dl, np.inf, stack, h_t, h_p, h_k, h_u, h_v, 0)
            if count > MAX_HITS:
                bad = True
                break
            base = tri_off[inst_shape[k]]
            signed = 0.0
            for h in range(count):
                if h_k[h] != TRIANGLE:  # a sphere placed as a mesh's part cannot happen; be safe
                    bad = True
                    break
                f = base + h_p[h]
                c = (dx * normals[f, 0] + dy * normals[f, 1] + dz * normals[f, 2]) / dl
                u, v = h_u[h], h_v[h]
                near_edge = min(u, min(v, 1.0 - u - v)) < EDGE_MARGIN
                if near_edge or abs(c) < GRAZE or abs(h_t[h]) * dl <= t_eps:
                    bad = True
                    break
                signed += 1.0 if c > 0.0 else -1.0
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
                dl = np.sqrt(dx * dx + dy * dy + dz * dz)
                count = blas_all(c_bounds, c_child, c_root[k], c_prim, c_tri, c_center, c_radius, c_sw2o,
                                 ox, oy, oz, dx, dy, dz, -t_eps / dl, np.inf, stack, h_t, h_p, h_k, h_u, h_v, 0)
                bad = count > MAX_HITS
                base = c_off[c_shape[k]]
                signed = 0.0
                for h in range(min(count, MAX_HITS)):
                    f = base + h_p[h]
                    c = (dx * c_normals[f, 0] + dy * c_normals[f, 1] + dz * c_normals[f, 2]) / dl
                    u, v = h_u[h], h_v[h]
                    bad |= min(u, min(v, 1.0 - u - v)) < EDGE_MARGIN or abs(c) < GRAZE or abs(h_t[h]) * dl <= t_eps
                    signed += 1.0 if c > 0.0 else -1.0
                if bad:
                    break
                w += c_sign[k] * signed
            bound[i] = lane_bound(cap_lanes, px, py, pz)
        w_out[i] = w
        unsure[i] = bad
