"""Variants of the one-ray closest-hit walk (kernels/bvh/single.blas_closest), paired against it in one process.

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/walk_variants.py [--mesh bun_zipper_subdiv2.ply]
        [--rays 262144] [--pairs 7] [--only NAME]

Every variant is the same walk built by `make_walk` with some of its pieces swapped (flags, folded at compile time):
  * nodiv: the prefetch of a leaf child's second line at a constant 64 bytes (the walk computes 64 // itemsize, an
    integer division per child and visit, in the code Numba emits);
  * csel: the nearest child's code chosen by selects from the row of 4 codes (loaded once, as one 16-byte vector,
    for the prefetch) rather than loaded again at child[node, nearest] after the test;
  * usp: unsigned stack indices (no negative-index wraparound code on each push);
  * fma: the slab test as fma(plane, 1/d, -(o/d)) with o/d rounded outwards per ray (simd.entry4_fma);
  * loops: "while inner / while leaf": the inner-node visits in a loop of their own;
  * f32: the node test in float32 lanes with a conservative margin (walk_f32.entry4_f32, the proof there).
Besides those (session 17): "8-wide f32", the walk over an 8-wide tree collapsed from the 4-wide one with the node
test in <8 x float> lanes (walk_f32.make_walk8; all 8 children prefetched, 3 or 1 lines of boxes each); and the
any-hit rows: blas_any against a triangles-only copy ("any branch-free"), against next_leaf's pushes ("any copy"),
and with a sphere in the sphere arrays ("general leaf loop", the same kernel). Differences are reported as rays
differing in t (escapes counted) or only in (prim, u, v) at the same t (ties).
Per variant and mesh: 262,144 incoherent rays (benchmarks/raycases.random_rays), the walk over the batch timed with
time.thread_time for A (the walk in single.py) and B alternately, --pairs pairs, the median B / A ratio (below 1:
B is faster) and the results checked equal to the bit (t, kind, prim, u, v). Mesh: the Stanford bunny (Stanford
Computer Graphics Laboratory) from ../shared/meshes.
"""

from __future__ import annotations

import argparse
import time

import numba as nb
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from raycases import SHARED, load_mesh, random_rays
from walk_f32 import collapse8, entry4_f32, make_run8, make_walk8, ray_setup_f32

from durer.accel.bvh import build_tree
from durer.kernels.bvh.layout import FAR_WIDEN, HI_X, HI_Y, HI_Z, LO_X, LO_Y, LO_Z, NODE_FLOATS, leaf_range
from durer.kernels.bvh.simd import _entered, _F64x4, _row, _splat, entry4, prefetch
from durer.kernels.bvh.single import blas_any, blas_closest, ray_setup
from durer.kernels.common import MISS, TRIANGLE
from durer.kernels.intersect import watertight_triangle

_UX, _UY, _UZ = np.uint64(LO_X + HI_X), np.uint64(LO_Y + HI_Y), np.uint64(LO_Z + HI_Z)
_UNODE = np.uint64(NODE_FLOATS)
_U0, _U1, _U2, _U4, _U9, _U16 = (np.uint64(k) for k in (0, 1, 2, 4, 9, 16))
ANY_VARIANTS = {"any copy": dict(), "any branch-free": dict(branchfree=True),
                "any general leaf loop (spheres present)": None}
_ULP4, _TINY = 2.0 ** -51, 2.0 ** -1022
_JIT = dict(error_model="numpy", nogil=True)  # as kernels/common.JIT, without the disk cache
VARIANTS = {
    "copy": {},
    "nodiv": dict(nodiv=True),
    "nodiv+csel": dict(nodiv=True, csel=True),
    "nodiv+csel+usp": dict(nodiv=True, csel=True, usp=True),
    "nodiv+csel+usp+fma": dict(nodiv=True, csel=True, usp=True, fma=True),
    "nodiv+csel+usp+loops": dict(nodiv=True, csel=True, usp=True, loops=True),
    "nodiv+usp": dict(nodiv=True, usp=True),
    "nodiv+csel+usp+fma+loops": dict(nodiv=True, csel=True, usp=True, fma=True, loops=True),
    "fma": dict(fma=True),
    "f32": dict(nodiv=True, csel=True, usp=True, f32=True),
    "kept (control)": dict(nodiv=True, csel=True, usp=True),
}
WIDE_VARIANTS = {"8-wide f32, 3 lines": 3, "8-wide f32, 1 line": 1}


