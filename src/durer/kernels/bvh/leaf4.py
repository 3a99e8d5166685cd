"""A leaf's triangles, up to 4 at a time, through the watertight test in one vector pass (Numba intrinsic).

The count walk (queued.blas_count) tests 23.6 triangles in 7.8 leaves a ray on the bunny's incoherent rays (2.8
triangles a leaf). Here the triangles of one leaf are gathered from the flat leaf_tri array (9 coordinates a slot,
float32 or float64; no copy of the leaves) into <4 x double> rows, one lane a triangle, and put through
intersect.watertight_triangle's arithmetic at once: every lane does the scalar operations in the same order
(IEEE subtraction, multiplication, division; no fused multiply-add), so a lane's t, u, v are the scalar test's to
the bit. A lane whose three edge functions have no mixed signs but include an exact 0 (a ray through an edge or a
vertex, or an edge-on triangle) is not decided here: it is flagged, and the caller sends that triangle to the
scalar test, whose tie-break (intersect.edge_tie) stays the only one; a determinant 0 up to its rounding bound
(intersect.edge_on, the same operations in the same order) is a miss, as there. Measured in the count walk on
incoherent rays: 0.89-0.94x its time on the bunny, 0.82x on the 1.1M bunny, the same counts
(benchmarks/walk_leaf4.py, benchmarks/README.md); in the closest walk it did not pay (1.05x: 2.1 leaves a ray,
each culled by the best hit), so single.blas_closest keeps the scalar loop.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from ..common import JIT
from ..intersect import EDGE_ON, watertight_triangle
from .simd import _F64x4, _splat

_I32 = ir.IntType(32)
_I64 = ir.IntType(64)


def _watertight4(context, builder, signature, at, okx, oky, okz, sx, sy, sz, t_min, t_max, n):
    """triangles4's arithmetic on rows at(vertex, axis) (axis 0, 1, 2 = the ray's kx, ky, kz) of 4 float64 lanes."""
    ox, oy, oz = _splat(builder, okx), _splat(builder, oky), _splat(builder, okz)
    vsx, vsy = _splat(builder, sx), _splat(builder, sy)
    az = builder.fsub(at(0, 2), oz)
    bz = builder.fsub(at(1, 2), oz)
    cz = builder.fsub(at(2, 2), oz)
    ax = builder.fsub(builder.fsub(at(0, 0), ox), builder.fmul(vsx, az))
    ay = builder.fsub(builder.fsub(at(0, 1), oy), builder.fmul(vsy, az))
    bx = builder.fsub(builder.fsub(at(1, 0), ox), builder.fmul(vsx, bz))
    by = builder.fsub(builder.fsub(at(1, 1), oy), builder.fmul(vsy, bz))
    cx = builder.fsub(builder.fsub(at(2, 0), ox), builder.fmul(vsx, cz))
    cy = builder.fsub(builder.fsub(at(2, 1), oy), builder.fmul(vsy, cz))
    e0 = builder.fsub(builder.fmul(cx, by), builder.fmul(cy, bx))
    e1 = builder.fsub(builder.fmul(ax, cy), builder.fmul(ay, cx))
    e2 = builder.fsub(builder.fmul(bx, ay), builder.fmul(by, ax))
    zero = _splat(builder, ir.Constant(ir.DoubleType(), 0.0))

    def any3(op):
        return builder.or_(builder.or_(builder.fcmp_ordered(op, e0, zero), builder.fcmp_ordered(op, e1, zero)),
                           builder.fcmp_ordered(op, e2, zero))

    neg, pos, on_edge = any3("<"), any3(">"), any3("==")
    count = builder.insert_element(ir.Constant(ir.VectorType(_I64, 4), ir.Undefined), n, ir.Constant(_I32, 0))
    count = builder.shuffle_vector(count, count, ir.Constant(ir.VectorType(_I32, 4), [0, 0, 0, 0]))
    valid = builder.icmp_signed("<", ir.Constant(ir.VectorType(_I64, 4), [0, 1, 2, 3]), count)
    inside = builder.and_(valid, builder.not_(builder.and_(neg, pos)))  # no mixed signs
    tie = builder.and_(inside, on_edge)
    det = builder.fadd(builder.fadd(e0, e1), e2)
    # intersect.edge_on, the same operations in the same order: det 0 up to its rounding bound is a miss
    fabs = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_F64x4, [_F64x4]), "llvm.fabs.v4f64")

    def mul_add(p, q, r, s_):
        return builder.fadd(builder.fmul(p, q), builder.fmul(r, s_))

    two = _splat(builder, ir.Constant(ir.DoubleType(), 2.0))
    tx = builder.fmul(two, builder.call(fabs, [vsx]))
    ty = builder.fmul(two, builder.call(fabs, [vsy]))
    bnd = []
    for x, y, z in ((ax, ay, az), (bx, by, bz), (cx, cy, cz)):
        fz = builder.call(fabs, [z])
        bnd.append((builder.fadd(builder.call(fabs, [x]), builder.fmul(tx, fz)),
                    builder.fadd(builder.call(fabs, [y]), builder.fmul(ty, fz))))
    (pa, qa), (pb, qb), (pc, qc) = bnd
    total = builder.fadd(builder.fadd(mul_add(pc, qb, pb, qc), mul_add(pa, qc, pc, qa)), mul_add(pb, qa, pa, qb))
    edge_on = builder.fcmp_ordered("<=", builder.call(fabs, [det]),
                                   builder.fmul(_splat(builder, ir.Constant(ir.DoubleType(), EDGE_ON)), total))
    num = builder.fadd(builder.fadd(builder.fmul(e0, az), builder.fmul(e1, bz)), builder.fmul(e2, cz))
    t = builder.fdiv(builder.fmul(_splat(builder, sz), num), det)
    hit = builder.and_(builder.and_(inside, builder.not_(on_edge)), builder.not_(edge_on))
    hit = builder.and_(hit, builder.and_(builder.fcmp_ordered("<", _splat(builder, t_min), t),
                                         builder.fcmp_ordered("<", t, _splat(builder, t_max))))
    inf = _splat(builder, ir.Constant(ir.DoubleType(), float("inf")))
    out = []
    for vec in (builder.select(hit, t, inf), builder.fdiv(e1, det), builder.fdiv(e2, det)):
        out += [builder.extract_element(vec, ir.Constant(_I32, k)) for k in range(4)]
    out.append(builder.zext(builder.bitcast(tie, ir.IntType(4)), _I64))
    return context.make_tuple(builder, signature.return_type, out)


@intrinsic
def triangles4(typingctx, leaf_tri, first, axes, okx, oky, okz, sx, sy, sz, t_min, t_max, n):
    """The watertight test of the n (1..4) triangles at slots first..first+n-1 of the flat leaf_tri (uint64 axes =
    the ray's (kx, ky, kz), the other arguments watertight_triangle's): (t0..t3, u0..u3, v0..v3, tie), t = inf
    where a lane misses or is beyond n (it reads slot first + n - 1 again), u, v meaningful where t < inf, and tie
    the 4-bit mask of the lanes the scalar test must decide (module docstring)."""
    f64 = types.float64
    if not (isinstance(leaf_tri, types.Array) and leaf_tri.dtype in (types.float32, types.float64)):
        return None
    sig = types.Tuple([f64] * 12 + [types.int64])(leaf_tri, first, axes, okx, oky, okz, sx, sy, sz, t_min, t_max, n)

    def codegen(context, builder, signature, args):
        arr, start, ax, *rest = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        ks = [builder.extract_value(ax, k) for k in range(3)]
        last = builder.sub(rest[-1], ir.Constant(_I64, 1))
        slots = []
        for lane in range(4):  # lanes beyond n read the last triangle again: never past the leaf
            k = ir.Constant(_I64, lane)
            slot = builder.add(start, builder.select(builder.icmp_signed("<", k, last), k, last))
            slots.append(builder.mul(slot, ir.Constant(_I64, 9)))
        widen = signature.args[0].dtype == types.float32

        def at(vertex, axis):
            vec = ir.Constant(_F64x4, ir.Undefined)
            for lane in range(4):
                x = builder.load(builder.gep(data, [builder.add(slots[lane],
                                                                builder.add(ir.Constant(_I64, 3 * vertex), ks[axis]))]))
                vec = builder.insert_element(vec, builder.fpext(x, ir.DoubleType()) if widen else x,
                                             ir.Constant(_I32, lane))
            return vec

        return _watertight4(context, builder, signature, at, *rest)

    return sig, codegen


@nb.njit(**JIT, inline="always")
def count_hits4(leaf_tri, first, end, kx, ky, kz, okx, oky, okz, sx, sy, sz, t_min, t_max):
    """How many triangles of slots first..end (a leaf of triangles only) the ray hits with t_min < t < t_max: the
    count the scalar watertight_triangle gives slot by slot, 4 slots a vector pass (triangles4), the flagged
    lanes through the scalar test."""
    axes = (np.uint64(kx), np.uint64(ky), np.uint64(kz))
    n = 0
    while first < end:
        r = triangles4(leaf_tri, np.int64(first), axes, okx, oky, okz, sx, sy, sz, t_min, t_max,
                       np.int64(min(end - first, 4)))
        n += np.int64(r[0] < np.inf) + np.int64(r[1] < np.inf) + np.int64(r[2] < np.inf) + np.int64(r[3] < np.inf)
        tie = r[12]
        if tie != 0:
            for lane in range(4):
                if (tie >> lane) & 1:
                    t, _, _ = watertight_triangle(leaf_tri, (first + lane) * 9, okx, oky, okz, kx, ky, kz, sx, sy,
                                                  sz, t_min, t_max)
                    n += np.int64(t < np.inf)
        first += 4
    return n
