"""Coherent ray packets through one BVH (Numba): PACKET rays share each node visit.

Coherent rays (a chunk of PACKET rays whose directions share their signs and the watertight test's axis
permutation, as camera and shadow rays do; consecutive rays, or a 4 x 4 tile of an image) are traversed
together: a node visit tests each child box once for the whole packet, with interval bounds over the packet's
origins and reciprocal directions that no ray's own slab test can beat (so nothing is culled that the one-ray
path would enter), and a leaf's triangles are tested against all its rays in a loop that LLVM vectorises
(AVX2: 4 float64 rays an instruction). Every ray does exactly the arithmetic of the one-ray path's watertight
test with the same constants, so t, u, v agree to the bit; only the visit order differs, which can change the
primitive named on an exact tie in t.

The leaf test repeats the watertight test of kernels/intersect.py inline, over a packet's rays: written that way
LLVM vectorises it (measured: a call per ray is not vectorised and is slower).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from ..intersect import edge_sign, shear_axes, sphere_hit_in_object_space
from ..small_sort import insert_ascending
from .layout import (
    FAR_WIDEN,
    HI_X,
    HI_Y,
    HI_Z,
    LO_X,
    LO_Y,
    LO_Z,
    NODE_FLOATS,
    PACKET,
    PACKET_CONE,
    TILE,
    WIDTH,
    leaf_range,
)

# The packet's scratch `rr`: a flat float64 array of _NROW rows of PACKET, row r at offset r * PACKET, so ray k of
# row _X is rr[_X + k] (the names below are offsets) and a row picked at run time (axis a after _DX) is
# rr[_DX + a * PACKET + k]. Flat, every address is a constant offset from one pointer, so LLVM sees that the rows
# do not overlap and vectorises the loops over rays without run-time checks (a 2-D (_NROW, PACKET) array has a
# run-time row stride: measured 1.3x slower traversal). Per ray, but for _EXT, the packet's extremes
# (packet_setup): columns 0-5 the origins' lo, hi on x, y, z; 6-11 the reciprocal directions' lo, hi; 12 the
# lowest t_min.
_NROW = 19
(_OX, _OY, _OZ, _EXT, _TMIN, _BEST, _OKX, _OKY, _OKZ, _SX, _SY, _SZ, _E1, _E2, _DET, _DX, _DY, _DZ,
 _PRIM) = range(0, _NROW * PACKET, PACKET)
_EXT_INV = 6   # column of the reciprocal directions' extremes in _EXT
_EXT_TMIN = 12  # column of the lowest t_min in _EXT


@nb.njit(**JIT, inline="always")
def chunk_rays(c, n, width, idx):
    """The rays of chunk c into idx; returns how many. width = 0: rays c * PACKET onwards, in order. width > 0
    (the rays are an image `width` wide, both sides multiples of TILE): the TILE x TILE tile c, row by row,
    whose rays are closer together than a 16 x 1 strip's, so a packet visits fewer nodes. (8 x 8 tiles of 64
    rays measured slower: more rays test each leaf.)"""
    if width == 0:
        i0 = c * PACKET
        m = min(n, i0 + PACKET) - i0
        for k in range(m):
            idx[k] = i0 + k
        return m
    tiles = width // TILE
    ty = c // tiles
    tx = c - ty * tiles
    for k in range(PACKET):
        idx[k] = (TILE * ty + k // TILE) * width + TILE * tx + k % TILE
    return PACKET


@nb.njit(**JIT, inline="always")
def _pick(axis, x, y, z):
    """x, y or z by axis 0, 1 or 2."""
    return x if axis == 0 else (y if axis == 1 else z)


@nb.njit(**JIT, inline="always")
def _nonzero(x):
    """A direction component as the slab test takes it: 0 as 1e-300 (ray_setup's reciprocal of 1e300)."""
    return x if x != 0.0 else 1e-300


@nb.njit(**JIT)
def packet_setup(origins, directions, t_min, t_max, idx, n, rr, max_spread):
    """Load rays idx[:n] into the scratch rows (padding rays never hit) and return (coherent, nrx, nry, nrz,
    kx, ky, kz): coherent when all n rays share direction signs and axis permutation, their directions lie
    within PACKET_CONE of the first ray's and their origins within max_spread of each other (packet_spread_limit)
    on every axis. Only then are the per-ray constants computed, with ray_setup's exact operations. Each loop
    reads and writes few rows, so that LLVM vectorises it (one loop writing every row was left scalar: too many
    arrays to check for overlap)."""
    i0 = idx[0]
    dx0, dy0, dz0 = directions[i0, 0], directions[i0, 1], directions[i0, 2]
    kx0, ky0, kz0 = shear_axes(dx0, dy0, dz0)
    s0 = (dx0 < 0.0) + 2 * (dy0 < 0.0) + 4 * (dz0 < 0.0)
    cone0 = PACKET_CONE * np.sqrt(dx0 * dx0 + dy0 * dy0 + dz0 * dz0)
    for k in range(PACKET):
        i = idx[k] if k < n else i0
        rr[_DX + k], rr[_DY + k], rr[_DZ + k] = directions[i, 0], directions[i, 1], directions[i, 2]
    bad = 0
    for k in range(PACKET):
        dx, dy, dz = rr[_DX + k], rr[_DY + k], rr[_DZ + k]
        ax, ay, az = abs(dx), abs(dy), abs(dz)
        kz = 0 if (ax >= ay) & (ax >= az) else (1 if ay >= az else 2)  # shear_axes' kz; kx, ky follow the signs
        sgn = (dx < 0.0) + 2 * (dy < 0.0) + 4 * (dz < 0.0)
        bad += ((sgn != s0) | (kz != kz0)
                | (dx * dx0 + dy * dy0 + dz * dz0 < cone0 * np.sqrt(dx * dx + dy * dy + dz * dz)))
    if bad:
        return False, LO_X, LO_Y, LO_Z, kx0, ky0, kz0
    for k in range(PACKET):
        i = idx[k] if k < n else i0
        rr[_OX + k], rr[_OY + k], rr[_OZ + k] = origins[i, 0], origins[i, 1], origins[i, 2]
        if k < n:
            rr[_TMIN + k], rr[_BEST + k] = t_min[i], t_max[i]
        else:
            rr[_TMIN + k], rr[_BEST + k] = np.inf, -np.inf
    for axis in range(3):
        lo = hi = rr[_OX + axis * PACKET]
        for k in range(1, PACKET):
            lo, hi = min(lo, rr[_OX + axis * PACKET + k]), max(hi, rr[_OX + axis * PACKET + k])
        if hi - lo > max_spread:
            return False, LO_X, LO_Y, LO_Z, kx0, ky0, kz0
        rr[_EXT + 2 * axis], rr[_EXT + 2 * axis + 1] = lo, hi
    # the reciprocal directions' extremes (a zero component as 1e-300, as ray_setup takes it): the rays share each
    # component's sign and 1 / x falls with x on either side of 0, rounding included, so the extremes of the
    # rounded reciprocals are the reciprocals of the extremes: 6 divisions a packet, not 48, and the same bits
    for axis in range(3):
        lo = hi = _nonzero(rr[_DX + axis * PACKET])
        for k in range(1, PACKET):
            dk = _nonzero(rr[_DX + axis * PACKET + k])
            lo, hi = min(lo, dk), max(hi, dk)
        rr[_EXT + _EXT_INV + 2 * axis], rr[_EXT + _EXT_INV + 2 * axis + 1] = 1.0 / hi, 1.0 / lo
    tlo = rr[_TMIN]
    for k in range(1, PACKET):
        tlo = min(tlo, rr[_TMIN + k])
    rr[_EXT + _EXT_TMIN] = tlo
    nrx, nry, nrz = packet_constants(rr, kx0, ky0, kz0)
    return True, nrx, nry, nrz, kx0, ky0, kz0


@nb.njit(**JIT, inline="always")
def packet_constants(rr, kx0, ky0, kz0):
    """The per-ray constants of the watertight test for every ray of the packet rr (ray_setup's exact operations,
    shear axes kx0, ky0, kz0 shared by the packet), its hit rows cleared, and the near-plane row offsets (nrx, nry,
    nrz) from the reciprocal directions' extremes, as in ray_setup (a zero component counts as positive there too).
    Used by packet_setup and by instance_packets for rays moved into an instance's object space."""
    for k in range(PACKET):  # rows by selects, not run-time offsets, so LLVM sees no overlap and vectorises
        dx, dy, dz = rr[_DX + k], rr[_DY + k], rr[_DZ + k]
        ox, oy, oz = rr[_OX + k], rr[_OY + k], rr[_OZ + k]
        dkz = _pick(kz0, dx, dy, dz)
        rr[_SX + k] = _pick(kx0, dx, dy, dz) / dkz
        rr[_SY + k] = _pick(ky0, dx, dy, dz) / dkz
        rr[_SZ + k] = 1.0 / dkz
        rr[_OKX + k] = _pick(kx0, ox, oy, oz)
        rr[_OKY + k] = _pick(ky0, ox, oy, oz)
        rr[_OKZ + k] = _pick(kz0, ox, oy, oz)
        rr[_E1 + k] = 0.0
        rr[_E2 + k] = 0.0
        rr[_DET + k] = 1.0
        rr[_PRIM + k] = -np.inf
    nrx = HI_X if rr[_EXT + _EXT_INV] < 0.0 else LO_X
    nry = HI_Y if rr[_EXT + _EXT_INV + 2] < 0.0 else LO_Y
    nrz = HI_Z if rr[_EXT + _EXT_INV + 4] < 0.0 else LO_Z
    return nrx, nry, nrz


@nb.njit(**JIT, inline="always")
def _any_inside(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, rr):
    """Whether any of the packet's rays may pass the watertight test's edge test of the triangle (the sheared
    vertices' edge functions, computed as in _packet_leaf to the bit, do not have mixed signs: a superset of the
    rays _packet_leaf accepts, which also settles ties by edge_sign): most triangles of a leaf miss every ray of a
    4 x 4 tile, and this loop (no division, no stores) lets _packet_leaf skip them."""
    inside = 0
    for k in range(PACKET):
        okx, oky, okz = rr[_OKX + k], rr[_OKY + k], rr[_OKZ + k]
        sx, sy = rr[_SX + k], rr[_SY + k]
        az = az0 - okz
        bz = bz0 - okz
        cz = cz0 - okz
        ax = (ax0 - okx) - sx * az
        ay = (ay0 - oky) - sy * az
        bx = (bx0 - okx) - sx * bz
        by = (by0 - oky) - sy * bz
        cx = (cx0 - okx) - sx * cz
        cy = (cy0 - oky) - sy * cz
        e0 = cx * by - cy * bx
        e1 = ax * cy - ay * cx
        e2 = bx * ay - by * ax
        inside += ~(((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0)))
    return inside > 0


@nb.njit(**JIT, inline="always")
def _packet_leaf(code, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, kx, ky, kz, rr, any_mode):
    """Test a leaf's items against all the packet's rays, in a loop over rays that vectorises; records closer
    hits (any_mode: a hit sets the ray's best to -inf, which retires it)."""
    first, end = leaf_range(code)
    for j in range(first, end):
        p = leaf_prim[j]
        if p >= 0:
            base = j * 9
            fp = np.float64(p)
            # widened to float64 as they load (the leaves may be float32: kernels/bvh/layout.py)
            ax0, ay0, az0 = (np.float64(leaf_tri[base + kx]), np.float64(leaf_tri[base + ky]),
                             np.float64(leaf_tri[base + kz]))
            bx0, by0, bz0 = (np.float64(leaf_tri[base + 3 + kx]), np.float64(leaf_tri[base + 3 + ky]),
                             np.float64(leaf_tri[base + 3 + kz]))
            cx0, cy0, cz0 = (np.float64(leaf_tri[base + 6 + kx]), np.float64(leaf_tri[base + 6 + ky]),
                             np.float64(leaf_tri[base + 6 + kz]))
            if not _any_inside(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, rr):
                continue
            ties = 0
            for k in range(PACKET):
                okx, oky, okz = rr[_OKX + k], rr[_OKY + k], rr[_OKZ + k]
                sx, sy, sz = rr[_SX + k], rr[_SY + k], rr[_SZ + k]
                az = az0 - okz
                bz = bz0 - okz
                cz = cz0 - okz
                ax = (ax0 - okx) - sx * az
                ay = (ay0 - oky) - sy * az
                bx = (bx0 - okx) - sx * bz
                by = (by0 - oky) - sy * bz
                cx = (cx0 - okx) - sx * cz
                cy = (cy0 - oky) - sy * cz
                e0 = cx * by - cy * bx
                e1 = ax * cy - ay * cx
                e2 = bx * ay - by * ax
                det = e0 + e1 + e2
                t = sz * (e0 * az + e1 * bz + e2 * cz) / det
                best = rr[_BEST + k]
                # a ray on an edge or a vertex (an edge function of 0) is left to _packet_ties, after this loop
                on_edge = (e0 == 0.0) | (e1 == 0.0) | (e2 == 0.0)
                ties += on_edge
                ok = ((det != 0.0) & (rr[_TMIN + k] < t) & (t < best) & ~on_edge
                      & ~(((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0))))
                if any_mode:
                    rr[_BEST + k] = -np.inf if ok else best
                else:
                    rr[_BEST + k] = t if ok else best
                    rr[_E1 + k] = e1 if ok else rr[_E1 + k]
                    rr[_E2 + k] = e2 if ok else rr[_E2 + k]
                    rr[_DET + k] = det if ok else rr[_DET + k]
                    rr[_PRIM + k] = fp if ok else rr[_PRIM + k]
            if ties:
                _packet_ties(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, fp, rr, any_mode)
        else:
            s = -p - 1
            for k in range(PACKET):
                if rr[_BEST + k] > -np.inf:
                    best = rr[_BEST + k]
                    t = sphere_hit_in_object_space((rr[_OX + k], rr[_OY + k], rr[_OZ + k]),
                                                   (rr[_DX + k], rr[_DY + k], rr[_DZ + k]), sph_center[s],
                                                   sph_radius[s], sph_w2o[s], rr[_TMIN + k], best)
                    if t < best:
                        if any_mode:
                            rr[_BEST + k] = -np.inf
                        else:
                            rr[_BEST + k] = t
                            rr[_E1 + k], rr[_E2 + k], rr[_DET + k] = 0.0, 0.0, 1.0
                            rr[_PRIM + k] = -(s + 1.0)


@nb.njit(**JIT, inline="always")
def _packet_ties(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, fp, rr, any_mode):
    """The rays of the packet that lie exactly on an edge or a vertex of the triangle (rare), which _packet_leaf's
    vector loop leaves out: the one-ray test's decision for them (the same arithmetic, to the bit, and
    intersect.edge_sign's tie-break), recorded as _packet_leaf records a hit. Kept out of the vector loop so that
    its common case does no more work than before the tie-break."""
    for k in range(PACKET):
        okx, oky, okz = rr[_OKX + k], rr[_OKY + k], rr[_OKZ + k]
        sx, sy, sz = rr[_SX + k], rr[_SY + k], rr[_SZ + k]
        az = az0 - okz
        bz = bz0 - okz
        cz = cz0 - okz
        ax = (ax0 - okx) - sx * az
        ay = (ay0 - oky) - sy * az
        bx = (bx0 - okx) - sx * bz
        by = (by0 - oky) - sy * bz
        cx = (cx0 - okx) - sx * cz
        cy = (cy0 - oky) - sy * cz
        e0 = cx * by - cy * bx
        e1 = ax * cy - ay * cx
        e2 = bx * ay - by * ax
        if not (e0 == 0.0 or e1 == 0.0 or e2 == 0.0):
            continue
        s0 = edge_sign(e0, bx, by, cx, cy)
        if s0 != edge_sign(e1, cx, cy, ax, ay) or s0 != edge_sign(e2, ax, ay, bx, by):
            continue
        det = e0 + e1 + e2
        if det == 0.0:
            continue
        t = sz * (e0 * az + e1 * bz + e2 * cz) / det
        if rr[_TMIN + k] < t < rr[_BEST + k]:
            if any_mode:
                rr[_BEST + k] = -np.inf
            else:
                rr[_BEST + k], rr[_E1 + k], rr[_E2 + k], rr[_DET + k], rr[_PRIM + k] = t, e1, e2, det, fp


@nb.njit(**JIT)
def packet_traverse(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                    nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, any_mode):
    """Traverse one tree with a coherent packet (see above). key (4,) float64 and order (4,) int64 are
    scratch. A node's child boxes are tested against the packet as a whole (_packet_slab: bounds over its rays,
    conservative to the bit), children are ordered by the packet's entry distance, which the stack keeps: a
    node is skipped when it lies beyond every ray's closest hit so far. Leaves met in a node are tested at once,
    against all the packet's rays (the triangle test is exact, so a ray outside the leaf's box just misses).
    Callers pass root as int32 and any_mode as a run-time np.bool_, never a literal: one compiled version then
    serves closest and any hit, one tree and instances (a literal compiled four, ~2.6 s each on a cold cache; no
    speed difference measured)."""
    # the packet's extremes (packet_setup): origins, reciprocal directions (one sign per axis), t_min
    oxl, oxh, oyl, oyh, ozl, ozh = rr[_EXT], rr[_EXT + 1], rr[_EXT + 2], rr[_EXT + 3], rr[_EXT + 4], rr[_EXT + 5]
    ixl, ixh = rr[_EXT + _EXT_INV], rr[_EXT + _EXT_INV + 1]
    iyl, iyh = rr[_EXT + _EXT_INV + 2], rr[_EXT + _EXT_INV + 3]
    izl, izh = rr[_EXT + _EXT_INV + 4], rr[_EXT + _EXT_INV + 5]
    tlo = rr[_EXT + _EXT_TMIN]
    # the origin extreme that minimises the near plane's distance and the one that maximises the far one's
    onx, ofx = (oxh, oxl) if nrx == LO_X else (oxl, oxh)
    ony, ofy = (oyh, oyl) if nry == LO_Y else (oyl, oyh)
    onz, ofz = (ozh, ozl) if nrz == LO_Z else (ozl, ozh)
    stack_node[0] = root
    stack_t[0] = -np.inf
    sp = 1
    far = _packet_far(rr)
    while sp > 0:
        sp -= 1
        if far == -np.inf:
            break  # every ray has retired (any-hit)
        if stack_t[sp] > far + abs(far) * FAR_WIDEN:
            continue  # no ray's box test could pass below this node (children lie inside its box)
        node = stack_node[sp]
        base = node * NODE_FLOATS
        n_in = 0
        for lane in range(WIDTH):
            c = child[node, lane]
            if c == 0:
                continue
            b = base + lane
            tn, tf = tlo, far
            a, e = _packet_slab(bounds[b + nrx], bounds[b + (LO_X + HI_X) - nrx], onx, ofx, ixl, ixh)
            tn, tf = max(tn, a), min(tf, e)
            a, e = _packet_slab(bounds[b + nry], bounds[b + (LO_Y + HI_Y) - nry], ony, ofy, iyl, iyh)
            tn, tf = max(tn, a), min(tf, e)
            a, e = _packet_slab(bounds[b + nrz], bounds[b + (LO_Z + HI_Z) - nrz], onz, ofz, izl, izh)
            tn, tf = max(tn, a), min(tf, e)
            if not tn <= tf + abs(tf) * FAR_WIDEN:
                continue
            n_in = insert_ascending(key, order, n_in, tn, lane)  # nearest first
        # leaves now (nearest first), inner children onto the stack farthest first
        for q in range(n_in):
            lane = order[q]
            c = child[node, lane]
            if c < 0:
                _packet_leaf(c, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, kx, ky, kz, rr, any_mode)
                far = _packet_far(rr)
        for q in range(n_in - 1, -1, -1):
            c = child[node, order[q]]
            if c > 0:
                stack_node[sp] = c
                stack_t[sp] = key[q]
                sp += 1


@nb.njit(**JIT, inline="always")
def _packet_slab(near_plane, far_plane, o_near, o_far, i_lo, i_hi):
    """Bounds on one slab's entry and exit distances over all rays of a packet: no ray enters before the first
    nor leaves after the second. The rays share the sign of the reciprocal direction i (in [i_lo, i_hi]); the
    distance (plane - o) * i is monotonic in o and bilinear, so its extremes sit at the extreme origin given
    and at i_lo or i_hi by the sign of plane - o. Rounding is monotonic too, so each bound is also one on every
    ray's own computed distance (the one-ray slab test's)."""
    v = np.float64(near_plane) - o_near
    w = np.float64(far_plane) - o_far
    return v * (i_lo if v >= 0.0 else i_hi), w * (i_hi if w >= 0.0 else i_lo)


@nb.njit(**JIT, inline="always")
def _packet_far(rr):
    """The farthest closest-hit-so-far among the packet's rays (-inf once all have retired)."""
    far = -np.inf
    for k in range(PACKET):
        b = rr[_BEST + k]
        far = b if b > far else far
    return far