@intrinsic
def prefetch_pair(typingctx, array, offset):
    """Prefetch the line of element `offset` (uint64, flat) of `array` and the line 64 bytes further on."""
    sig = types.void(array, offset)

    def codegen(context, builder, signature, args):
        arr, off = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        ptr = builder.bitcast(builder.gep(data, [off]), ir.IntType(8).as_pointer())
        i32 = ir.IntType(32)
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32]),
                                            "llvm.prefetch.p0i8")
        for p in (ptr, builder.gep(ptr, [ir.Constant(ir.IntType(64), 64)])):
            builder.call(fn, [p, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def row4(typingctx, array, row):
    """The 4 int32 of row `row` (uint64) of a C-contiguous (N, 4) int32 array, as one 16-byte vector load."""
    sig = types.UniTuple(types.int32, 4)(array, row)

    def codegen(context, builder, signature, args):
        arr, r = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        off = builder.mul(r, ir.Constant(ir.IntType(64), 4))
        vec_t = ir.VectorType(ir.IntType(32), 4)
        vec = builder.load(builder.bitcast(builder.gep(data, [off]), vec_t.as_pointer()), align=4)
        lanes = [builder.extract_element(vec, ir.Constant(ir.IntType(32), k)) for k in range(4)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return sig, codegen


@intrinsic
def entry4_fma(typingctx, bounds, near_x, far_x, near_y, far_y, near_z, far_z, wn, wf, inv, t_lo, t_hi, widen):
    """simd.entry4 with each plane's distance as one fused multiply-add: fma(near, inv, -wn) and
    fma(far, inv, -wf), wn = o * inv rounded up, wf rounded down (per ray)."""
    f64 = types.float64
    sig = types.UniTuple(f64, 4)(bounds, near_x, far_x, near_y, far_y, near_z, far_z, wn, wf, inv, t_lo, t_hi, widen)

    def codegen(context, builder, signature, args):
        arr, nx, fx, ny, fy, nz, fz, wnear, wfar, inverse, lo, hi, wid = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_F64x4, [_F64x4] * 3), "llvm.fma.v4f64")
        tn = _splat(builder, lo)
        tf = _splat(builder, hi)
        for axis, (near, far) in enumerate(((nx, fx), (ny, fy), (nz, fz))):
            iv = _splat(builder, builder.extract_value(inverse, axis))
            wnv = _splat(builder, builder.fneg(builder.extract_value(wnear, axis)))
            wfv = _splat(builder, builder.fneg(builder.extract_value(wfar, axis)))
            a = builder.call(fma, [_row(builder, data, near), iv, wnv])
            b = builder.call(fma, [_row(builder, data, far), iv, wfv])
            tn = builder.select(builder.fcmp_ordered(">", a, tn), a, tn)
            tf = builder.select(builder.fcmp_ordered("<", b, tf), b, tf)
        return _entered(context, builder, signature, tn, tf, wid)

    return sig, codegen


def make_walk(nodiv=False, csel=False, usp=False, fma=False, loops=False, f32=False):
    """The closest-hit walk of blas_closest (triangles only) with the named pieces swapped (each flag picks a
    helper here, in Python, so Numba types only the chosen code)."""

    @nb.njit(inline="always", **_JIT)
    def prefetch_div(leaf_tri, tri):
        prefetch(leaf_tri, tri)
        prefetch(leaf_tri, tri + np.uint64(64 // leaf_tri.itemsize))

    prefetch_leaf = prefetch_pair if nodiv else prefetch_div

    @nb.njit(inline="always", **_JIT)
    def prefetch_child(bounds, leaf_tri, child, code):
        node = np.uint64(max(code, 0))
        base = node * _UNODE
        prefetch(bounds, base)
        prefetch(bounds, base + _U16)
        prefetch(child, node * _U4)
        prefetch_leaf(leaf_tri, np.uint64((-min(code, -1) - 1) >> 3) * _U9)

    @nb.njit(inline="always", **_JIT)
    def dists_sub(bounds, base, rx, ry, rz, ox, oy, oz, idx, idy, idz, wn, wf, t_lo, t_hi):
        return entry4(bounds, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry), base + rz, base + (_UZ - rz),
                      (ox, oy, oz), (idx, idy, idz), t_lo, t_hi, FAR_WIDEN)

    @nb.njit(inline="always", **_JIT)
    def dists_fma(bounds, base, rx, ry, rz, ox, oy, oz, idx, idy, idz, wn, wf, t_lo, t_hi):
        return entry4_fma(bounds, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry), base + rz,
                          base + (_UZ - rz), wn, wf, (idx, idy, idz), t_lo, t_hi, FAR_WIDEN)

    @nb.njit(inline="always", **_JIT)
    def dists_f32(bounds, base, rx, ry, rz, ox, oy, oz, idx, idy, idz, wn, wf, t_lo, t_hi):
        return entry4_f32(bounds, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry), base + rz,
                          base + (_UZ - rz), wn, wf, (idx, idy, idz), t_lo, t_hi, FAR_WIDEN)

    dists = dists_f32 if f32 else (dists_fma if fma else dists_sub)

    @nb.njit(inline="always", **_JIT)
    def codes_plain(child, node):
        return child[node, 0], child[node, 1], child[node, 2], child[node, 3]

    @nb.njit(inline="always", **_JIT)
    def codes_vec(child, node):
        return row4(child, np.uint64(node))

    codes = codes_vec if csel else codes_plain

    @nb.njit(inline="always", **_JIT)
    def next_plain(child, node, nearest, code):
        return child[node, nearest]

    @nb.njit(inline="always", **_JIT)
    def next_sel(child, node, nearest, code):
        return code

    next_code = next_sel if csel else next_plain

    @nb.njit(inline="always", **_JIT)
    def push_signed(stack_node, stack_t, sp, c0, c1, c2, c3, d0, d1, d2, d3, nearest):
        """Pushes in lane order 3..0 and the exchange, signed stack pointer (index -1: the array's last entry)."""
        start = sp
        stack_node[sp] = c3
        stack_t[sp] = d3
        sp = sp + np.int64(d3 < np.inf) * np.int64(nearest != 3)
        stack_node[sp] = c2
        stack_t[sp] = d2
        sp = sp + np.int64(d2 < np.inf) * np.int64(nearest != 2)
        stack_node[sp] = c1
        stack_t[sp] = d1
        sp = sp + np.int64(d1 < np.inf) * np.int64(nearest != 1)
        stack_node[sp] = c0
        stack_t[sp] = d0
        sp = sp + np.int64(d0 < np.inf) * np.int64(nearest != 0)
        top = sp - 1
        below = top - np.int64(sp - start >= 2)
        t_top, t_below = stack_t[top], stack_t[below]
        n_top, n_below = stack_node[top], stack_node[below]
        swap = t_top > t_below
        stack_t[top], stack_t[below] = min(t_top, t_below), max(t_top, t_below)
        stack_node[top] = n_below if swap else n_top
        stack_node[below] = n_top if swap else n_below
        return sp

    @nb.njit(inline="always", **_JIT)
    def push_unsigned(stack_node, stack_t, sp, c0, c1, c2, c3, d0, d1, d2, d3, nearest):
        """The same with sp uint64 and entry k at index k + 1 (index 0: the spare the exchange reads when the
        stack is empty)."""
        start = sp
        stack_node[sp + _U1] = c3
        stack_t[sp + _U1] = d3
        sp = sp + np.uint64(d3 < np.inf) * np.uint64(nearest != 3)
        stack_node[sp + _U1] = c2
        stack_t[sp + _U1] = d2
        sp = sp + np.uint64(d2 < np.inf) * np.uint64(nearest != 2)
        stack_node[sp + _U1] = c1
        stack_t[sp + _U1] = d1
        sp = sp + np.uint64(d1 < np.inf) * np.uint64(nearest != 1)
        stack_node[sp + _U1] = c0
        stack_t[sp + _U1] = d0
        sp = sp + np.uint64(d0 < np.inf) * np.uint64(nearest != 0)
        top = sp
        below = top - np.uint64(sp - start >= _U2)
        t_top, t_below = stack_t[top], stack_t[below]
        n_top, n_below = stack_node[top], stack_node[below]
        swap = t_top > t_below
        stack_t[top], stack_t[below] = min(t_top, t_below), max(t_top, t_below)
        stack_node[top] = n_below if swap else n_top
        stack_node[below] = n_top if swap else n_below
        return sp

    push = push_unsigned if usp else push_signed

    @nb.njit(inline="always", **_JIT)
    def pop_signed(stack_node, stack_t, sp, best):
        while sp > 0:
            sp -= 1
            if stack_t[sp] <= best:
                return stack_node[sp], sp
        return np.int32(0), sp

    @nb.njit(inline="always", **_JIT)
    def pop_unsigned(stack_node, stack_t, sp, best):
        while sp > _U0:
            if stack_t[sp] <= best:
                return stack_node[sp], sp - _U1
            sp -= _U1
        return np.int32(0), sp

    pop = pop_unsigned if usp else pop_signed
    sp0 = np.uint64(0) if usp else np.int64(0)

    @nb.njit(inline="always", **_JIT)
    def visit(bounds, child, leaf_tri, node, stack_node, stack_t, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz,
              wn, wf, t_lo, best):
        """One inner node: prefetch, test, push; (next code or 0, sp)."""
        c0, c1, c2, c3 = codes(child, node)
        prefetch_child(bounds, leaf_tri, child, c0)
        prefetch_child(bounds, leaf_tri, child, c1)
        prefetch_child(bounds, leaf_tri, child, c2)
        prefetch_child(bounds, leaf_tri, child, c3)
        base = np.uint64(node) * _UNODE
        d0, d1, d2, d3 = dists(bounds, base, np.uint64(nrx), np.uint64(nry), np.uint64(nrz), ox, oy, oz, idx, idy, idz,
                               wn, wf, t_lo, best)
        a = d1 < d0
        m01 = d1 if a else d0
        l01 = 1 if a else 0
        k01 = c1 if a else c0
        b = d3 < d2
        m23 = d3 if b else d2
        l23 = 3 if b else 2
        k23 = c3 if b else c2
        c = m23 < m01
        nearest = l23 if c else l01
        code = k23 if c else k01
        if (m23 if c else m01) == np.inf:
            return np.int32(0), sp
        sp = push(stack_node, stack_t, sp, c0, c1, c2, c3, d0, d1, d2, d3, nearest)
        return next_code(child, node, nearest, code), sp

    @nb.njit(inline="always", **_JIT)
    def leaf(leaf_prim, leaf_tri, node, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, best, kind, prim, bu, bv):
        first, end = leaf_range(node)
        for j in range(first, end):
            t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, best)
            if t < best:
                best, kind, prim, bu, bv = t, TRIANGLE, leaf_prim[j], u, w
        return best, kind, prim, bu, bv

    @nb.njit(inline="always", **_JIT)
    def setup_fma(ox, oy, oz, dx, dy, dz):
        """ray_setup, and o / d rounded up (wn) and down (wf) per axis for entry4_fma: w = fl(o * inv) is within
        u |w| / (1 - u) of the exact product (u = 2^-53), so w +- (|w| 2^-51 + 2^-1022) rounded to nearest is
        still beyond it (the 2^-1022 covers products that underflow)."""
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        wx, wy, wz = ox * idx, oy * idy, oz * idz
        ex, ey, ez = abs(wx) * _ULP4 + _TINY, abs(wy) * _ULP4 + _TINY, abs(wz) * _ULP4 + _TINY
        wn = (wx + ex, wy + ey, wz + ez)
        wf = (wx - ex, wy - ey, wz - ez)
        return idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz, wn, wf

    @nb.njit(inline="always", **_JIT)
    def setup_sub(ox, oy, oz, dx, dy, dz):
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        return idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)

    @nb.njit(inline="always", **_JIT)
    def setup_f32(ox, oy, oz, dx, dy, dz):
        """ray_setup, and the float32 origins and 1/d of entry4_f32 (passed on as wn, wf, idx..idz)."""
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        on, of, inv = ray_setup_f32(ox, oy, oz, dx, dy, dz, idx, idy, idz)
        return inv[0], inv[1], inv[2], nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz, on, of

    setup = setup_f32 if f32 else (setup_fma if fma else setup_sub)

    @nb.njit(**_JIT, _nrt=False)
    def walk_branch(bounds, child, root, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node,
                    stack_t):
        """blas_closest's loop: one `if inner ... else leaf` per step."""
        best, kind, prim, bu, bv = t_max, MISS, -1, 0.0, 0.0
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz, wn, wf = setup(ox, oy, oz, dx, dy, dz)
        sp = sp0
        node = root
        while True:
            if node >= 0:
                nxt, sp = visit(bounds, child, leaf_tri, node, stack_node, stack_t, sp, nrx, nry, nrz,
                                ox, oy, oz, idx, idy, idz, wn, wf, t_min, best)
                if nxt != 0:
                    node = nxt
                    continue
            else:
                best, kind, prim, bu, bv = leaf(leaf_prim, leaf_tri, node, okx, oky, okz, kx, ky, kz, sx, sy, sz,
                                                t_min, best, kind, prim, bu, bv)
            node, sp = pop(stack_node, stack_t, sp, best)
            if node == 0:
                break
        if kind == MISS:
            best = np.inf
        return best, kind, prim, bu, bv

    @nb.njit(**_JIT, _nrt=False)
    def walk_loops(bounds, child, root, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node,
                   stack_t):
        """The same with the inner visits in a loop of their own ("while inner / while leaf"); node 0 (the root)
        is visited before the loop."""
        best, kind, prim, bu, bv = t_max, MISS, -1, 0.0, 0.0
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz, wn, wf = setup(ox, oy, oz, dx, dy, dz)
        sp = sp0
        node = root
        if node >= 0:
            node, sp = visit(bounds, child, leaf_tri, node, stack_node, stack_t, sp, nrx, nry, nrz,
                             ox, oy, oz, idx, idy, idz, wn, wf, t_min, best)
        else:
            best, kind, prim, bu, bv = leaf(leaf_prim, leaf_tri, node, okx, oky, okz, kx, ky, kz, sx, sy, sz,
                                            t_min, best, kind, prim, bu, bv)
            node = 0
        while True:
            while node > 0:
                node, sp = visit(bounds, child, leaf_tri, node, stack_node, stack_t, sp, nrx, nry, nrz,
                                 ox, oy, oz, idx, idy, idz, wn, wf, t_min, best)
            if node < 0:
                best, kind, prim, bu, bv = leaf(leaf_prim, leaf_tri, node, okx, oky, okz, kx, ky, kz, sx, sy, sz,
                                                t_min, best, kind, prim, bu, bv)
            node, sp = pop(stack_node, stack_t, sp, best)
            if node == 0:
                break
        if kind == MISS:
            best = np.inf
        return best, kind, prim, bu, bv

    return walk_loops if loops else walk_branch


