"""The float32 node tests of benchmarks/walk_variants.py (issue 21 item 2, session 17): 4 boxes in <4 x float> lanes
(entry4_f32, a drop-in for simd.entry4) and an 8-wide tree collapsed from the 4-wide one, tested in <8 x float>
lanes (collapse8, entry8_f32, make_walk8). Measured there against single.blas_closest; not kept (benchmarks/README.md).

Why the float32 test never culls a box the float64 test (simd.entry4) enters. Per ray and axis, with inv = 1/d:
the near plane's distance uses an origin o_n rounded to float32 towards the side that makes (p - o_n) * inv <=
(p - o) * inv (o_n >= o when inv > 0, o_n <= o when inv < 0; the far plane the other way), so Z = (p - o_n) * inv
<= X = (p - o) * inv exactly. The float32 result m = fl(fl(p - o_n) * inv32), inv32 = 1/d rounded to nearest
(relative error u + 2^-53, u = 2^-24), is Z (1 + theta) with |theta| <= 3.01 u while nothing under- or overflows.
The entry bound L = min(fma(M, 1 - c, -e), fma(M, 1 + c, -e)) of M = max over axes (c = 2^-21 = 8u, e = 2^-125;
a monotone function of M, so applying it after the max is applying it to each axis) is then <= Z - |Z|(c - 4.1u)
for either sign of Z, so below X and below float64's computed value of X (relative error 2^-51) by more than the
widening FAR_WIDEN; e covers results below float32's normal range (absolute errors of 2^-150 an operation). The
exit bound mirrors it. t_lo / t_hi are met in float64 (entry4_f32) or rounded down / up to float32 (entry8_f32),
so the box is entered whenever the float64 test enters it; extra boxes only cost time. Edge cases: d = 0 gives
inv32 = +inf (a plane through o: 0 * inf = NaN, which the selects ignore, as entry4 does); 0 < |d| < 2^-120
gives NaN (that axis ignored: conservative); a ray with |o| > 2^100 or largest |d| outside [2^-60, 2^60] gets NaN
on every axis (enters every box); a box whose float32 entry distance overflows (beyond 3.4e38) is culled, which
the float64 test differs on only for rays that reach that far. The fma margins keep infinities (an empty lane's
box at +inf still misses), which tn - |tn| c would turn into NaN.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from durer.kernels.bvh.layout import leaf_range
from durer.kernels.bvh.simd import _entered, _F64x4, _splat, prefetch, prefetch_pair
from durer.kernels.bvh.single import ray_setup
from durer.kernels.common import MISS, TRIANGLE
from durer.kernels.intersect import watertight_triangle

_JIT = dict(error_model="numpy", nogil=True)  # as kernels/common.JIT, without the disk cache
_U0, _U1, _U2, _U9, _U16 = (np.uint64(k) for k in (0, 1, 2, 9, 16))


_F32x4 = ir.VectorType(ir.FloatType(), 4)
_C32 = 2.0 ** -21      # the float32 node test's relative margin (8 units of float32 rounding): entry4_f32
_TINY32 = 2.0 ** -125  # and its absolute one, for results below float32's normal range


def _splat32(builder, value, width=4):
    """A <width x float> with `value` (a float) in every lane."""
    vec = ir.Constant(ir.VectorType(ir.FloatType(), width), ir.Undefined)
    for lane in range(width):
        vec = builder.insert_element(vec, value, ir.Constant(ir.IntType(32), lane))
    return vec


def _slabs32(builder, data, rows, on, of, inv, width):
    """The float32 slab test of `width` boxes: (entry lower bound, exit upper bound) as <width x float>, before the
    margins (entry4_f32). rows: the 6 flat offsets near x, far x, near y, ...; a NaN lane of an axis is ignored."""
    vt = ir.VectorType(ir.FloatType(), width)
    f32 = ir.FloatType()
    tn = _splat32(builder, ir.Constant(f32, float("-inf")), width)
    tf = _splat32(builder, ir.Constant(f32, float("inf")), width)
    for axis in range(3):
        near, far = rows[2 * axis], rows[2 * axis + 1]
        iv = _splat32(builder, builder.extract_value(inv, axis), width)
        onv = _splat32(builder, builder.extract_value(on, axis), width)
        ofv = _splat32(builder, builder.extract_value(of, axis), width)
        pn = builder.load(builder.bitcast(builder.gep(data, [near]), vt.as_pointer()), align=4)
        pf = builder.load(builder.bitcast(builder.gep(data, [far]), vt.as_pointer()), align=4)
        a = builder.fmul(builder.fsub(pn, onv), iv)
        b = builder.fmul(builder.fsub(pf, ofv), iv)
        tn = builder.select(builder.fcmp_ordered(">", a, tn), a, tn)
        tf = builder.select(builder.fcmp_ordered("<", b, tf), b, tf)
    return tn, tf


def _margins32(builder, tn, tf, width):
    """The entry bound moved down and the exit bound up by a relative 2^-21 and an absolute 2^-125:
    min(fma(tn, 1 - c, -tiny), fma(tn, 1 + c, -tiny)) and max(fma(tf, 1 - c, tiny), fma(tf, 1 + c, tiny)), which
    keeps infinities (an empty lane's box at +inf still misses) where tn - |tn| c would give inf - inf = NaN."""
    vt = ir.VectorType(ir.FloatType(), width)
    f32 = ir.FloatType()
    fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(vt, [vt] * 3), f"llvm.fma.v{width}f32")
    dn = _splat32(builder, ir.Constant(f32, 1.0 - _C32), width)
    up = _splat32(builder, ir.Constant(f32, 1.0 + _C32), width)
    tiny = _splat32(builder, ir.Constant(f32, _TINY32), width)
    ntiny = _splat32(builder, ir.Constant(f32, -_TINY32), width)
    a, b = builder.call(fma, [tn, dn, ntiny]), builder.call(fma, [tn, up, ntiny])
    lo = builder.select(builder.fcmp_ordered("<", a, b), a, b)
    a, b = builder.call(fma, [tf, dn, tiny]), builder.call(fma, [tf, up, tiny])
    hi = builder.select(builder.fcmp_ordered(">", a, b), a, b)
    return lo, hi


