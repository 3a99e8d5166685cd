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
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from ..common import JIT, SPHERE, TRIANGLE
from ..intersect import edge_on, edge_tie, sphere_hit_in_object_space
from ..small_sort import insert_ascending
from .chunks import (
    _BEST,
    _DET,
    _DX,
    _DY,
    _DZ,
    _E1,
    _E2,
    _EXT,
    _EXT_INV,
    _EXT_TMIN,
    _OKX,
    _OKY,
    _OKZ,
    _OX,
    _OY,
    _OZ,
    _PRIM,
    _SX,
    _SY,
    _SZ,
    _TMIN,
)
from .layout import FAR_WIDEN, HI_X, HI_Y, HI_Z, LO_X, LO_Y, LO_Z, NODE_FLOATS, PACKET, WIDTH, leaf_range
from .single import prefetch_children

_UNODE = np.uint64(NODE_FLOATS)
_UX, _UY, _UZ = np.uint64(LO_X + HI_X), np.uint64(LO_Y + HI_Y), np.uint64(LO_Z + HI_Z)


@nb.njit(**JIT, inline="always")
def _edges(rr, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0):
    """Ray k's watertight test of the triangle (vertex coordinates in the packet's shear axes) up to its edge
    functions, with intersect.watertight_triangle's operations: the vertices relative to the ray's origin, sheared
    (az, bz, cz, ax, ay, bx, by, cx, cy), and the edge functions e0, e1, e2. The one copy of this arithmetic
    that _any_inside, _packet_leaf and _packet_ties share, so all three decide on the same bits."""
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
    return az, bz, cz, ax, ay, bx, by, cx, cy, cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax


@nb.njit(**JIT, inline="always")
def _flat(rr, k, det, ax, ay, az, bx, by, bz, cx, cy, cz):
    """intersect.edge_on for ray k of the packet rr (its shear read from the packet's rows): the ray lies in the
    triangle's plane up to rounding, a miss."""
    return edge_on(det, ax, ay, az, bx, by, bz, cx, cy, cz, rr[_SX + k], rr[_SY + k])


@nb.njit(**JIT, inline="always")
def _mixed(e0, e1, e2):
    """Whether edge functions have mixed signs (the ray passes outside the triangle)."""
    return ((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0))