@nb.njit(**_JIT)
def run_a(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out):
    """single.blas_closest over the batch, as trace.closest_hit_bvh calls it; out (n, 5) = t, kind, prim, u, v."""
    stack_node = np.empty(stack_size, np.int32)
    stack_t = np.empty(stack_size)
    e3, e1, e34 = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 4))
    for i in range(o.shape[0]):
        t, kind, prim, u, v = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, e3, e1, e34, o[i, 0], o[i, 1],
                                           o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v


def make_run(walk):
    """run_a's loop over a variant walk."""

    @nb.njit(**_JIT)
    def run(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out):
        stack_node = np.empty(stack_size + 1, np.int32)
        stack_t = np.empty(stack_size + 1)
        for i in range(o.shape[0]):
            t, kind, prim, u, v = walk(bounds, child, np.int32(0), leaf_prim, leaf_tri, o[i, 0], o[i, 1], o[i, 2],
                                       d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
            out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v

    return run


def make_any(branchfree=False):
    """blas_any (triangles only) with next_leaf's pushes branch-free on an unsigned stack (as blas_all's)."""

    @nb.njit(inline="always", **_JIT)
    def prefetch_child(bounds, child, code):
        node = np.uint64(max(code, 0))
        base = node * _UNODE
        prefetch(bounds, base)
        prefetch(bounds, base + _U16)
        prefetch(child, node * _U4)

    @nb.njit(**_JIT, _nrt=False)
    def walk_any(bounds, child, root, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node):
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        rx, ry, rz = np.uint64(nrx), np.uint64(nry), np.uint64(nrz)
        stack_node[0] = root
        sp = _U1
        while sp > _U0:
            sp -= _U1
            node = stack_node[sp]
            if node >= 0:
                c0, c1, c2, c3 = row4(child, np.uint64(node))
                prefetch_child(bounds, child, c0)
                prefetch_child(bounds, child, c1)
                prefetch_child(bounds, child, c2)
                prefetch_child(bounds, child, c3)
                base = np.uint64(node) * _UNODE
                d0, d1, d2, d3 = entry4(bounds, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry),
                                        base + rz, base + (_UZ - rz), (ox, oy, oz), (idx, idy, idz), t_min, t_max,
                                        FAR_WIDEN)
                if branchfree:
                    stack_node[sp] = c0
                    sp += np.uint64(d0 < np.inf)
                    stack_node[sp] = c1
                    sp += np.uint64(d1 < np.inf)
                    stack_node[sp] = c2
                    sp += np.uint64(d2 < np.inf)
                    stack_node[sp] = c3
                    sp += np.uint64(d3 < np.inf)
                else:
                    for lane, d in enumerate((d0, d1, d2, d3)):
                        if d < np.inf:
                            stack_node[sp] = (c0, c1, c2, c3)[lane]
                            sp += _U1
                continue
            first, end = leaf_range(node)
            for j in range(first, end):
                if watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min,
                                       t_max)[0] < np.inf:
                    return True
        return False

    return walk_any