@intrinsic
def entry4_f32(typingctx, bounds, near_x, far_x, near_y, far_y, near_z, far_z, on, of, inv, t_lo, t_hi, widen):
    """simd.entry4 with the slab test in float32 lanes: on / of are the per-ray float32 origins for the near /
    far planes (rounded towards the box side that makes the distance a bound: ray_setup_f32), inv the float32
    1/d; the bounds are widened by a relative 2^-21 and an absolute 2^-125, widened to float64 and then met with
    t_lo / t_hi and the same entered test as entry4."""
    f64 = types.float64
    sig = types.UniTuple(f64, 4)(bounds, near_x, far_x, near_y, far_y, near_z, far_z, on, of, inv, t_lo, t_hi, widen)

    def codegen(context, builder, signature, args):
        arr, nx, fx, ny, fy, nz, fz, onear, ofar, inverse, lo, hi, wid = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        tn, tf = _slabs32(builder, data, (nx, fx, ny, fy, nz, fz), onear, ofar, inverse, 4)
        tn, tf = _margins32(builder, tn, tf, 4)
        tn, tf = builder.fpext(tn, _F64x4), builder.fpext(tf, _F64x4)
        lov, hiv = _splat(builder, lo), _splat(builder, hi)
        tn = builder.select(builder.fcmp_ordered(">", tn, lov), tn, lov)
        tf = builder.select(builder.fcmp_ordered("<", tf, hiv), tf, hiv)
        return _entered(context, builder, signature, tn, tf, wid)

    return sig, codegen


@nb.njit(inline="always", **_JIT)
def _up32(x):
    """A float32 at or above x (float64): x moved up by |x| 2^-22 + 2^-140 before rounding to nearest, which
    rounding (relative 2^-24, absolute 2^-150 below the normal range) cannot undo. No nextafter: Numba calls
    libm for it."""
    return np.float32(x + (abs(x) * 2.0 ** -22 + 2.0 ** -140))


@nb.njit(inline="always", **_JIT)
def _down32(x):
    """A float32 at or below x (float64): _up32 mirrored."""
    return np.float32(x - (abs(x) * 2.0 ** -22 + 2.0 ** -140))