@nb.njit(**JIT, inline="always")
def _any_inside(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, rr):
    """Whether any of the packet's rays may pass the watertight test's edge test of the triangle (edge functions
    without mixed signs: a superset of the rays _packet_leaf accepts, which also settles ties by edge_tie): most
    triangles of a leaf miss every ray of a 4 x 4 tile, and this loop (no division, no stores) lets _packet_leaf
    skip them."""
    inside = 0
    for k in range(PACKET):
        _, _, _, _, _, _, _, _, _, e0, e1, e2 = _edges(rr, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0)
        inside += ~_mixed(e0, e1, e2)
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
                az, bz, cz, ax, ay, bx, by, cx, cy, e0, e1, e2 = _edges(rr, k, ax0, ay0, az0, bx0, by0, bz0, cx0,
                                                                       cy0, cz0)
                det = e0 + e1 + e2
                t = rr[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
                best = rr[_BEST + k]
                # a ray on an edge or a vertex (an edge function of 0) is left to _packet_ties, after this loop
                on_edge = (e0 == 0.0) | (e1 == 0.0) | (e2 == 0.0)
                ties += on_edge
                flat = _flat(rr, k, det, ax, ay, az, bx, by, bz, cx, cy, cz)
                ok = ~flat & (rr[_TMIN + k] < t) & (t < best) & ~on_edge & ~_mixed(e0, e1, e2)
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
    intersect.edge_tie's tie-break), recorded as _packet_leaf records a hit. Kept out of the vector loop so that
    its common case does no more work than before the tie-break."""
    for k in range(PACKET):
        az, bz, cz, ax, ay, bx, by, cx, cy, e0, e1, e2 = _edges(rr, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0)
        if not (e0 == 0.0 or e1 == 0.0 or e2 == 0.0):
            continue
        if not edge_tie(e0, e1, e2, ax, ay, bx, by, cx, cy):
            continue
        det = e0 + e1 + e2
        if _flat(rr, k, det, ax, ay, az, bx, by, bz, cx, cy, cz):
            continue
        t = rr[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
        if rr[_TMIN + k] < t < rr[_BEST + k]:
            if any_mode:
                rr[_BEST + k] = -np.inf
            else:
                rr[_BEST + k], rr[_E1 + k], rr[_E2 + k], rr[_DET + k], rr[_PRIM + k] = t, e1, e2, det, fp


@nb.njit(**JIT)
def packet_traverse(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                    nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, any_mode):
    """Traverse one tree with a coherent packet (see above). key (4,) float64 and order (4,) int64 are
    scratch. A node's children are prefetched as the one-ray walk does (single.prefetch_children: the 1.1M bunny's
    tree is ~67 MB, and ~45% of this walk's time there was waiting on cold nodes and leaves), its child boxes are
    tested against the packet as a whole (packet_node4, the vector form of packet_node), children are ordered by
    the packet's entry distance, which the stack keeps: a node is skipped when it lies beyond every ray's closest
    hit so far (packet_pop). Leaves met in a node are tested at once, against all the packet's rays (the triangle
    test is exact, so a ray outside the leaf's box just misses).
    Callers pass root as int32 and any_mode as a run-time np.bool_, never a literal: one compiled version then
    serves closest and any hit, one tree and instances (a literal compiled four, ~2.6 s each on a cold cache; no
    speed difference measured)."""
    ext = packet_extents(rr, nrx, nry, nrz)
    stack_node[0] = root
    stack_t[0] = -np.inf
    sp = 1
    far = _packet_far(rr)
    while True:
        node, sp = packet_pop(stack_node, stack_t, sp, far)
        if node < 0:
            break
        codes = prefetch_children(bounds, leaf_tri, child, node)
        n_in = packet_node4(bounds, codes, node, nrx, nry, nrz, ext, far, key, order)
        for q in range(n_in):  # leaves now, nearest first
            c = child[node, order[q]]
            if c < 0:
                _packet_leaf(c, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, kx, ky, kz, rr, any_mode)
                far = _packet_far(rr)
        sp = push_inner(child, node, key, order, n_in, stack_node, stack_t, sp)


@nb.njit(**JIT, inline="always")
def packet_extents(rr, nrx, nry, nrz):
    """The packet's bounds for packet_node, from the extremes packet_setup stored: per axis the origin extreme
    that minimises the near plane's distance and the one that maximises the far one's, the reciprocal
    directions' extremes (one sign per axis), and the lowest t_min."""
    oxl, oxh, oyl, oyh, ozl, ozh = rr[_EXT], rr[_EXT + 1], rr[_EXT + 2], rr[_EXT + 3], rr[_EXT + 4], rr[_EXT + 5]
    onx, ofx = (oxh, oxl) if nrx == LO_X else (oxl, oxh)
    ony, ofy = (oyh, oyl) if nry == LO_Y else (oyl, oyh)
    onz, ofz = (ozh, ozl) if nrz == LO_Z else (ozl, ozh)
    inv = _EXT + _EXT_INV
    return (onx, ofx, ony, ofy, onz, ofz, rr[inv], rr[inv + 1], rr[inv + 2], rr[inv + 3], rr[inv + 4], rr[inv + 5],
            rr[_EXT + _EXT_TMIN])


@nb.njit(**JIT, inline="always")
def packet_node(bounds, child, node, nrx, nry, nrz, ext, far, key, order):
    """The children of `node` that a ray of the packet may enter before `far`: each child box tested once for the
    whole packet (_packet_slab's bounds, ext = packet_extents), the entered lanes into order[:n] nearest first
    with their entry bounds in key[:n]; returns n. The node test of packet_traverse and of the two-level
    kernels' walk over instances (instance_packets.packet_instances)."""
    onx, ofx, ony, ofy, onz, ofz, ixl, ixh, iyl, iyh, izl, izh, tlo = ext
    base = node * NODE_FLOATS
    n_in = 0
    for lane in range(WIDTH):
        if child[node, lane] == 0:
            continue
        b = base + lane
        tn, tf = tlo, far
        a, e = _packet_slab(bounds[b + nrx], bounds[b + (LO_X + HI_X) - nrx], onx, ofx, ixl, ixh)
        tn, tf = max(tn, a), min(tf, e)
        a, e = _packet_slab(bounds[b + nry], bounds[b + (LO_Y + HI_Y) - nry], ony, ofy, iyl, iyh)
        tn, tf = max(tn, a), min(tf, e)
        a, e = _packet_slab(bounds[b + nrz], bounds[b + (LO_Z + HI_Z) - nrz], onz, ofz, izl, izh)
        tn, tf = max(tn, a), min(tf, e)
        if tn <= tf + abs(tf) * FAR_WIDEN:
            n_in = insert_ascending(key, order, n_in, tn, lane)  # nearest first
    return n_in


@nb.njit(**JIT, inline="always")
def packet_node4(bounds, codes, node, nrx, nry, nrz, ext, far, key, order):
    """packet_node's test in 4-wide vector code (packet_entry4: the four lanes' bounds at once, the operations
    and their order those of _packet_slab, so the same entry bounds to the bit), given the node's child codes
    (single.prefetch_children's, which also started loading the children): returns n as packet_node does.
    packet_traverse's node test; the other walks keep packet_node."""
    onx, ofx, ony, ofy, onz, ofz, ixl, ixh, iyl, iyh, izl, izh, tlo = ext
    base = np.uint64(node) * _UNODE
    rx, ry, rz = np.uint64(nrx), np.uint64(nry), np.uint64(nrz)
    d0, d1, d2, d3 = packet_entry4(bounds, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry), base + rz,
                                   base + (_UZ - rz), (onx, ony, onz), (ofx, ofy, ofz), (ixl, iyl, izl),
                                   (ixh, iyh, izh), tlo, far, FAR_WIDEN)
    c0, c1, c2, c3 = codes
    n_in = 0
    if c0 != 0 and d0 < np.inf:
        n_in = insert_ascending(key, order, n_in, d0, 0)
    if c1 != 0 and d1 < np.inf:
        n_in = insert_ascending(key, order, n_in, d1, 1)
    if c2 != 0 and d2 < np.inf:
        n_in = insert_ascending(key, order, n_in, d2, 2)
    if c3 != 0 and d3 < np.inf:
        n_in = insert_ascending(key, order, n_in, d3, 3)
    return n_in


