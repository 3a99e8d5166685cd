"""Generalized winding numbers through the BVH (Numba): inside/outside that stays right on meshes with holes.

The winding number of a point p with respect to triangles T_i is w(p) = sum_i Omega_i(p) / (4 pi), Omega_i the
signed solid angle of T_i seen from p (Jacobson, Kavan and Sorkine-Hornung 2013), here by Van Oosterom and
Strackee's formula. For a closed, outward-wound (counter-clockwise seen from outside) mesh it is exactly 1 inside
and 0 outside; on a mesh with holes it varies smoothly and w > 1/2 is the natural inside test.

Evaluated fast with Barill et al. 2018 ("Fast Winding Numbers for Soups and Clouds"): every BVH node stores the
sum of its triangles' area vectors N, their area-weighted centroid c, a radius rho bounding every triangle point
from c (the distance from c to the farthest corner of the node's box), and their unsigned area A. A node whose
centre is farther than beta * rho from p (beta > 1) is replaced by its dipole term N . (c - p) / |c - p|^3; nearer
nodes are opened, leaves are summed exactly.

Error bound (derived here for the order-1 dipole): for a triangle point x and the kernel K(x) = n . (x - p) /
|x - p|^3, |grad K| <= 2 / |x - p|^3, and every x is within rho of c, at least d - rho from p (d = |c - p|), so
one approximated node is off by at most A * 2 rho / (d - rho)^3 in solid angle, i.e. A rho / (2 pi (d - rho)^3)
in w. `winding_numbers_instances` returns the sum of these terms for each point, a rigorous bound on
|w_fast - w_exact| up to rounding (tests/test_kernels_winding.py checks it).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .closest import POINTS_PER_BLOCK
from .layout import HI_X, HI_Y, HI_Z, JIT, LO_X, LO_Y, LO_Z, NODE_FLOATS, WIDTH, leaf_range

FOUR_PI = 4.0 * np.pi


@nb.njit(**JIT, inline="always")
def solid_angle(leaf_tri, o, px, py, pz):
    """Signed solid angle of the triangle at leaf_tri[o:o+9] seen from p (Van Oosterom and Strackee 1983):
    positive when p sees its back (the side its counter-clockwise normal points away from). 0 at a vertex."""
    ax, ay, az = leaf_tri[o] - px, leaf_tri[o + 1] - py, leaf_tri[o + 2] - pz
    bx, by, bz = leaf_tri[o + 3] - px, leaf_tri[o + 4] - py, leaf_tri[o + 5] - pz
    cx, cy, cz = leaf_tri[o + 6] - px, leaf_tri[o + 7] - py, leaf_tri[o + 8] - pz
    la = np.sqrt(ax * ax + ay * ay + az * az)
    lb = np.sqrt(bx * bx + by * by + bz * bz)
    lc = np.sqrt(cx * cx + cy * cy + cz * cz)
    det = ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    den = la * lb * lc + (ax * bx + ay * by + az * bz) * lc + (bx * cx + by * cy + bz * cz) * la \
        + (cx * ax + cy * ay + cz * az) * lb
    return 2.0 * np.arctan2(det, den)


@nb.njit(**JIT)
def node_moments(bounds, child, leaf_prim, leaf_tri, mom_n, mom_c, mom_r, mom_a):
    """Per node: area vector sum mom_n (N, 3), area-weighted centroid mom_c (N, 3), radius mom_r (N,) from the
    centroid to the farthest corner of the node's box, unsigned area mom_a (N,). Children are numbered after
    their parents (kernels/bvh_build.collapse_bvh4), so one pass from the last node up fills every node."""
    for node in range(child.shape[0] - 1, -1, -1):
        nx = ny = nz = 0.0
        sx = sy = sz = 0.0
        area = 0.0
        lx = ly = lz = np.inf
        hx = hy = hz = -np.inf
        base = node * NODE_FLOATS
        for lane in range(WIDTH):
            code = child[node, lane]
            if code == 0:
                continue
            lx, ly, lz = min(lx, bounds[base + LO_X + lane]), min(ly, bounds[base + LO_Y + lane]), \
                min(lz, bounds[base + LO_Z + lane])
            hx, hy, hz = max(hx, bounds[base + HI_X + lane]), max(hy, bounds[base + HI_Y + lane]), \
                max(hz, bounds[base + HI_Z + lane])
            if code > 0:
                a = mom_a[code]
                nx, ny, nz = nx + mom_n[code, 0], ny + mom_n[code, 1], nz + mom_n[code, 2]
                sx, sy, sz = sx + a * mom_c[code, 0], sy + a * mom_c[code, 1], sz + a * mom_c[code, 2]
                area += a
                continue
            first, end = leaf_range(code)
            for j in range(first, end):
                if leaf_prim[j] < 0:
                    continue
                o = j * 9
                ux, uy, uz = leaf_tri[o + 3] - leaf_tri[o], leaf_tri[o + 4] - leaf_tri[o + 1], \
                    leaf_tri[o + 5] - leaf_tri[o + 2]
                vx, vy, vz = leaf_tri[o + 6] - leaf_tri[o], leaf_tri[o + 7] - leaf_tri[o + 1], \
                    leaf_tri[o + 8] - leaf_tri[o + 2]
                cx, cy, cz = 0.5 * (uy * vz - uz * vy), 0.5 * (uz * vx - ux * vz), 0.5 * (ux * vy - uy * vx)
                a = np.sqrt(cx * cx + cy * cy + cz * cz)
                nx, ny, nz = nx + cx, ny + cy, nz + cz
                sx += a * (leaf_tri[o] + leaf_tri[o + 3] + leaf_tri[o + 6]) / 3.0
                sy += a * (leaf_tri[o + 1] + leaf_tri[o + 4] + leaf_tri[o + 7]) / 3.0
                sz += a * (leaf_tri[o + 2] + leaf_tri[o + 5] + leaf_tri[o + 8]) / 3.0
                area += a
        if area > 0.0:
            cx, cy, cz = sx / area, sy / area, sz / area
        else:
            cx, cy, cz = 0.5 * (lx + hx), 0.5 * (ly + hy), 0.5 * (lz + hz)
        if not np.isfinite(cx + cy + cz):  # an empty tree's root: nothing to approximate
            cx = cy = cz = 0.0
        mom_n[node, 0], mom_n[node, 1], mom_n[node, 2] = nx, ny, nz
        mom_c[node, 0], mom_c[node, 1], mom_c[node, 2] = cx, cy, cz
        mom_a[node] = area
        ex, ey, ez = max(cx - lx, hx - cx), max(cy - ly, hy - cy), max(cz - lz, hz - cz)
        r = np.sqrt(ex * ex + ey * ey + ez * ez)
        mom_r[node] = r if np.isfinite(r) else 0.0


@nb.njit(**JIT, inline="always")
def _far(mom_n, mom_c, mom_r, mom_a, node, beta, px, py, pz):
    """(dipole solid angle, its error bound) of `node` if p is farther than beta * rho from its centre, else
    (0, -1) to say it must be opened."""
    rx, ry, rz = mom_c[node, 0] - px, mom_c[node, 1] - py, mom_c[node, 2] - pz
    d = np.sqrt(rx * rx + ry * ry + rz * rz)
    rho = mom_r[node]
    if d <= beta * rho or d == 0.0:
        return 0.0, -1.0
    omega = (mom_n[node, 0] * rx + mom_n[node, 1] * ry + mom_n[node, 2] * rz) / (d * d * d)
    g = d - rho
    return omega, 2.0 * mom_a[node] * rho / (g * g * g)


@nb.njit(**JIT)
def blas_winding(bounds, child, root, leaf_prim, leaf_tri, mom_n, mom_c, mom_r, mom_a, beta, px, py, pz, stack):
    """(sum of solid angles of one object-space tree's triangles seen from p, bound on its error), both in
    steradians. beta = inf sums every triangle exactly."""
    omega = 0.0
    err = 0.0
    if child.shape[0] == 0:
        return omega, err
    f, e = _far(mom_n, mom_c, mom_r, mom_a, root, beta, px, py, pz)
    if e >= 0.0:
        return f, e
    stack[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        for lane in range(WIDTH):
            code = child[node, lane]
            if code == 0:
                continue
            if code > 0:
                f, e = _far(mom_n, mom_c, mom_r, mom_a, code, beta, px, py, pz)
                if e >= 0.0:
                    omega += f
                    err += e
                else:
                    stack[sp] = code
                    sp += 1
                continue
            first, end = leaf_range(code)
            for j in range(first, end):
                if leaf_prim[j] >= 0:
                    omega += solid_angle(leaf_tri, j * 9, px, py, pz)
    return omega, err


@nb.njit(**JIT)
def winding_numbers_instances(points, inst_root, inst_w2o, inst_sign, inst_sphere, sph_center, sph_radius,
                              bounds, child, leaf_prim, leaf_tri, mom_n, mom_c, mom_r, mom_a, beta, stack_size,
                              w_out, err_out, blk0, blk1):
    """Winding number of every point in blocks blk0..blk1 summed over all instances, and its error bound.

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
            m = inst_w2o[k]
            ox = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
            oy = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
            oz = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
            s = inst_sphere[k]
            if s >= 0:
                dx, dy, dz = ox - sph_center[s, 0], oy - sph_center[s, 1], oz - sph_center[s, 2]
                d2 = dx * dx + dy * dy + dz * dz
                r2 = sph_radius[s] * sph_radius[s]
                w += 1.0 if d2 < r2 else (0.5 if d2 == r2 else 0.0)
                continue
            omega, e = blas_winding(bounds, child, inst_root[k], leaf_prim, leaf_tri, mom_n, mom_c, mom_r, mom_a,
                                    beta, ox, oy, oz, stack)
            w += inst_sign[k] * omega / FOUR_PI
            err += e / FOUR_PI
        w_out[i] = w
        err_out[i] = err