@nb.njit(inline="always", **_JIT)
def _axis_f32(o, d, inv):
    """(near origin, far origin, 1/d) of one axis in float32 for entry4_f32: o rounded up and down to float32
    (near takes the one that makes (plane - o) * inv smaller, far the larger), 1/d to nearest; an axis whose
    |1/d| is beyond 2^120 (|d| < 2^-120 but not 0) gets NaN (the test then ignores it); d = 0 (inv = 1e300, the
    float64 test's stand-in) gets +inf."""
    up = _up32(o)
    dn = _down32(o)
    if d == 0.0:
        i32 = np.float32(np.inf)
    elif abs(inv) > 2.0 ** 120:
        i32 = np.float32(np.nan)
    else:
        i32 = np.float32(inv)
    if inv >= 0.0:
        return up, dn, i32
    return dn, up, i32


@nb.njit(inline="always", **_JIT)
def ray_setup_f32(ox, oy, oz, dx, dy, dz, idx, idy, idz):
    """The per-ray float32 constants of entry4_f32: (near origins), (far origins), (1/d) as tuples. A ray outside
    the proof's domain (|o| > 2^100, or its largest |d| outside [2^-60, 2^60], NaNs included) gets NaN for every
    1/d: it then enters every box (correct, only slower)."""
    nx, fx, ix = _axis_f32(ox, dx, idx)
    ny, fy, iy = _axis_f32(oy, dy, idy)
    nz, fz, iz = _axis_f32(oz, dz, idz)
    dmax = max(abs(dx), max(abs(dy), abs(dz)))
    if not (dmax >= 2.0 ** -60 and dmax <= 2.0 ** 60 and max(abs(ox), max(abs(oy), abs(oz))) <= 2.0 ** 100):
        nan = np.float32(np.nan)
        ix, iy, iz = nan, nan, nan
    return (nx, ny, nz), (fx, fy, fz), (ix, iy, iz)


# ---- 8-wide nodes collapsed from the 4-wide tree, tested in <8 x float> lanes (issue 21 item 2, session 17) ----
_UNODE8 = np.uint64(48)
_UX8, _UY8, _UZ8 = np.uint64(0 + 24), np.uint64(8 + 32), np.uint64(16 + 40)