@nb.njit
def run_any_a(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, t_max, out):
    """single.blas_any over the batch (t_max per ray)."""
    stack_node = np.empty(stack_size, np.int32)
    e3, e1, e34 = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 4))
    for i in range(o.shape[0]):
        out[i] = blas_any(bounds, child, 0, leaf_prim, leaf_tri, e3, e1, e34, o[i, 0], o[i, 1], o[i, 2], d[i, 0],
                          d[i, 1], d[i, 2], 0.0, t_max[i], stack_node)


@nb.njit
def run_any_general(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, t_max, out):
    """single.blas_any with one sphere in the sphere arrays that no leaf names: the general leaf loop (each slot's
    kind checked, leaf_prim read), as every tree took before session 17."""
    stack_node = np.empty(stack_size, np.int32)
    e3, e1, e34 = np.zeros((1, 3)), np.ones(1), np.zeros((1, 3, 4))
    for i in range(o.shape[0]):
        out[i] = blas_any(bounds, child, 0, leaf_prim, leaf_tri, e3, e1, e34, o[i, 0], o[i, 1], o[i, 2], d[i, 0],
                          d[i, 1], d[i, 2], 0.0, t_max[i], stack_node)


def make_run_any(walk):
    """run_any_a's loop over a variant walk."""

    @nb.njit
    def run(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, t_max, out):
        stack_node = np.empty(stack_size, np.int32)
        for i in range(o.shape[0]):
            out[i] = walk(bounds, child, np.int32(0), leaf_prim, leaf_tri, o[i, 0], o[i, 1], o[i, 2], d[i, 0],
                          d[i, 1], d[i, 2], 0.0, t_max[i], stack_node)

    return run


