"""Closest points on triangles, spheres and ellipsoids, and the BVH traversal that finds them (Numba).

* `closest_on_triangle`: Ericson's region test ("Real-Time Collision Detection", 5.1.5): the closest point of a
  triangle and its barycentric weights, exact up to float64 rounding; degenerate (zero-area) triangles fall back
  to their three edges.
* `closest_on_ellipsoid`: Eberly's robust bisection ("Distance from a Point to an Ellipse, an Ellipsoid, or a
  Hyperellipsoid", 2013) on the root of the Lagrange-multiplier equation; bisection runs until the interval
  stops shrinking, so the result is exact to float64 rounding (an ellipsoid's closest point has no closed form).
* `closest_points_instances`: for each point, nearest-first traversal of the top-level tree (world boxes of
  instances) and of each instance's bottom-level tree in object space, both pruned by the best squared distance
  found so far. Bottom-level trees are only entered under similarity transforms (rotation, mirror, uniform scale
  s, translation), where an object-space distance times s is the world distance; accel/distance.py bakes any
  other mesh instance into world space first, and every sphere instance is solved in world space as an
  ellipsoid (a sphere when its axes are equal), so every result is exact.

The work is spread over threads by kernels/threads.run_blocks (the kernels are serial and nogil: they compile and
load from the cache faster than prange kernels).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..bvh.layout import BLOCK, NODE_FLOATS, PACKET, WIDTH, lane_box, leaf_range, leaf_vertices
from ..common import JIT, SPHERE, TRIANGLE
from ..small_sort import insert_ascending

POINTS_PER_BLOCK = PACKET * BLOCK  # points per work item of run_blocks


ROOT_CANCEL = 1e-3  # below this s + 1, the shortest axis's coordinate is taken from the surface equation

@nb.njit(**JIT, inline="always")
def _segment(px, py, pz, ax, ay, az, bx, by, bz):
    """Closest point of segment ab to p: (t along ab in [0, 1], squared distance)."""
    ex, ey, ez = bx - ax, by - ay, bz - az
    ee = ex * ex + ey * ey + ez * ez
    t = 0.0
    if ee > 0.0:
        t = ((px - ax) * ex + (py - ay) * ey + (pz - az) * ez) / ee
        t = min(max(t, 0.0), 1.0)
    qx, qy, qz = ax + t * ex - px, ay + t * ey - py, az + t * ez - pz
    return t, qx * qx + qy * qy + qz * qz


@nb.njit(**JIT)
def _degenerate(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Closest point of a zero-area triangle: the best of its three edges, as weights (v, w) of b and c."""
    t, d = _segment(px, py, pz, ax, ay, az, bx, by, bz)
    v, w = t, 0.0
    t2, d2 = _segment(px, py, pz, ax, ay, az, cx, cy, cz)
    if d2 < d:
        d, v, w = d2, 0.0, t2
    t3, d3 = _segment(px, py, pz, bx, by, bz, cx, cy, cz)
    if d3 < d:
        v, w = 1.0 - t3, t3
    return v, w


@nb.njit(**JIT, inline="always")
def _edge_dots(abx, aby, abz, acx, acy, acz, rx, ry, rz):
    """(ab . r, ac . r): where r, from a vertex to the point, falls along the triangle's two edges from a."""
    return abx * rx + aby * ry + abz * rz, acx * rx + acy * ry + acz * rz


@nb.njit(**JIT, inline="always")
def _corner_or_edge(q_own, q_other, a_own, a_other):
    """Ericson's test of corner q (b or c) and of edge aq, from the dot products of the edge vectors with q -> p
    (q_own along aq, q_other along the other edge) and with a -> p (a_own, a_other): (q's barycentric weight,
    whether p's region was found, the face test's barycentric numerator of the third vertex)."""
    if q_own >= 0.0 and q_other <= q_own:                        # vertex region q
        return 1.0, True, 0.0
    area = a_own * q_other - q_own * a_other
    if area <= 0.0 and a_own >= 0.0 and q_own <= 0.0 and a_own - q_own > 0.0:   # edge region aq
        return a_own / (a_own - q_own), True, area
    return 0.0, False, area