def collapse8(bounds: np.ndarray, child: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An 8-wide tree from the 4-wide one: each node takes its children and opens the inner child of largest
    surface area while its children still fit in 8 lanes (the usual collapse), then the same below. Returns
    bounds (M, 6, 8) float32 (empty lanes at +inf) and child (M, 8) int32 with the 4-wide tree's leaf codes."""
    nb4 = bounds.reshape(-1, 6, 4)
    counts = (child != 0).sum(axis=1)
    out_b, out_c = [], []
    queue = [0]
    ids = {0: 0}
    head = 0
    while head < len(queue):
        n = queue[head]
        head += 1
        lanes = [(nb4[n, :, k].copy(), int(child[n, k])) for k in range(4) if child[n, k] != 0]
        while True:
            pick, area = -1, -1.0
            for i, (box, code) in enumerate(lanes):
                if code > 0 and len(lanes) - 1 + counts[code] <= 8:
                    e = box[3:] - box[:3]
                    a = e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
                    if a > area:
                        pick, area = i, a
            if pick < 0:
                break
            code = lanes.pop(pick)[1]
            lanes[pick:pick] = [(nb4[code, :, k].copy(), int(child[code, k])) for k in range(4) if child[code, k] != 0]
        b = np.full((6, 8), np.inf, np.float32)
        c = np.zeros(8, np.int32)
        for k, (box, code) in enumerate(lanes):
            b[:, k] = box
            if code > 0:
                ids[code] = len(queue)
                queue.append(code)
                code = ids[code]
            c[k] = code
        out_b.append(b)
        out_c.append(c)
    return np.ascontiguousarray(np.array(out_b, np.float32)), np.ascontiguousarray(np.array(out_c, np.int32))


@intrinsic
def entry8_f32(typingctx, bounds, near_x, far_x, near_y, far_y, near_z, far_z, on, of, inv, t_lo, t_hi):
    """The float32 node test of 8 boxes (rows of 8 lanes at the flat offsets): entry4_f32's arithmetic in
    <8 x float>, met with t_lo / t_hi given as float32 already rounded down / up (no widening to float64):
    a tuple of 8 float32, the entry bound where the box is entered, else inf."""
    f32 = types.float32
    sig = types.UniTuple(f32, 8)(bounds, near_x, far_x, near_y, far_y, near_z, far_z, on, of, inv, t_lo, t_hi)

    def codegen(context, builder, signature, args):
        arr, nx, fx, ny, fy, nz, fz, onear, ofar, inverse, lo, hi = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        tn, tf = _slabs32(builder, data, (nx, fx, ny, fy, nz, fz), onear, ofar, inverse, 8)
        tn, tf = _margins32(builder, tn, tf, 8)
        lov, hiv = _splat32(builder, lo, 8), _splat32(builder, hi, 8)
        tn = builder.select(builder.fcmp_ordered(">", tn, lov), tn, lov)
        tf = builder.select(builder.fcmp_ordered("<", tf, hiv), tf, hiv)
        inf = _splat32(builder, ir.Constant(ir.FloatType(), float("inf")), 8)
        dist = builder.select(builder.fcmp_ordered("<=", tn, tf), tn, inf)
        lanes = [builder.extract_element(dist, ir.Constant(ir.IntType(32), k)) for k in range(8)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return sig, codegen


@intrinsic
def row8(typingctx, array, row):
    """The 8 int32 of row `row` (uint64) of a C-contiguous (N, 8) int32 array as one 32-byte load."""
    sig = types.UniTuple(types.int32, 8)(array, row)

    def codegen(context, builder, signature, args):
        arr, r = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        vec_t = ir.VectorType(ir.IntType(32), 8)
        ptr = builder.gep(data, [builder.mul(r, ir.Constant(ir.IntType(64), 8))])
        vec = builder.load(builder.bitcast(ptr, vec_t.as_pointer()), align=4)
        lanes = [builder.extract_element(vec, ir.Constant(ir.IntType(32), k)) for k in range(8)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return sig, codegen


@nb.njit(inline="always", **_JIT)
def _round_up32(t):
    """A float32 at least t + |t| 2^-24 (above t widened by FAR_WIDEN as well); +inf stays."""
    return np.float32(t + (abs(t) * 2.0 ** -21 + 2.0 ** -140))


@nb.njit(inline="always", **_JIT)
def _round_down32(t):
    return np.float32(t - (abs(t) * 2.0 ** -21 + 2.0 ** -140))


@nb.njit(inline="always", **_JIT)
def _min_lane(da, ka, la, db, kb, lb):
    """The nearer of two (distance, code, lane) triples, by selects."""
    c = db < da
    return (db if c else da), (kb if c else ka), (lb if c else la)


@nb.njit(inline="always", **_JIT)
def _push8(stack_node, stack_t, sp, code, d, lane, nearest):
    u = sp + _U1
    stack_node[u] = code
    stack_t[u] = d
    return sp + np.uint64(d < np.inf) * np.uint64(lane != nearest)


def make_walk8(prefetch_lines=3):
    """The closest-hit walk over the collapsed 8-wide tree: float32 node test of 8 lanes (entry8_f32), nearest child
    by a tree of selects, the other entered ones pushed branch-free in lane order and the two topmost exchanged
    (as push_nearest_first), all 8 children prefetched (prefetch_lines lines of boxes each, its code row and a
    leaf's first triangles)."""

    @nb.njit(inline="always", **_JIT)
    def prefetch_child(bounds, leaf_tri, child, code):
        node = np.uint64(max(code, 0))
        base = node * _UNODE8
        prefetch(bounds, base)
        if prefetch_lines > 1:
            prefetch(bounds, base + _U16)
        if prefetch_lines > 2:
            prefetch(bounds, base + np.uint64(32))
        prefetch(child, node * np.uint64(8))
        prefetch_pair(leaf_tri, np.uint64((-min(code, -1) - 1) >> 3) * _U9)

    @nb.njit(**_JIT, _nrt=False)
    def walk8(bounds, child, root, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, stack_t):
        best, kind, prim, bu, bv = t_max, MISS, -1, 0.0, 0.0
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        on, of, inv = ray_setup_f32(ox, oy, oz, dx, dy, dz, idx, idy, idz)
        rx, ry, rz = np.uint64(nrx * 2), np.uint64(nry * 2), np.uint64(nrz * 2)  # rows of 8 lanes
        lo32 = _round_down32(t_min)
        hi32 = _round_up32(best)
        sp = _U0
        node = root
        while True:
            if node >= 0:
                c0, c1, c2, c3, c4, c5, c6, c7 = row8(child, np.uint64(node))
                prefetch_child(bounds, leaf_tri, child, c0)
                prefetch_child(bounds, leaf_tri, child, c1)
                prefetch_child(bounds, leaf_tri, child, c2)
                prefetch_child(bounds, leaf_tri, child, c3)
                prefetch_child(bounds, leaf_tri, child, c4)
                prefetch_child(bounds, leaf_tri, child, c5)
                prefetch_child(bounds, leaf_tri, child, c6)
                prefetch_child(bounds, leaf_tri, child, c7)
                base = np.uint64(node) * _UNODE8
                d0, d1, d2, d3, d4, d5, d6, d7 = entry8_f32(bounds, base + rx, base + (_UX8 - rx), base + ry,
                                                            base + (_UY8 - ry), base + rz, base + (_UZ8 - rz),
                                                            on, of, inv, lo32, hi32)
                m01, k01, l01 = _min_lane(d0, c0, 0, d1, c1, 1)
                m23, k23, l23 = _min_lane(d2, c2, 2, d3, c3, 3)
                m45, k45, l45 = _min_lane(d4, c4, 4, d5, c5, 5)
                m67, k67, l67 = _min_lane(d6, c6, 6, d7, c7, 7)
                ma, ka, la = _min_lane(m01, k01, l01, m23, k23, l23)
                mb, kb, lb = _min_lane(m45, k45, l45, m67, k67, l67)
                m, code, nearest = _min_lane(ma, ka, la, mb, kb, lb)
                if m < np.inf:
                    start = sp
                    sp = _push8(stack_node, stack_t, sp, c7, d7, 7, nearest)
                    sp = _push8(stack_node, stack_t, sp, c6, d6, 6, nearest)
                    sp = _push8(stack_node, stack_t, sp, c5, d5, 5, nearest)
                    sp = _push8(stack_node, stack_t, sp, c4, d4, 4, nearest)
                    sp = _push8(stack_node, stack_t, sp, c3, d3, 3, nearest)
                    sp = _push8(stack_node, stack_t, sp, c2, d2, 2, nearest)
                    sp = _push8(stack_node, stack_t, sp, c1, d1, 1, nearest)
                    sp = _push8(stack_node, stack_t, sp, c0, d0, 0, nearest)
                    top = sp
                    below = top - np.uint64(sp - start >= _U2)
                    t_top, t_below = stack_t[top], stack_t[below]
                    n_top, n_below = stack_node[top], stack_node[below]
                    swap = t_top > t_below
                    stack_t[top], stack_t[below] = min(t_top, t_below), max(t_top, t_below)
                    stack_node[top] = n_below if swap else n_top
                    stack_node[below] = n_top if swap else n_below
                    node = code
                    continue
            else:
                first, end = leaf_range(node)
                for j in range(first, end):
                    t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, best)
                    if t < best:
                        best, kind, prim, bu, bv = t, TRIANGLE, leaf_prim[j], u, w
                        hi32 = _round_up32(best)
            node = 0
            while sp > _U0:
                if stack_t[sp] <= best:
                    node = stack_node[sp]
                    sp -= _U1
                    break
                sp -= _U1
            if node == 0:
                break
        if kind == MISS:
            best = np.inf
        return best, kind, prim, bu, bv

    return walk8


def make_run8(walk):
    """run_a's loop over an 8-wide walk (float32 stack distances, a deeper stack: up to 7 pushes a level)."""

    @nb.njit(**_JIT)
    def run(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out):
        stack_node = np.empty(3 * stack_size, np.int32)
        stack_t = np.empty(3 * stack_size, np.float32)
        for i in range(o.shape[0]):
            t, kind, prim, u, v = walk(bounds, child, np.int32(0), leaf_prim, leaf_tri, o[i, 0], o[i, 1], o[i, 2],
                                       d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
            out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v

    return run
