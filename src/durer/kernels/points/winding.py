"""Generalized winding numbers through the BVH (Numba): inside/outside that stays right on meshes with holes.

The winding number of a point p with respect to triangles T_i is w(p) = sum_i Omega_i(p) / (4 pi), Omega_i the
signed solid angle of T_i seen from p (Jacobson, Kavan and Sorkine-Hornung 2013), here by Van Oosterom and
Strackee's formula. For a closed, outward-wound (counter-clockwise seen from outside) mesh it is exactly 1 inside
and 0 outside; on a mesh with holes it varies smoothly and w > 1/2 is the natural inside test.

Evaluated fast with Barill et al. 2018 ("Fast Winding Numbers for Soups and Clouds"): every lane of every BVH
node (a child subtree or a leaf) stores the sum N of its triangles' area vectors A_i, their area-weighted
centroid c, the second moment M = sum_i (c_i - c) (x) A_i (c_i: triangle centroids), a radius rho bounding every
triangle point from c (a leaf's farthest vertex; above, the smaller of the farthest box corner and the
children's spheres) and the unsigned area A. A
lane whose centre is farther than beta * rho from p (beta > 1) is replaced by its Taylor expansion: order 1 the
dipole N . r / |r|^3 (r = c - p), order 2 adds tr(M) / |r|^3 - 3 r . M r / |r|^5 (the linear term, exact since
the integral of x - c over a triangle is its area times c_i - c). Nearer lanes are opened; leaves summed exactly.

Error bounds, per approximated lane, for the kernel K(x) = n . (x - p) / |x - p|^3 of a unit normal n: every
triangle point x is within rho of c and at least d - rho from p (d = |c - p|). Order 1: |grad K| <= 2 / |x - p|^3
gives |error| <= 2 A rho / (d - rho)^3 in solid angle. Order 2: the Taylor remainder is 1/2 v . H v |x - c|^2 with
|v . H v| <= 6 / |x - p|^4 for unit v (H = -3 (n y' + y n') - 3 (n . y) I + 15 (n . y) y y' at |y| = 1, whose
quadratic form is at most 6 = 15 - 6 - 3 in size, reached at n = y = v), so |error| <= 3 A rho^2 / (d - rho)^4.
Divided by 4 pi for w. `winding_numbers_instances` returns the sum of these terms for each point, a bound on
|w_fast - w_exact| up to rounding (tests/test_kernels_points_winding.py checks it).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..bvh.layout import HI_X, HI_Y, HI_Z, LO_X, LO_Y, LO_Z, NODE_FLOATS, WIDTH, leaf_range, leaf_vertices
from ..bvh.single import blas_all
from ..common import JIT
from .closest import POINTS_PER_BLOCK

FOUR_PI = 4.0 * np.pi


@nb.njit(**JIT, inline="always")
def away_from(center, px, py, pz):
    """The unit direction from `center` to the point (zero at the centre itself): a parity ray's base direction."""
    ax, ay, az = px - center[0], py - center[1], pz - center[2]
    norm = np.sqrt(ax * ax + ay * ay + az * az)
    if norm > 0.0:
        ax, ay, az = ax / norm, ay / norm, az / norm
    return ax, ay, az


@nb.njit(**JIT, inline="always")
def object_point(m, px, py, pz):
    """World point (px, py, pz) in an instance's object space, m its (3, 4) world-to-object rows."""
    return (m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3], m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3],
            m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3])


@nb.njit(**JIT, inline="always")
def sphere_winding(dx, dy, dz, r):
    """A sphere's winding number at offset (dx, dy, dz) from its centre: 1 inside, 1/2 on it, 0 outside."""
    d2 = dx * dx + dy * dy + dz * dz
    r2 = r * r
    return 1.0 if d2 < r2 else (0.5 if d2 == r2 else 0.0)


