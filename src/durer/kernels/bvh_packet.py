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

from .intersect import shear_axes, sphere_hit_in_object_space
from .layout import (
    FAR_WIDEN,
    HI_X,
    HI_Y,
    HI_Z,
    JIT,
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
from .small_sort import insert_ascending

# Scratch rows of `rr` (float64, (_NROW, PACKET)):
(_OX, _OY, _OZ, _IX, _IY, _IZ, _TMIN, _BEST, _OKX, _OKY, _OKZ, _SX, _SY, _SZ, _E1, _E2, _DET, _DX, _DY, _DZ,
 _PRIM) = range(21)
_NROW = 21


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


@nb.njit(**JIT)
def packet_setup(origins, directions, t_min, t_max, idx, n, rr, max_spread):
    """Load rays idx[:n] into the scratch rows (padding rays never hit) and return (coherent, nrx, nry, nrz,
    kx, ky, kz): coherent when all n rays share direction signs and axis permutation, their directions lie
    within PACKET_CONE of the first ray's and their origins within max_spread of each other (packet_spread_limit)
    on every axis. Only then are the per-ray constants computed (in a loop over rays that vectorises, with
    ray_setup's exact operations)."""
    i0 = idx[0]
    dx0, dy0, dz0 = directions[i0, 0], directions[i0, 1], directions[i0, 2]
    kx0, ky0, kz0 = shear_axes(dx0, dy0, dz0)
    s0 = (dx0 < 0.0) + 2 * (dy0 < 0.0) + 4 * (dz0 < 0.0)
    cone0 = PACKET_CONE * np.sqrt(dx0 * dx0 + dy0 * dy0 + dz0 * dz0)
    coherent = True
    for k in range(PACKET):
        i = idx[k] if k < n else i0
        dx, dy, dz = directions[i, 0], directions[i, 1], directions[i, 2]
        kx, ky, kz = shear_axes(dx, dy, dz)
        sgn = (dx < 0.0) + 2 * (dy < 0.0) + 4 * (dz < 0.0)
        if (sgn != s0 or kx != kx0 or ky != ky0 or kz != kz0
                or dx * dx0 + dy * dy0 + dz * dz0 < cone0 * np.sqrt(dx * dx + dy * dy + dz * dz)):
            coherent = False
            break
        rr[_OX, k], rr[_OY, k], rr[_OZ, k] = origins[i, 0], origins[i, 1], origins[i, 2]
        rr[_DX, k], rr[_DY, k], rr[_DZ, k] = dx, dy, dz
        if k < n:
            rr[_TMIN, k], rr[_BEST, k] = t_min[i], t_max[i]
        else:
            rr[_TMIN, k], rr[_BEST, k] = np.inf, -np.inf
    if coherent:
        for row in (_OX, _OY, _OZ):
            lo = hi = rr[row, 0]
            for k in range(1, PACKET):
                lo, hi = min(lo, rr[row, k]), max(hi, rr[row, k])
            if hi - lo > max_spread:
                coherent = False
    if not coherent:
        return False, 0, 4, 8, kx0, ky0, kz0
    for k in range(PACKET):
        dx, dy, dz = rr[_DX, k], rr[_DY, k], rr[_DZ, k]
        rr[_IX, k] = 1.0 / (dx if dx != 0.0 else 1e-300)
        rr[_IY, k] = 1.0 / (dy if dy != 0.0 else 1e-300)
        rr[_IZ, k] = 1.0 / (dz if dz != 0.0 else 1e-300)
        dkz = rr[_DX + kz0, k]
        rr[_SX, k] = rr[_DX + kx0, k] / dkz
        rr[_SY, k] = rr[_DX + ky0, k] / dkz
        rr[_SZ, k] = 1.0 / dkz
        rr[_OKX, k] = rr[_OX + kx0, k]
        rr[_OKY, k] = rr[_OX + ky0, k]
        rr[_OKZ, k] = rr[_OX + kz0, k]
        rr[_E1, k] = 0.0
        rr[_E2, k] = 0.0
        rr[_DET, k] = 1.0
        rr[_PRIM, k] = -np.inf
    # near-plane row offsets as in ray_setup (a zero component counts as positive there too)
    nrx = 12 if rr[_IX, 0] < 0.0 else 0
    nry = 16 if rr[_IY, 0] < 0.0 else 4
    nrz = 20 if rr[_IZ, 0] < 0.0 else 8
    return True, nrx, nry, nrz, kx0, ky0, kz0


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
            ax0, ay0, az0 = leaf_tri[base + kx], leaf_tri[base + ky], leaf_tri[base + kz]
            bx0, by0, bz0 = leaf_tri[base + 3 + kx], leaf_tri[base + 3 + ky], leaf_tri[base + 3 + kz]
            cx0, cy0, cz0 = leaf_tri[base + 6 + kx], leaf_tri[base + 6 + ky], leaf_tri[base + 6 + kz]
            for k in range(PACKET):
                okx, oky, okz = rr[_OKX, k], rr[_OKY, k], rr[_OKZ, k]
                sx, sy, sz = rr[_SX, k], rr[_SY, k], rr[_SZ, k]
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
                best = rr[_BEST, k]
                ok = ((det != 0.0) & (rr[_TMIN, k] < t) & (t < best)
                      & ~(((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0))))
                if any_mode:
                    rr[_BEST, k] = -np.inf if ok else best
                else:
                    rr[_BEST, k] = t if ok else best
                    rr[_E1, k] = e1 if ok else rr[_E1, k]
                    rr[_E2, k] = e2 if ok else rr[_E2, k]
                    rr[_DET, k] = det if ok else rr[_DET, k]
                    rr[_PRIM, k] = fp if ok else rr[_PRIM, k]
        else:
            s = -p - 1
            for k in range(PACKET):
                if rr[_BEST, k] > -np.inf:
                    best = rr[_BEST, k]
                    t = sphere_hit_in_object_space((rr[_OX, k], rr[_OY, k], rr[_OZ, k]),
                                                   (rr[_DX, k], rr[_DY, k], rr[_DZ, k]), sph_center[s],
                                                   sph_radius[s], sph_w2o[s], rr[_TMIN, k], best)
                    if t < best:
                        if any_mode:
                            rr[_BEST, k] = -np.inf
                        else:
                            rr[_BEST, k] = t
                            rr[_E1, k], rr[_E2, k], rr[_DET, k] = 0.0, 0.0, 1.0
                            rr[_PRIM, k] = -(s + 1.0)


@nb.njit(**JIT)
def packet_traverse(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                    nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, any_mode):
    """Traverse one tree with a coherent packet (see above). key (4,) float64 and order (4,) int64 are
    scratch. A node's child boxes are tested against the packet as a whole (_packet_slab: bounds over its rays,
    conservative to the bit), children are ordered by the packet's entry distance, which the stack keeps: a
    node is skipped when it lies beyond every ray's closest hit so far. Leaves met in a node are tested at once,
    against all the packet's rays (the triangle test is exact, so a ray outside the leaf's box just misses)."""
    # the packet's extremes: origins, reciprocal directions (one sign per axis), t_min
    oxl = oxh = rr[_OX, 0]
    oyl = oyh = rr[_OY, 0]
    ozl = ozh = rr[_OZ, 0]
    ixl = ixh = rr[_IX, 0]
    iyl = iyh = rr[_IY, 0]
    izl = izh = rr[_IZ, 0]
    tlo = rr[_TMIN, 0]
    for k in range(1, PACKET):
        oxl, oxh = min(oxl, rr[_OX, k]), max(oxh, rr[_OX, k])
        oyl, oyh = min(oyl, rr[_OY, k]), max(oyh, rr[_OY, k])
        ozl, ozh = min(ozl, rr[_OZ, k]), max(ozh, rr[_OZ, k])
        ixl, ixh = min(ixl, rr[_IX, k]), max(ixh, rr[_IX, k])
        iyl, iyh = min(iyl, rr[_IY, k]), max(iyh, rr[_IY, k])
        izl, izh = min(izl, rr[_IZ, k]), max(izh, rr[_IZ, k])
        tlo = min(tlo, rr[_TMIN, k])
    # the origin extreme that minimises the near plane's distance and the one that maximises the far one's
    onx, ofx = (oxh, oxl) if nrx == 0 else (oxl, oxh)
    ony, ofy = (oyh, oyl) if nry == 4 else (oyl, oyh)
    onz, ofz = (ozh, ozl) if nrz == 8 else (ozl, ozh)
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
        b = rr[_BEST, k]
        far = b if b > far else far
    return far


