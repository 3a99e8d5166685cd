"""Signed crossings of coherent point packets (Numba): the inside test's rays walked PACKET at a time.

`inside` (accel/distance.py) sends one ray a point, from points sorted in Morton order, each leaving along a fixed
tilt plus the unit direction from the scene's middle: PACKET neighbouring points have nearly the same ray, as a
camera's 4 x 4 tile has. Walked one ray at a time (crossings.signed_crossings) each ray repeats its neighbours'
node visits and waits on the same loads; here the packet walks the tree once (packet.packet_node's interval
test, no culling but the rays' range: every box any ray enters is opened, an unordered stack as
packet_all.packet_all_traverse) and a leaf's triangle is tested against its PACKET rays in one vectorised loop
with the one-ray watertight test's arithmetic and tie-break (packet._edges), so each ray meets exactly the
crossings the one-ray walk meets, t, u, v to the bit. Only the few hits are then judged one by one with
signed_crossings' rules (side by the leaf's own unit normal, EDGE_MARGIN, GRAZE, t_eps); a ray with an unclean
crossing is retired (its range emptied) and reported unsure. A chunk whose rays do not share direction signs
and shear axes, or spread too far (chunks.packet_setup), goes ray by ray through signed_crossings.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..bvh.chunks import _BEST, _DX, _DY, _DZ, _EXT, _EXT_TMIN, _SZ, _TMIN, object_packet, packet_rows, packet_setup
from ..bvh.items import unit_normal
from ..bvh.layout import PACKET, leaf_range
from ..bvh.packet import _any_inside, _edges, _flat, _mixed, _packet_far, packet_extents, packet_node
from ..common import JIT
from ..intersect import edge_tie
from .closest import POINTS_PER_BLOCK
from .crossings import EDGE_MARGIN, GRAZE, signed_crossings
from .winding import away_from, ball_bound, lane_bound, object_point, sphere_winding


@nb.njit(**JIT, inline="always")
def _judge(k, ro, t_eps, nx, ny, nz, e0, e1, e2, az, bz, cz, signed, bad):
    """Ray k's crossing of a triangle (unit normal nx, ny, nz; edge functions e0, e1, e2, sheared z's az, bz,
    cz): its side into signed[k], or the ray retired as unsure (signed_crossings' rules, the same arithmetic)."""
    det = e0 + e1 + e2
    t = ro[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
    u, v = e1 / det, e2 / det
    dx, dy, dz = ro[_DX + k], ro[_DY + k], ro[_DZ + k]
    dl = np.sqrt(dx * dx + dy * dy + dz * dz)
    c = (dx * nx + dy * ny + dz * nz) / dl
    if min(u, min(v, 1.0 - u - v)) < EDGE_MARGIN or abs(c) < GRAZE or abs(t) * dl <= t_eps:
        bad[k] = True
        ro[_BEST + k] = -np.inf  # retired: no later box or triangle can pass its range
    else:
        signed[k] += 1.0 if c > 0.0 else -1.0


@nb.njit(**JIT, inline="always")
def _triangle_crossings(j, leaf_prim, leaf_tri, kx, ky, kz, ro, t_eps, signed, bad):
    """Triangle slot j against every live ray of the packet ro: the rays the one-ray watertight test would find
    crossing it (a vector loop; ties on an edge or vertex by edge_tie after it), each then judged (_judge)."""
    if leaf_prim[j] < 0:  # a sphere slot: cannot happen in a mesh's tree; be safe (signed_crossings does the same)
        for k in range(PACKET):
            if ro[_BEST + k] > -np.inf:
                bad[k] = True
                ro[_BEST + k] = -np.inf
        return
    base = j * 9
    ax0, ay0, az0 = (np.float64(leaf_tri[base + kx]), np.float64(leaf_tri[base + ky]),
                     np.float64(leaf_tri[base + kz]))
    bx0, by0, bz0 = (np.float64(leaf_tri[base + 3 + kx]), np.float64(leaf_tri[base + 3 + ky]),
                     np.float64(leaf_tri[base + 3 + kz]))
    cx0, cy0, cz0 = (np.float64(leaf_tri[base + 6 + kx]), np.float64(leaf_tri[base + 6 + ky]),
                     np.float64(leaf_tri[base + 6 + kz]))
    if not _any_inside(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, ro):
        return
    ties = 0
    mask = np.int64(0)
    for k in range(PACKET):
        az, bz, cz, ax, ay, bx, by, cx, cy, e0, e1, e2 = _edges(ro, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0,
                                                               cz0)
        det = e0 + e1 + e2
        t = ro[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
        on_edge = (e0 == 0.0) | (e1 == 0.0) | (e2 == 0.0)
        ties += on_edge
        flat = _flat(ro, k, det, ax, ay, az, bx, by, bz, cx, cy, cz)
        hit = ~flat & (ro[_TMIN + k] < t) & (t < ro[_BEST + k]) & ~on_edge & ~_mixed(e0, e1, e2)
        mask |= np.int64(hit) << k
    if ties:
        for k in range(PACKET):  # rays on an edge or a vertex: intersect.watertight_triangle's tie-break
            az, bz, cz, ax, ay, bx, by, cx, cy, e0, e1, e2 = _edges(ro, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0,
                                                                   cz0)
            if not (e0 == 0.0 or e1 == 0.0 or e2 == 0.0) or _mixed(e0, e1, e2):
                continue
            if not edge_tie(e0, e1, e2, ax, ay, bx, by, cx, cy):
                continue
            det = e0 + e1 + e2
            if _flat(ro, k, det, ax, ay, az, bx, by, bz, cx, cy, cz):
                continue
            t = ro[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
            if ro[_TMIN + k] < t < ro[_BEST + k]:
                mask |= np.int64(1) << k
    if mask == 0:
        return
    x0, y0, z0 = np.float64(leaf_tri[base]), np.float64(leaf_tri[base + 1]), np.float64(leaf_tri[base + 2])
    nx, ny, nz = unit_normal(np.float64(leaf_tri[base + 3]) - x0, np.float64(leaf_tri[base + 4]) - y0,
                             np.float64(leaf_tri[base + 5]) - z0, np.float64(leaf_tri[base + 6]) - x0,
                             np.float64(leaf_tri[base + 7]) - y0, np.float64(leaf_tri[base + 8]) - z0)
    for k in range(PACKET):
        if (mask >> k) & 1:
            az, bz, cz, _, _, _, _, _, _, e0, e1, e2 = _edges(ro, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0)
            _judge(k, ro, t_eps, nx, ny, nz, e0, e1, e2, az, bz, cz, signed, bad)


@nb.njit(**JIT)
def packet_crossings(bounds, child, root, leaf_prim, leaf_tri, nrx, nry, nrz, kx, ky, kz, ro, t_eps, stack, key,
                     order, signed, bad):
    """Add each live ray's signed crossings of the tree at `root` (object space: ro, packet rows with each ray's
    t_min = -t_eps / |d| set) into signed; rays with an unclean crossing get bad[k] = True (module docstring)."""
    far = _packet_far(ro)
    if far == -np.inf:
        return
    ext = packet_extents(ro, nrx, nry, nrz)
    stack[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack[sp]
        n_in = packet_node(bounds, child, node, nrx, nry, nrz, ext, far, key, order)
        for q in range(n_in):
            c = child[node, order[q]]
            if c > 0:
                stack[sp] = c
                sp += 1
                continue
            first, end = leaf_range(c)
            for j in range(first, end):
                _triangle_crossings(j, leaf_prim, leaf_tri, kx, ky, kz, ro, t_eps, signed, bad)


@nb.njit(**JIT, inline="always")
def _mesh_crossings(k, inst_w2o, inst_root, inst_sign, bounds, child, leaf_prim, leaf_tri, i0, points, rx, ry, rz,
                    packet, rr, ro, moved, t_eps, stack, key, order, signed, w, bad, gone):
    """Mesh instance k's signed crossings, times its sign, added into w for the chunk's PACKET points from i0: as
    a packet when the chunk and its rays moved into object space are coherent, else ray by ray. moved is the
    packet ro's state (coherent, nrx, nry, nrz, kx, ky, kz, the (3, 4) matrix it was moved by): a matrix equal to
    it (a cap placed as its mesh) reuses ro. Rays with gone[r] (leaving the scene's box) are not walked. Returns
    the state."""
    m = inst_w2o[k]
    if not _same_matrix(m, moved[7]):
        c, nrx, nry, nrz, kx, ky, kz = object_packet(rr, ro, m)  # rr is scratch when not packet
        moved = (c, nrx, nry, nrz, kx, ky, kz, m)
    coherent, nrx, nry, nrz, kx, ky, kz, _ = moved
    if packet and coherent:
        tlo = np.inf
        for r in range(PACKET):
            dx, dy, dz = ro[_DX + r], ro[_DY + r], ro[_DZ + r]
            ro[_TMIN + r] = -t_eps / np.sqrt(dx * dx + dy * dy + dz * dz)
            ro[_BEST + r] = -np.inf if bad[r] or gone[r] else np.inf
            tlo = min(tlo, ro[_TMIN + r])
            signed[r] = 0.0
        ro[_EXT + _EXT_TMIN] = tlo
        packet_crossings(bounds, child, inst_root[k], leaf_prim, leaf_tri, nrx, nry, nrz, kx, ky, kz, ro, t_eps,
                         stack, key, order, signed, bad)
        for r in range(PACKET):
            w[r] += inst_sign[k] * signed[r]
        return moved
    for r in range(rx.shape[0]):
        if bad[r] or gone[r]:
            continue
        i = i0 + r
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        ox, oy, oz = object_point(m, px, py, pz)
        dx = m[0, 0] * rx[r] + m[0, 1] * ry[r] + m[0, 2] * rz[r]
        dy = m[1, 0] * rx[r] + m[1, 1] * ry[r] + m[1, 2] * rz[r]
        dz = m[2, 0] * rx[r] + m[2, 1] * ry[r] + m[2, 2] * rz[r]
        s, b = signed_crossings(bounds, child, inst_root[k], leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_eps, stack)
        bad[r] = b
        w[r] += inst_sign[k] * s
    return moved


@nb.njit(**JIT, inline="always")
def _chunk_bounds(lanes, o16, m, bad, bound, i0):
    """bound[i0 + r] = a bound on the caps' |w| at each of the chunk's m points o16 that is not bad: the bound of
    the ball around their box (winding.ball_bound) for all of them where it is below 1/2 (only that side of 1/2
    is used), else each point's own lane_bound. Points far from the caps (most) then pay one sum a chunk."""
    lo0, lo1, lo2, hi0, hi1, hi2 = np.inf, np.inf, np.inf, -np.inf, -np.inf, -np.inf
    for r in range(m):
        lo0, lo1, lo2 = min(lo0, o16[r, 0]), min(lo1, o16[r, 1]), min(lo2, o16[r, 2])
        hi0, hi1, hi2 = max(hi0, o16[r, 0]), max(hi1, o16[r, 1]), max(hi2, o16[r, 2])
    h0, h1, h2 = (hi0 - lo0) * 0.5, (hi1 - lo1) * 0.5, (hi2 - lo2) * 0.5
    b = ball_bound(lanes, lo0 + h0, lo1 + h1, lo2 + h2, np.sqrt(h0 * h0 + h1 * h1 + h2 * h2) * (1.0 + 1e-12))
    for r in range(m):
        if not bad[r]:
            bound[i0 + r] = b if b < 0.5 else lane_bound(lanes, o16[r, 0], o16[r, 1], o16[r, 2])


@nb.njit(**JIT, inline="always")
def outside_box(px, py, pz, lo, hi):
    """Whether the point lies outside the box lo..hi."""
    return px < lo[0] or px > hi[0] or py < lo[1] or py > hi[1] or pz < lo[2] or pz > hi[2]


@nb.njit(**JIT, inline="always")
def misses_box(px, py, pz, dx, dy, dz, lo, hi):
    """Whether the ray from p along d (t >= 0) misses the box lo..hi: the slab test, an axis with d = 0 missed
    when p is outside its slab."""
    t0, t1 = 0.0, np.inf
    for a in range(3):
        p, d = (px, py, pz)[a], (dx, dy, dz)[a]
        if d == 0.0:
            if p < lo[a] or p > hi[a]:
                return True
            continue
        ta, tb = (lo[a] - p) / d, (hi[a] - p) / d
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return t0 > t1


@nb.njit(**JIT, inline="always")
def _same_matrix(a, b):
    """Whether two (3, 4) matrices are equal entry by entry."""
    same = True
    for r in range(3):
        for c in range(4):
            same &= a[r, c] == b[r, c]
    return same


@nb.njit(**JIT)
def ray_windings(points, tilt, center, box_lo, box_hi, t_eps, max_spread, inst_root, inst_w2o, inst_sign, inst_sphere,
                 bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, caps, cap_lanes,
                 cap_lo, cap_hi, w_out, unsure, bound, blk0, blk1):
    """w_out[i] = the winding number of point i (blocks blk0..blk1) over all instances: for a mesh instance the
    signed count of one ray's crossings (along tilt + the unit direction from `center` to the point, moved into
    the instance's object space, times the instance's inst_sign), for a sphere instance 1 inside, 1/2 on the
    surface (as winding.winding_numbers_instances). unsure[i] = True when a crossing is not clean
    (crossings.py's docstring): w_out[i] is then not to be used. `caps`, a second tree's arguments in the same
    order (inst_root .. sph_w2o, then its stack size; no instances: none), is crossed by the same ray and its
    count added (accel/caps.py), and bound[i] = winding.lane_bound's bound on its winding number from cap_lanes.
    A ray that misses cap instance k's world box cap_lo[k]..cap_hi[k] (grown by more than any rounding) is not
    walked in its tree: most rays miss the caps, and their setup and root test cost more than the slab test.
    Every mesh instance of the two together must be closed and consistently oriented (the caller checks). Points
    go PACKET at a time (module docstring); max_spread is the origins' largest spread a packet may have. Points
    outside the box box_lo..box_hi (around every instance of both trees, grown by more than any rounding) are not
    walked: the winding number of closed, consistently oriented surfaces is 0 outside their convex hull, so their
    count is 0 and sure whatever their ray would meet (a query box grown 10% around a mesh: ~40% of the points;
    a chunk of only such points skips its setup too)."""
    n = points.shape[0]
    c_root, c_w2o, c_sign, _, c_bounds, c_child, c_prim, c_tri, _, _, _, c_stack = caps
    stack = np.empty(max(stack_size, c_stack, 1) * 4, np.int32)
    rr, ro = packet_rows(), packet_rows()
    key, order = np.empty(4), np.empty(4, np.int64)
    o16, d16 = np.empty((PACKET, 3)), np.empty((PACKET, 3))
    t0, t1, idx = np.zeros(PACKET), np.full(PACKET, np.inf), np.arange(PACKET)
    signed, w, bad, gone = np.empty(PACKET), np.empty(PACKET), np.empty(PACKET, np.bool_), np.empty(PACKET, np.bool_)
    miss = np.empty(PACKET, np.bool_)
    nan_matrix = np.full((3, 4), np.nan)  # equal to no matrix
    for i0 in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK), PACKET):
        m = min(n, i0 + PACKET) - i0
        rx, ry, rz = d16[:m, 0], d16[:m, 1], d16[:m, 2]
        for r in range(m):
            px, py, pz = points[i0 + r, 0], points[i0 + r, 1], points[i0 + r, 2]
            ax, ay, az = away_from(center, px, py, pz)
            o16[r, 0], o16[r, 1], o16[r, 2] = px, py, pz
            d16[r, 0], d16[r, 1], d16[r, 2] = tilt[0] + ax, tilt[1] + ay, tilt[2] + az
            w[r] = 0.0
            bad[r] = False
        outside = True
        for r in range(m):
            gone[r] = outside_box(o16[r, 0], o16[r, 1], o16[r, 2], box_lo, box_hi)
            outside &= gone[r]
        if outside:
            if c_root.shape[0] > 0:
                _chunk_bounds(cap_lanes, o16, m, bad, bound, i0)
            for r in range(m):
                w_out[i0 + r] = 0.0
                unsure[i0 + r] = False
            continue
        packet = m == PACKET and packet_setup(o16, d16, t0, t1, idx, PACKET, rr, max_spread)[0]
        moved = (False, 0, 0, 0, 0, 0, 0, nan_matrix)  # ro moved by no matrix yet
        for k in range(inst_root.shape[0]):
            s = inst_sphere[k]
            if s >= 0:
                for r in range(m):
                    ox, oy, oz = object_point(inst_w2o[k], o16[r, 0], o16[r, 1], o16[r, 2])
                    w[r] += sphere_winding(ox - sph_center[s, 0], oy - sph_center[s, 1], oz - sph_center[s, 2],
                                           sph_radius[s])
                continue
            moved = _mesh_crossings(k, inst_w2o, inst_root, inst_sign, bounds, child, leaf_prim, leaf_tri, i0, points,
                                    rx, ry, rz, packet, rr, ro, moved, t_eps, stack, key, order, signed, w, bad, gone)
        for k in range(c_root.shape[0]):  # the caps (meshes only), as above, but only the rays entering their box
            walk = False
            for r in range(m):
                miss[r] = gone[r] or bad[r] or misses_box(o16[r, 0], o16[r, 1], o16[r, 2], d16[r, 0], d16[r, 1],
                                                          d16[r, 2], cap_lo[k], cap_hi[k])
                walk |= not miss[r]
            if walk:
                moved = _mesh_crossings(k, c_w2o, c_root, c_sign, c_bounds, c_child, c_prim, c_tri, i0, points, rx, ry,
                                        rz, packet, rr, ro, moved, t_eps, stack, key, order, signed, w, bad, miss)
        if c_root.shape[0] > 0:
            _chunk_bounds(cap_lanes, o16, m, bad, bound, i0)
        for r in range(m):
            w_out[i0 + r] = w[r]
            unsure[i0 + r] = bad[r]


@nb.njit(**JIT)
def outside_bounds(points, box_lo, box_hi, lanes, out, blk0, blk1):
    """out[i] = winding.lane_bound(lanes, point i) for each point outside the box box_lo..box_hi (blocks
    blk0..blk1), -1 for a point inside it. An open mesh's inside test (accel/distance.py) sorts and walks only the
    points inside the scene's box, whose count outside is 0: there only the caps' winding number can put a point
    inside, and this bound says where it must be computed."""
    n = points.shape[0]
    for i in range(blk0 * POINTS_PER_BLOCK, min(n, blk1 * POINTS_PER_BLOCK)):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        out[i] = lane_bound(lanes, px, py, pz) if outside_box(px, py, pz, box_lo, box_hi) else -1.0