@nb.njit(**JIT, inline="always")
def solid_angle(leaf_tri, o, px, py, pz):
    """Signed solid angle of the triangle at leaf_tri[o:o+9] seen from p (Van Oosterom and Strackee 1983):
    positive when p sees its back (the side its counter-clockwise normal points away from). 0 at a vertex."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = leaf_vertices(leaf_tri, o)
    ax, ay, az = x0 - px, y0 - py, z0 - pz
    bx, by, bz = x1 - px, y1 - py, z1 - pz
    cx, cy, cz = x2 - px, y2 - py, z2 - pz
    la = np.sqrt(ax * ax + ay * ay + az * az)
    lb = np.sqrt(bx * bx + by * by + bz * bz)
    lc = np.sqrt(cx * cx + cy * cy + cz * cz)
    det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    den = la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la \
        + (cx * ax + cy * ay + cz * az) * lb
    return 2.0 * np.arctan2(det, den)


@nb.njit(**JIT, inline="always")
def _add_triangle(leaf_tri, o, acc):
    """Accumulate one triangle into acc: area vector (0:3), area * centroid (3:6), unsigned area (6), and
    centroid (x) area vector (7:16), the raw sums the lane moments are made of."""
    x0, y0, z0, x1, y1, z1, x2, y2, z2 = leaf_vertices(leaf_tri, o)
    ux, uy, uz = x1 - x0, y1 - y0, z1 - z0
    vx, vy, vz = x2 - x0, y2 - y0, z2 - z0
    n0, n1, n2 = 0.5 * (uy * vz - uz * vy), 0.5 * (uz * vx - ux * vz), 0.5 * (ux * vy - uy * vx)
    a = np.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    c0 = (x0 + x1 + x2) / 3.0
    c1 = (y0 + y1 + y2) / 3.0
    c2 = (z0 + z1 + z2) / 3.0
    acc[0] += n0
    acc[1] += n1
    acc[2] += n2
    acc[3] += a * c0
    acc[4] += a * c1
    acc[5] += a * c2
    acc[6] += a
    c = (c0, c1, c2)
    for r in range(3):
        acc[7 + 3 * r] += c[r] * n0
        acc[8 + 3 * r] += c[r] * n1
        acc[9 + 3 * r] += c[r] * n2


@nb.njit(**JIT)
def lane_moments(bounds, child, leaf_prim, leaf_tri, mom_n, mom_c, mom_m, mom_r, mom_a):
    """Moments of every lane (node * 4 + lane) of a tree, i.e. of each child subtree or leaf:

    mom_n (L, 3) sum of area vectors A_i; mom_c (L, 3) area-weighted centroid c; mom_m (L, 9) the second-order
    moment sum_i (c_i - c) (x) A_i (row-major, row = offset); mom_r (L,) a radius around c holding every
    triangle point: a leaf's farthest vertex, else the smaller of the farthest box corner and the sub-lanes'
    spheres (|c_sub - c| + rho_sub); mom_a (L,) unsigned area. Children are numbered after
    their parents (kernels/bvh/build.collapse_bvh4), so one pass from the last node up fills every lane."""
    acc = np.zeros(16)
    for node in range(child.shape[0] - 1, -1, -1):
        base = node * NODE_FLOATS
        for lane in range(WIDTH):
            out = node * WIDTH + lane
            code = child[node, lane]
            acc[:] = 0.0
            if code > 0:
                for sub in range(WIDTH):  # raw sums from the child's lanes' central moments
                    q = code * WIDTH + sub
                    a = mom_a[q]
                    for r in range(3):
                        acc[r] += mom_n[q, r]
                        acc[3 + r] += a * mom_c[q, r]
                        for col in range(3):
                            acc[7 + 3 * r + col] += mom_m[q, 3 * r + col] + mom_c[q, r] * mom_n[q, col]
                    acc[6] += a
            elif code < 0:
                first, end = leaf_range(code)
                for j in range(first, end):
                    if leaf_prim[j] >= 0:
                        _add_triangle(leaf_tri, j * 9, acc)
            lo = (bounds[base + LO_X + lane], bounds[base + LO_Y + lane], bounds[base + LO_Z + lane])
            hi = (bounds[base + HI_X + lane], bounds[base + HI_Y + lane], bounds[base + HI_Z + lane])
            area = acc[6]
            r2 = 0.0
            for r in range(3):
                if code == 0:
                    c = 0.0
                elif area > 0.0:
                    c = acc[3 + r] / area
                else:
                    c = 0.5 * (lo[r] + hi[r])
                mom_c[out, r] = c
                mom_n[out, r] = acc[r]
                e = max(c - lo[r], hi[r] - c) if code != 0 else 0.0
                r2 += e * e
            for r in range(3):
                for col in range(3):
                    mom_m[out, 3 * r + col] = acc[7 + 3 * r + col] - mom_c[out, r] * acc[col]
            mom_a[out] = area
            # the radius: the box's corners bound it; so do the sub-lanes' spheres, or a leaf's vertices exactly
            cx, cy, cz = mom_c[out, 0], mom_c[out, 1], mom_c[out, 2]
            tight = 0.0
            if code > 0:
                for sub in range(WIDTH):
                    q = code * WIDTH + sub
                    if child[code, sub] != 0:
                        dx, dy, dz = mom_c[q, 0] - cx, mom_c[q, 1] - cy, mom_c[q, 2] - cz
                        tight = max(tight, np.sqrt(dx * dx + dy * dy + dz * dz) + mom_r[q])
            elif code < 0:
                first, end = leaf_range(code)
                for j in range(first, end):
                    if leaf_prim[j] >= 0:
                        for v in range(3):
                            o = j * 9 + 3 * v
                            dx = np.float64(leaf_tri[o]) - cx
                            dy = np.float64(leaf_tri[o + 1]) - cy
                            dz = np.float64(leaf_tri[o + 2]) - cz
                            tight = max(tight, dx * dx + dy * dy + dz * dz)
                tight = np.sqrt(tight)
            mom_r[out] = min(np.sqrt(r2), tight)


# the far-field table: one 128-byte row per lane, what the decision and the dipole need in its first 64 bytes
FAR_CX, FAR_CY, FAR_CZ, FAR_RHO, FAR_NX, FAR_NY, FAR_NZ, FAR_AREA = range(8)
FAR_TRACE, FAR_S00, FAR_S11, FAR_S22, FAR_S01, FAR_S02, FAR_S12 = range(8, 15)  # S01.. are doubled (see below)
FAR_FLOATS = 16


@nb.njit(**JIT)
def far_field_table(mom_n, mom_c, mom_m, mom_r, mom_a, table):
    """Pack lane_moments' arrays into table (L, FAR_FLOATS): centre, radius, area vector, area, tr(M) and the
    symmetric part of M (the far field only needs r . M r = r . sym(M) r), off-diagonal terms doubled so that
    r . M r = S00 x^2 + S11 y^2 + S22 z^2 + S01 x y + S02 x z + S12 y z. One contiguous row per lane: a node's
    four lanes are four rows in a row, where five separate arrays cost five streams of memory."""
    for q in range(mom_a.shape[0]):
        m = mom_m[q]
        row = table[q]
        row[FAR_CX], row[FAR_CY], row[FAR_CZ] = mom_c[q, 0], mom_c[q, 1], mom_c[q, 2]
        row[FAR_RHO] = mom_r[q]
        row[FAR_NX], row[FAR_NY], row[FAR_NZ] = mom_n[q, 0], mom_n[q, 1], mom_n[q, 2]
        row[FAR_AREA] = mom_a[q]
        row[FAR_TRACE] = m[0] + m[4] + m[8]
        row[FAR_S00], row[FAR_S11], row[FAR_S22] = m[0], m[4], m[8]
        row[FAR_S01], row[FAR_S02], row[FAR_S12] = m[1] + m[3], m[2] + m[6], m[5] + m[7]
        row[15] = 0.0


@nb.njit(**JIT, inline="always")
def _far(table, lane, beta2, order, want_err, px, py, pz):
    """(far-field solid angle, its error bound) of a lane if p is farther than beta * rho from its centre
    (beta2 = beta^2), else (0, -1) to say it must be opened. Order 1: the dipole N . r / |r|^3 (r = c - p);
    order 2 adds the first Taylor term, tr(M) / |r|^3 - 3 r . M r / |r|^5. The bound (module docstring) costs a
    division: it is computed only when want_err."""
    row = table[lane]
    rx, ry, rz = row[FAR_CX] - px, row[FAR_CY] - py, row[FAR_CZ] - pz
    d2 = rx * rx + ry * ry + rz * rz
    rho = row[FAR_RHO]
    if d2 <= beta2 * rho * rho or d2 == 0.0:  # squared: no square root for the lanes that are opened
        return 0.0, -1.0
    inv2 = 1.0 / d2
    inv3 = inv2 * np.sqrt(inv2)
    omega = (row[FAR_NX] * rx + row[FAR_NY] * ry + row[FAR_NZ] * rz) * inv3
    if order == 2:
        rmr = (row[FAR_S00] * rx * rx + row[FAR_S11] * ry * ry + row[FAR_S22] * rz * rz + row[FAR_S01] * rx * ry
               + row[FAR_S02] * rx * rz + row[FAR_S12] * ry * rz)
        omega += (row[FAR_TRACE] - 3.0 * rmr * inv2) * inv3
    if not want_err:
        return omega, 0.0
    g = np.sqrt(d2) - rho
    if order == 1:
        return omega, 2.0 * row[FAR_AREA] * rho / (g * g * g)
    return omega, 3.0 * row[FAR_AREA] * rho * rho / (g * g * g * g)


@nb.njit(**JIT)
def blas_winding(child, root, leaf_prim, leaf_tri, table, beta, order, want_err, px, py, pz, stack):
    """(sum of solid angles of one object-space tree's triangles seen from p, bound on its error when want_err,
    else 0), both in steradians. beta = inf sums every triangle exactly."""
    omega = 0.0
    err = 0.0
    if child.shape[0] == 0:
        return omega, err
    beta2 = beta * beta
    stack[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        for lane in range(WIDTH):
            code = child[node, lane]
            if code == 0:
                continue
            f, e = _far(table, node * WIDTH + lane, beta2, order, want_err, px, py, pz)
            if e >= 0.0:
                omega += f
                err += e
            elif code > 0:
                stack[sp] = code
                sp += 1
            else:
                first, end = leaf_range(code)
                for j in range(first, end):
                    if leaf_prim[j] >= 0:
                        omega += solid_angle(leaf_tri, j * 9, px, py, pz)
    return omega, err


@nb.njit(**JIT)
def winding_numbers_instances(points, inst_root, inst_w2o, inst_sign, inst_sphere, sph_center, sph_radius,
                              child, leaf_prim, leaf_tri, table, beta, order, want_err, stack_size, w_out, err_out,
                              blk0, blk1):
    """Winding number of every point in blocks blk0..blk1 summed over all instances, and its error bound (0 unless
    want_err).

    Mesh instances: the point moved into object space (instances are similarity transforms here: the solid
    angle is invariant under rotation, translation and uniform scale, and flips sign under a mirror,
    inst_sign). Sphere instances (inst_sphere >= 0: the sphere's index) count 1 inside, 1/2 on the surface."""
    n = points.shape[0]
    stack = np.empty(max(stack_size, 1) * 4, np.int64)
    for i in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK)):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        w = 0.0
        err = 0.0
        for k in range(inst_root.shape[0]):
            ox, oy, oz = object_point(inst_w2o[k], px, py, pz)
            s = inst_sphere[k]
            if s >= 0:
                w += sphere_winding(ox - sph_center[s, 0], oy - sph_center[s, 1], oz - sph_center[s, 2], sph_radius[s])
                continue
            omega, e = blas_winding(child, inst_root[k], leaf_prim, leaf_tri, table, beta, order, want_err, ox, oy,
                                    oz, stack)
            w += inst_sign[k] * omega / FOUR_PI
            err += e / FOUR_PI
        w_out[i] = w
        err_out[i] = err