@nb.njit(**JIT)
def closest_on_triangle(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Closest point of triangle abc to p by Ericson's Voronoi-region test: (qx, qy, qz, v, w), with v and w the
    barycentric weights of b and c (q = a + v (b - a) + w (c - a))."""
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    d1, d2 = _edge_dots(abx, aby, abz, acx, acy, acz, px - ax, py - ay, pz - az)
    v = w = 0.0
    done = False
    if d1 <= 0.0 and d2 <= 0.0:                      # vertex region a
        done = True
    if not done:
        d3, d4 = _edge_dots(abx, aby, abz, acx, acy, acz, px - bx, py - by, pz - bz)
        v, done, vc = _corner_or_edge(d3, d4, d1, d2)            # vertex region b, edge region ab
        if not done:
            d5, d6 = _edge_dots(abx, aby, abz, acx, acy, acz, px - cx, py - cy, pz - cz)
            w, done, vb = _corner_or_edge(d6, d5, d2, d1)        # vertex region c, edge region ac
            if not done:
                va = d3 * d6 - d5 * d4
                e43, e56 = d4 - d3, d5 - d6
                if va <= 0.0 and e43 >= 0.0 and e56 >= 0.0 and e43 + e56 > 0.0:   # edge region bc
                    w = e43 / (e43 + e56)
                    v, done = 1.0 - w, True
            if not done:
                denom = va + vb + vc
                if denom > 0.0:                      # face region
                    v, w = vb / denom, vc / denom
                else:
                    v, w = _degenerate(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz)
    return ax + v * abx + w * acx, ay + v * aby + w * acy, az + v * abz + w * acz, v, w


@nb.njit(**JIT, inline="always")
def _box_dist2(bounds, base, px, py, pz):
    """Squared distance from p to the box at flat offset `base` (inf for an empty lane's box at infinity)."""
    lx, ly, lz, hx, hy, hz = lane_box(bounds, base)
    dx = max(lx - px, 0.0, px - hx)
    dy = max(ly - py, 0.0, py - hy)
    dz = max(lz - pz, 0.0, pz - hz)
    return dx * dx + dy * dy + dz * dz


@nb.njit(**JIT, inline="always")
def _push_children(bounds, child, node, px, py, pz, best2, stack_node, stack_d, sp, d, c):
    """Push the children of `node` that may hold a point closer than sqrt(best2), farthest first, so the nearest
    is popped next (d, c: the caller's scratch of 4). Returns the new stack pointer."""
    base = node * NODE_FLOATS
    m = 0
    for lane in range(WIDTH):  # an empty lane's box sits at infinity: its distance is never below best2
        dd = _box_dist2(bounds, base + lane, px, py, pz)
        if dd < best2:  # by descending distance (ascending -dd), so the nearest child is pushed last
            m = insert_ascending(d, c, m, -dd, child[node, lane])
    for k in range(m):
        stack_node[sp] = c[k]
        stack_d[sp] = -d[k]
        sp += 1
    return sp


@nb.njit(**JIT, inline="always")
def _next_leaf(bounds, child, stack_node, stack_d, sp, px, py, pz, best2, d4, c4):
    """The nearest-first walk of closest-point queries (one or two levels): pop nodes, skipping those farther than
    sqrt(best2), pushing the children of inner ones, until a leaf comes up. Returns (leaf code, or 0 when the stack
    is empty, stack pointer); the caller pushes the root first with distance 0."""
    while sp > 0:
        sp -= 1
        if stack_d[sp] >= best2:
            continue
        node = stack_node[sp]
        if node < 0:
            return node, sp
        sp = _push_children(bounds, child, node, px, py, pz, best2, stack_node, stack_d, sp, d4, c4)
    return 0, sp


@nb.njit(**JIT)
def blas_closest_point(bounds, child, root, leaf_prim, leaf_tri, px, py, pz, best2, stack_node, stack_d, d4, c4):
    """Closest triangle point of one object-space tree to p, closer than sqrt(best2): (best2, prim (-1 if none),
    qx, qy, qz, v, w). Sphere items are skipped (sphere instances are solved as ellipsoids in world space)."""
    prim = -1
    bqx = bqy = bqz = bv = bw = 0.0
    stack_node[0] = root
    stack_d[0] = 0.0
    sp = 1
    while True:
        leaf, sp = _next_leaf(bounds, child, stack_node, stack_d, sp, px, py, pz, best2, d4, c4)
        if leaf == 0:
            break
        first, end = leaf_range(leaf)
        for j in range(first, end):
            p = leaf_prim[j]
            if p < 0:
                continue
            o = j * 9
            qx, qy, qz, v, w = closest_on_triangle(px, py, pz, *leaf_vertices(leaf_tri, o))
            dx, dy, dz = qx - px, qy - py, qz - pz
            dd = dx * dx + dy * dy + dz * dz
            if dd < best2:
                best2, prim, bqx, bqy, bqz, bv, bw = dd, p, qx, qy, qz, v, w
    return best2, prim, bqx, bqy, bqz, bv, bw


@nb.njit(**JIT, inline="always")
def _robust_length(a, b, c):
    m = max(abs(a), abs(b), abs(c))
    if m == 0.0:
        return 0.0
    return m * np.sqrt((a / m) ** 2 + (b / m) ** 2 + (c / m) ** 2)


@nb.njit(**JIT)
def _ellipse_root(r0, z0, z1, g):
    """Eberly's 2D root: the 3D one with a zero middle coordinate (its term is exactly 0, so the same bisection)."""
    return _ellipsoid_root(r0, 1.0, z0, 0.0, z1, g)


@nb.njit(**JIT)
def _ellipse(e0, e1, y0, y1):
    """Eberly: closest point of the ellipse with semi-axes e0 >= e1 > 0 to (y0, y1), both >= 0."""
    if y1 > 0.0:
        if y0 > 0.0:
            if e0 == e1:  # a circle: straight out from the centre (the root below would cancel in both coordinates)
                m = max(y0, y1)  # scaled first, so subnormal coordinates keep their digits
                a, b = y0 / m, y1 / m
                n = np.hypot(a, b)
                return e0 * (a / n), e0 * (b / n)
            z0, z1 = y0 / e0, y1 / e1
            g = z0 * z0 + z1 * z1 - 1.0
            if g == 0.0:
                return y0, y1
            r0 = (e0 / e1) ** 2
            s = _ellipse_root(r0, z0, z1, g)
            x0, x1 = r0 * y0 / (s + r0), y1 / (s + 1.0)
            # s + 1 near 0 (y1 tiny, the point well inside): y1 / (s + 1) loses its digits to the root's rounding,
            # so x1 comes from the ellipse itself (x0 stays accurate: s + r0 >= r0 - 1 does not cancel)
            if not (np.isfinite(x1) and x1 <= e1) or s + 1.0 < ROOT_CANCEL:
                x1 = e1 * np.sqrt(max(1.0 - (x0 / e0) ** 2, 0.0))
            return x0, x1
        return 0.0, e1
    denom0 = e0 * e0 - e1 * e1
    numer0 = e0 * y0
    if numer0 < denom0:
        x = numer0 / denom0
        return e0 * x, e1 * np.sqrt(max(1.0 - x * x, 0.0))
    return e0, 0.0


@nb.njit(**JIT)
def _ellipsoid_root(r0, r1, z0, z1, z2, g):
    n0, n1 = r0 * z0, r1 * z1
    s0 = z2 - 1.0
    s1 = 0.0 if g < 0.0 else _robust_length(n0, n1, z2) - 1.0
    s = 0.0
    for _ in range(2000):
        s = 0.5 * (s0 + s1)
        if s == s0 or s == s1:
            break
        g = (n0 / (s + r0)) ** 2 + (n1 / (s + r1)) ** 2 + (z2 / (s + 1.0)) ** 2 - 1.0
        if g > 0.0:
            s0 = s
        elif g < 0.0:
            s1 = s
        else:
            break
    return s


@nb.njit(**JIT)
def closest_on_ellipsoid(e0, e1, e2, y0, y1, y2):
    """Eberly: closest point of the ellipsoid with semi-axes e0 >= e1 >= e2 > 0 (along x, y, z) to y, all
    coordinates >= 0 (the caller reflects the point into the first octant and back)."""
    if y2 > 0.0:
        if y1 > 0.0:
            if y0 > 0.0:
                if e0 == e2:  # a sphere: straight out from the centre
                    m = max(y0, y1, y2)  # scaled first, so subnormal coordinates keep their digits
                    a, b, c = y0 / m, y1 / m, y2 / m
                    n = _robust_length(a, b, c)
                    return e0 * (a / n), e0 * (b / n), e0 * (c / n)
                z0, z1, z2 = y0 / e0, y1 / e1, y2 / e2
                g = z0 * z0 + z1 * z1 + z2 * z2 - 1.0
                if g == 0.0:
                    return y0, y1, y2
                r0, r1 = (e0 / e2) ** 2, (e1 / e2) ** 2
                s = _ellipsoid_root(r0, r1, z0, z1, z2, g)
                x0, x1, x2 = r0 * y0 / (s + r0), r1 * y1 / (s + r1), y2 / (s + 1.0)
                if e1 == e2 and s + 1.0 < ROOT_CANCEL:
                    # a spheroid about x, the point well inside: x1 and x2 share the cancelling factor 1 / (s + 1),
                    # so the circle they lie on comes from the surface equation, their direction from y1, y2
                    rho = e2 * np.sqrt(max(1.0 - (x0 / e0) ** 2, 0.0))
                    m = max(y1, y2)
                    a, b = y1 / m, y2 / m
                    n = np.hypot(a, b)
                    return x0, rho * (a / n), rho * (b / n)
                if np.isfinite(x0 + x1) and x0 <= e0 and x1 <= e1:
                    if not (np.isfinite(x2) and x2 <= e2) or s + 1.0 < ROOT_CANCEL:  # y2 below the root's resolution
                        x2 = e2 * np.sqrt(max(1.0 - (x0 / e0) ** 2 - (x1 / e1) ** 2, 0.0))
                    return x0, x1, x2
                return _ellipsoid_flat(e0, e1, e2, y0, y1)  # y1 (and y2) below resolution: as if y2 = 0
            x1, x2 = _ellipse(e1, e2, y1, y2)
            return 0.0, x1, x2
        if y0 > 0.0:
            x0, x2 = _ellipse(e0, e2, y0, y2)
            return x0, 0.0, x2
        return 0.0, 0.0, e2
    return _ellipsoid_flat(e0, e1, e2, y0, y1)


@nb.njit(**JIT)
def _ellipsoid_flat(e0, e1, e2, y0, y1):
    """Eberly's case y2 = 0: the closest point may leave the plane (when y is deep enough inside)."""
    denom0, denom1 = e0 * e0 - e2 * e2, e1 * e1 - e2 * e2
    numer0, numer1 = e0 * y0, e1 * y1
    if numer0 < denom0 and numer1 < denom1:
        x0, x1 = numer0 / denom0, numer1 / denom1
        discr = 1.0 - x0 * x0 - x1 * x1
        if discr > 0.0:
            return e0 * x0, e1 * x1, e2 * np.sqrt(discr)
    x0, x1 = _ellipse(e0, e1, y0, y1)
    return x0, x1, 0.0


@nb.njit(**JIT)
def _ellipsoid_point(center, frame, semi, px, py, pz):
    """Closest point of a world-space ellipsoid (centre, rows of `frame` = unit axes by decreasing semi-axis)."""
    rx, ry, rz = px - center[0], py - center[1], pz - center[2]
    y0 = frame[0, 0] * rx + frame[0, 1] * ry + frame[0, 2] * rz
    y1 = frame[1, 0] * rx + frame[1, 1] * ry + frame[1, 2] * rz
    y2 = frame[2, 0] * rx + frame[2, 1] * ry + frame[2, 2] * rz
    if semi[0] == semi[2]:  # a sphere: closed form
        n = np.sqrt(y0 * y0 + y1 * y1 + y2 * y2)
        if n == 0.0:
            x0, x1, x2 = 0.0, 0.0, semi[2]
        else:
            x0, x1, x2 = semi[0] * y0 / n, semi[0] * y1 / n, semi[0] * y2 / n
    else:
        x0, x1, x2 = closest_on_ellipsoid(semi[0], semi[1], semi[2], abs(y0), abs(y1), abs(y2))
        x0, x1, x2 = np.copysign(x0, y0), np.copysign(x1, y1), np.copysign(x2, y2)
    return (center[0] + frame[0, 0] * x0 + frame[1, 0] * x1 + frame[2, 0] * x2,
            center[1] + frame[0, 1] * x0 + frame[1, 1] * x1 + frame[2, 1] * x2,
            center[2] + frame[0, 2] * x0 + frame[1, 2] * x1 + frame[2, 2] * x2)


@nb.njit(**JIT)
def closest_points_instances(points, top_bounds, top_child, top_leaf, inst_root, inst_w2o, inst_o2w, inst_scale,
                             inst_ell, ell_center, ell_frame, ell_semi, bounds, child, leaf_prim, leaf_tri,
                             stack_size, dist2_out, inst_out, kind_out, prim_out, q_out, uv_out, blk0, blk1):
    """Closest surface point of every point in blocks blk0..blk1 (POINTS_PER_BLOCK points each) over all
    instances: squared distance, instance, kind (TRIANGLE, SPHERE or 0 with no geometry), primitive, the point
    (world), and the triangle's barycentric weights of vertices 1 and 2 (0 for spheres)."""
    n = points.shape[0]
    top_node = np.empty(stack_size, np.int64)
    top_d = np.empty(stack_size)
    stack_node = np.empty(stack_size, np.int64)
    stack_d = np.empty(stack_size)
    d4 = np.empty(WIDTH)
    c4 = np.empty(WIDTH, np.int64)
    for i in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK)):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        best2 = np.inf
        b_inst, b_kind, b_prim = -1, 0, -1
        bqx = bqy = bqz = bv = bw = 0.0
        top_node[0] = 0
        top_d[0] = 0.0
        sp = 1 if top_child.shape[0] > 0 else 0
        leaf = -1
        while leaf != 0:  # 0: the walk is over
            leaf, sp = _next_leaf(top_bounds, top_child, top_node, top_d, sp, px, py, pz, best2, d4, c4)
            first, end = leaf_range(leaf) if leaf != 0 else (0, 0)
            for j in range(first, end):
                k = top_leaf[j]
                e = inst_ell[k]
                if e >= 0:
                    qx, qy, qz = _ellipsoid_point(ell_center[e], ell_frame[e], ell_semi[e], px, py, pz)
                    dd = (qx - px) ** 2 + (qy - py) ** 2 + (qz - pz) ** 2
                    if dd < best2:
                        best2, b_inst, b_kind, b_prim = dd, k, SPHERE, 0
                        bqx, bqy, bqz, bv, bw = qx, qy, qz, 0.0, 0.0
                    continue
                m = inst_w2o[k]
                ox = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
                oy = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
                oz = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
                s = inst_scale[k]
                _, prim, qx, qy, qz, v, w = blas_closest_point(bounds, child, inst_root[k], leaf_prim, leaf_tri,
                                                               ox, oy, oz, best2 / (s * s), stack_node, stack_d, d4, c4)
                if prim >= 0:
                    a = inst_o2w[k]
                    wx = a[0, 0] * qx + a[0, 1] * qy + a[0, 2] * qz + a[0, 3]
                    wy = a[1, 0] * qx + a[1, 1] * qy + a[1, 2] * qz + a[1, 3]
                    wz = a[2, 0] * qx + a[2, 1] * qy + a[2, 2] * qz + a[2, 3]
                    # the blas found it closer than best2 / s^2; its world distance is taken from the world point
                    dd = (wx - px) ** 2 + (wy - py) ** 2 + (wz - pz) ** 2
                    best2, b_inst, b_kind, b_prim = dd, k, TRIANGLE, prim
                    bqx, bqy, bqz, bv, bw = wx, wy, wz, v, w
        dist2_out[i] = best2
        inst_out[i], kind_out[i], prim_out[i] = b_inst, b_kind, b_prim
        q_out[i, 0], q_out[i, 1], q_out[i, 2] = bqx, bqy, bqz
        uv_out[i, 0], uv_out[i, 1] = bv, bw