def _splat(builder, value):
    """A <4 x double> with `value` in every lane."""
    vec = ir.Constant(ir.VectorType(ir.DoubleType(), 4), ir.Undefined)
    for lane in range(4):
        vec = builder.insert_element(vec, value, ir.Constant(ir.IntType(32), lane))
    return vec


def _row(builder, data, offset):
    """The 4 float32 lanes at flat element `offset` of `data` (float*), widened to <4 x double>."""
    ptr = builder.bitcast(builder.gep(data, [offset]), ir.VectorType(ir.FloatType(), 4).as_pointer())
    return builder.fpext(builder.load(ptr, align=4), ir.VectorType(ir.DoubleType(), 4))


@intrinsic
def packet_entry4(typingctx, bounds, near_x, far_x, near_y, far_y, near_z, far_z, o_near, o_far, i_lo, i_hi,
                  t_lo, t_hi, widen):
    """(d0, d1, d2, d3): the packet's entry bound into each of the 4 boxes whose planes are the float32 rows at
    flat offsets near_* / far_* (uint64) of `bounds`, or inf for a box no ray of the packet enters within
    [t_lo, t_hi]. Per axis and lane, _packet_slab's bounds: v = near - o_near, a = v * (i_lo if v >= 0 else
    i_hi), w = far - o_far, b = w * (i_hi if w >= 0 else i_lo) (tuples o_near, o_far, i_lo, i_hi of float64
    per axis); tn from t_lo grows to a where a > tn, tf from t_hi shrinks to b where b < tf, and a lane is
    entered when tn <= tf + |tf| * widen. One AVX2 instruction per row and operation instead of 4 scalar ones
    with branches (LLVM left packet_node's lane loop scalar)."""
    sig = types.UniTuple(types.float64, 4)(bounds, near_x, far_x, near_y, far_y, near_z, far_z, o_near, o_far,
                                           i_lo, i_hi, t_lo, t_hi, widen)

    def codegen(context, builder, signature, args):
        arr, nx, fx, ny, fy, nz, fz, on, of, ilo, ihi, lo, hi, wid = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        f64 = ir.DoubleType()
        zero = _splat(builder, ir.Constant(f64, 0.0))
        tn = _splat(builder, lo)
        tf = _splat(builder, hi)
        for axis, (near, far) in enumerate(((nx, fx), (ny, fy), (nz, fz))):
            lo_i = _splat(builder, builder.extract_value(ilo, axis))
            hi_i = _splat(builder, builder.extract_value(ihi, axis))
            v = builder.fsub(_row(builder, data, near), _splat(builder, builder.extract_value(on, axis)))
            w = builder.fsub(_row(builder, data, far), _splat(builder, builder.extract_value(of, axis)))
            a = builder.fmul(v, builder.select(builder.fcmp_ordered(">=", v, zero), lo_i, hi_i))
            b = builder.fmul(w, builder.select(builder.fcmp_ordered(">=", w, zero), hi_i, lo_i))
            tn = builder.select(builder.fcmp_ordered(">", a, tn), a, tn)
            tf = builder.select(builder.fcmp_ordered("<", b, tf), b, tf)
        fabs = cgutils.get_or_insert_function(builder.module, ir.FunctionType(tf.type, [tf.type]), "llvm.fabs.v4f64")
        reach = builder.fadd(tf, builder.fmul(builder.call(fabs, [tf]), _splat(builder, wid)))
        dist = builder.select(builder.fcmp_ordered("<=", tn, reach), tn, _splat(builder, ir.Constant(f64, np.inf)))
        lanes = [builder.extract_element(dist, ir.Constant(ir.IntType(32), k)) for k in range(4)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return sig, codegen


@nb.njit(**JIT, inline="always")
def packet_pop(stack_node, stack_t, sp, far):
    """The next stacked node a ray of the packet may still need: (node, or -1 when none is left or every ray has
    retired (far = -inf, any-hit), stack pointer). A node whose entry bound lies beyond every ray's closest hit
    so far is dropped: no ray's box test could pass below it (children lie inside its box)."""
    while sp > 0 and far != -np.inf:
        sp -= 1
        if not stack_t[sp] > far + abs(far) * FAR_WIDEN:
            return stack_node[sp], sp
    return -1, sp


@nb.njit(**JIT, inline="always")
def push_inner(child, node, key, order, n_in, stack_node, stack_t, sp):
    """Push the inner children among the lanes order[:n_in] (packet_node's) with their entry bounds, farthest
    first so that the nearest is popped first; returns the stack pointer."""
    for q in range(n_in - 1, -1, -1):
        c = child[node, order[q]]
        if c > 0:
            stack_node[sp] = c
            stack_t[sp] = key[q]
            sp += 1
    return sp


@nb.njit(**JIT, inline="always")
def packet_barycentrics(rr):
    """After packet_traverse: every ray's barycentrics (0, 0 without a hit) into its hit rows, in a loop that
    vectorises; packet_hit reads them."""
    for k in range(PACKET):
        rr[_E1 + k], rr[_E2 + k] = rr[_E1 + k] / rr[_DET + k], rr[_E2 + k] / rr[_DET + k]


@nb.njit(**JIT, inline="always")
def packet_hit(rr, k):
    """Ray k's closest hit after packet_barycentrics: (t so far, primitive code (triangle id, -(sphere + 1), or -inf
    when nothing in the tree was hit), u, v)."""
    return rr[_BEST + k], rr[_PRIM + k], rr[_E1 + k], rr[_E2 + k]


@nb.njit(**JIT, inline="always")
def packet_retired(rr, k):
    """Whether ray k has retired (any-hit: it hit something)."""
    return rr[_BEST + k] == -np.inf


@nb.njit(**JIT, inline="always")
def hit_of_code(code):
    """(kind, primitive) of a primitive code >= 0 or > -inf (the _PRIM row): a triangle id, or -(sphere + 1)."""
    return (TRIANGLE if code >= 0.0 else SPHERE), (np.int32(code) if code >= 0.0 else np.int32(-code - 1.0))


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