@nb.njit(**JIT)
def crossing_votes_instances(points, dirs, center, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri,
                             sph_center, sph_radius, sph_w2o, stack_size, votes, blk0, blk1):
    """Open3D's inside test, for comparison: votes[i] = how many of R rays from point i cross the surfaces an odd
    number of times (every instance's tree, the ray moved into its object space). Ray r leaves along
    dirs[r] + the unit direction from `center` (the scene's middle) to the point: any direction gives the same
    parity on a closed mesh, and pointing away from the middle crosses fewer boxes. Serial and nogil, spread by
    run_blocks (no Numba parallel region: safe in forked processes)."""
    n = points.shape[0]
    stack = np.empty(max(stack_size, 1) * 4, np.int32)
    e_t, e_u, e_v = np.empty(0), np.empty(0), np.empty(0)
    e_p, e_k = np.empty(0, np.int32), np.empty(0, np.int8)
    for i in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK)):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        ax, ay, az = away_from(center, px, py, pz)
        v = 0
        for r in range(dirs.shape[0]):
            count = 0
            rx, ry, rz = dirs[r, 0] + ax, dirs[r, 1] + ay, dirs[r, 2] + az
            for k in range(inst_root.shape[0]):
                m = inst_w2o[k]
                ox = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
                oy = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
                oz = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
                dx = m[0, 0] * rx + m[0, 1] * ry + m[0, 2] * rz
                dy = m[1, 0] * rx + m[1, 1] * ry + m[1, 2] * rz
                dz = m[2, 0] * rx + m[2, 1] * ry + m[2, 2] * rz
                count = blas_all(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                 ox, oy, oz, dx, dy, dz, 0.0, np.inf, stack, e_t, e_p, e_k, e_u, e_v, count)
            v += count & 1
        votes[i] = v