def diff_report(out: np.ndarray, ref: np.ndarray) -> str:
    """"yes" when (t, kind, prim, u, v) agree to the bit, else how many rays differ: in t (a real difference:
    an escape or a wrong hit), in t's class (hit / miss), or only in (prim, u, v) at the same t (a tie: the ray
    meets two triangles at one t, through a shared edge or vertex, and the visit order picked the other)."""
    bits, rbits = out.view(np.int64), ref.view(np.int64)
    rows = np.any(bits != rbits, axis=1)
    if not rows.any():
        return "yes"
    t_differs = bits[:, 0] != rbits[:, 0]
    escapes = int(np.sum(np.isfinite(ref[:, 0]) & ~np.isfinite(out[:, 0])))
    return (f"no: {int(rows.sum())} rays differ, {int(t_differs.sum())} in t ({escapes} escapes), "
            f"{int((rows & ~t_differs).sum())} ties (same t, other prim)")



def timed(fn) -> float:
    start = time.thread_time()
    fn()
    return time.thread_time() - start


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh", default="bun_zipper.ply")
    ap.add_argument("--rays", type=int, default=262_144)
    ap.add_argument("--pairs", type=int, default=7)
    ap.add_argument("--only", default="", help="the variants whose name contains this")
    a = ap.parse_args()
    mesh = load_mesh(SHARED / "meshes", a.mesh)
    o, d = random_rays(mesh, a.rays)
    tree = build_tree(np.asarray(mesh.triangles), np.zeros((0, 3)), np.zeros((0, 3)))
    args = (tree.bounds.reshape(-1), tree.child, tree.leaf_prim, tree.leaf_tri.reshape(-1), o, d, tree.stack_size)
    print(f"{a.mesh}: {len(tree.child)} nodes, leaves {tree.leaf_tri.dtype}, {a.rays} rays", flush=True)
    ref = np.empty((len(o), 5))
    run_a(*args, ref)
    for name, flags in VARIANTS.items():
        if a.only not in name:
            continue
        run_b = make_run(make_walk(**flags))
        out = np.empty_like(ref)
        run_b(*args, out)
        same = diff_report(out, ref)
        ratios, ta, tb = [], [], []
        for k in range(a.pairs):
            first, second = (run_a, run_b) if k % 2 == 0 else (run_b, run_a)
            t1 = timed(lambda f=first: f(*args, ref))
            t2 = timed(lambda f=second, r=out: f(*args, r))
            x, y = (t1, t2) if k % 2 == 0 else (t2, t1)
            ta.append(x)
            tb.append(y)
            ratios.append(y / x)
        print(f"{name:28s} B/A median {np.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f}) "
              f"A {np.median(ta) / len(o) * 1e9:.0f} ns/ray B {np.median(tb) / len(o) * 1e9:.0f} ns/ray "
              f"same to the bit: {same}", flush=True)

    if any(a.only in name for name in WIDE_VARIANTS):
        b8, c8 = collapse8(tree.bounds, tree.child)
        print(f"collapsed to 8-wide: {len(c8)} nodes, {np.mean(c8 != 0):.2f} lanes full", flush=True)
        args8 = (b8.reshape(-1), c8, *args[2:])
    for name, lines in WIDE_VARIANTS.items():
        if a.only not in name:
            continue
        run_b = make_run8(make_walk8(lines))
        out = np.empty_like(ref)
        run_b(*args8, out)
        same = diff_report(out, ref)
        ratios = []
        for k in range(a.pairs):
            if k % 2 == 0:
                ta = timed(lambda: run_a(*args, ref))
                tb = timed(lambda r=out, f=run_b: f(*args8, r))
            else:
                tb = timed(lambda r=out, f=run_b: f(*args8, r))
                ta = timed(lambda: run_a(*args, ref))
            ratios.append(tb / ta)
        print(f"{name:28s} B/A median {np.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f}) "
              f"same to the bit: {same}", flush=True)

    shadow = np.where(np.isfinite(ref[:, 0]), ref[:, 0] * 0.999, np.inf)
    for name, flags in ANY_VARIANTS.items():
        if a.only not in name:
            continue
        run_b = run_any_general if flags is None else make_run_any(make_any(**flags))
        for label, t_max in (("t_max = inf", np.full(len(o), np.inf)), ("unoccluded shadow rays", shadow)):
            hit_a, hit_b = np.empty(len(o), np.bool_), np.empty(len(o), np.bool_)
            run_any_a(*args, t_max, hit_a)
            run_b(*args, t_max, hit_b)
            ratios = []
            for k in range(a.pairs):
                first, second = (run_any_a, run_b) if k % 2 == 0 else (run_b, run_any_a)
                t1 = timed(lambda f=first, r=hit_a, tm=t_max: f(*args, tm, r))
                t2 = timed(lambda f=second, r=hit_b, tm=t_max: f(*args, tm, r))
                ratios.append(t2 / t1 if k % 2 == 0 else t1 / t2)
            print(f"{name} ({label}): B/A median {np.median(ratios):.3f} (range {min(ratios):.3f}-{max(ratios):.3f})"
                  f" same: {np.array_equal(hit_a, hit_b)}", flush=True)


if __name__ == "__main__":
    main()