@nb.njit(**JIT, inline="always")
def lane_bound(lanes, px, py, pz):
    """A bound on |w| of the triangles under the lanes (L, 5: world centre, radius rho, area A) at p: the sum of
    A / (4 pi (d - rho)^2), d the distance to a lane's centre, since no triangle point is nearer than d - rho and
    a surface of area A seen from at least r subtends at most A / r^2; inf when p is within a lane's sphere.
    accel/distance.py skips the caps' winding number where it is below 1/2."""
    b = 0.0
    for q in range(lanes.shape[0]):
        dx, dy, dz = lanes[q, 0] - px, lanes[q, 1] - py, lanes[q, 2] - pz
        g = np.sqrt(dx * dx + dy * dy + dz * dz) - lanes[q, 3]
        b += lanes[q, 4] / (FOUR_PI * g * g) if g > 0.0 else np.inf
    return b


@nb.njit(**JIT, inline="always")
def ball_bound(lanes, px, py, pz, reach):
    """lane_bound at every point within `reach` of p at once: the same sum with each gap shortened by reach (no
    point of the ball is nearer a lane's centre than d - reach), so it is at least lane_bound at each of them."""
    b = 0.0
    for q in range(lanes.shape[0]):
        dx, dy, dz = lanes[q, 0] - px, lanes[q, 1] - py, lanes[q, 2] - pz
        g = np.sqrt(dx * dx + dy * dy + dz * dz) - lanes[q, 3] - reach
        b += lanes[q, 4] / (FOUR_PI * g * g) if g > 0.0 else np.inf
    return b


@nb.njit(**JIT)
def lane_bounds(lanes, points, out):
    """out[i] = lane_bound(lanes, points[i]) for each point (N, 3): serial, for the few points near the caps."""
    for i in range(points.shape[0]):
        out[i] = lane_bound(lanes, points[i, 0], points[i, 1], points[i, 2])
