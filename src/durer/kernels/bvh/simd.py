"""The one-ray node test as explicit 4-wide LLVM vector code, and the walk's loads and prefetches (Numba intrinsics).

Numba leaves LLVM's SLP vectoriser off (NUMBA_SLP_VECTORIZE=0), and its loop vectoriser does not take a 4-lane
loop with the per-ray row offsets of the slab test, so the node test of kernels/bvh/single.py compiled to scalar
code: 24 loads, conversions, subtractions, multiplications and 24 min/max a visit. This intrinsic emits the same
operations on <4 x float> loads widened to <4 x double> (one AVX2 instruction per row and operation). Every lane
does exactly the scalar arithmetic (IEEE subtraction, multiplication, compare-and-select, in the same order), so
the entry distances are bit-identical to the scalar form's.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

_F64x4 = ir.VectorType(ir.DoubleType(), 4)
_F32x4 = ir.VectorType(ir.FloatType(), 4)


def _splat(builder, value):
    """A <4 x double> with `value` in every lane."""
    vec = ir.Constant(_F64x4, ir.Undefined)
    for lane in range(4):
        vec = builder.insert_element(vec, value, ir.Constant(ir.IntType(32), lane))
    return vec


def _row(builder, data, offset):
    """The 4 float32 lanes at flat element `offset` of `data` (float*), widened to <4 x double>."""
    ptr = builder.bitcast(builder.gep(data, [offset]), _F32x4.as_pointer())
    return builder.fpext(builder.load(ptr, align=4), _F64x4)


def _entered(context, builder, signature, tn, tf, widen):
    """The node test's result from the lanes' entry (tn) and exit (tf) distances: a tuple of 4 float64, tn where
    tn <= tf + |tf| * widen (the box is entered), else inf."""
    fabs = cgutils.get_or_insert_function(builder.module, ir.FunctionType(_F64x4, [_F64x4]), "llvm.fabs.v4f64")
    reach = builder.fadd(tf, builder.fmul(builder.call(fabs, [tf]), _splat(builder, widen)))
    inf = _splat(builder, ir.Constant(ir.DoubleType(), float("inf")))
    dist = builder.select(builder.fcmp_ordered("<=", tn, reach), tn, inf)
    lanes = [builder.extract_element(dist, ir.Constant(ir.IntType(32), k)) for k in range(4)]
    return context.make_tuple(builder, signature.return_type, lanes)


@intrinsic
def entry4(typingctx, bounds, near_x, far_x, near_y, far_y, near_z, far_z, o, inv, t_lo, t_hi, widen):
    """(d0, d1, d2, d3): entry distance of the ray into each of the 4 boxes whose planes are the float32 rows at
    flat offsets near_* / far_* (uint64) of `bounds`, or inf for a box it misses within [t_lo, t_hi].

    o = (ox, oy, oz) and inv = (1/dx, 1/dy, 1/dz) are tuples of float64; per axis, a = (near - o) * inv and
    b = (far - o) * inv narrow tn (from t_lo, kept when a > tn is false, as for NaN) and tf (from t_hi); a lane is
    entered when tn <= tf + |tf| * widen. The scalar form of the same test is single._entry / _slab."""
    f64 = types.float64
    sig = types.UniTuple(f64, 4)(bounds, near_x, far_x, near_y, far_y, near_z, far_z, o, inv, t_lo, t_hi, widen)

    def codegen(context, builder, signature, args):
        arr, nx, fx, ny, fy, nz, fz, origin, inverse, lo, hi, wid = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        tn = _splat(builder, lo)
        tf = _splat(builder, hi)
        for axis, (near, far) in enumerate(((nx, fx), (ny, fy), (nz, fz))):
            ov = _splat(builder, builder.extract_value(origin, axis))
            iv = _splat(builder, builder.extract_value(inverse, axis))
            a = builder.fmul(builder.fsub(_row(builder, data, near), ov), iv)
            b = builder.fmul(builder.fsub(_row(builder, data, far), ov), iv)
            tn = builder.select(builder.fcmp_ordered(">", a, tn), a, tn)
            tf = builder.select(builder.fcmp_ordered("<", b, tf), b, tf)
        return _entered(context, builder, signature, tn, tf, wid)

    return sig, codegen


@intrinsic
def row4(typingctx, array, row):
    """The 4 int32 of row `row` (uint64) of a C-contiguous (N, 4) int32 array (a node's child codes) as one 16-byte
    vector load: no stride multiply, no negative-index wraparound, and the walk picks the nearest child's code
    from the registers by selects instead of loading it again after the node test."""
    if not (isinstance(array, types.Array) and array.layout == "C" and array.ndim == 2 and array.dtype == types.int32):
        return None  # a typing error: the flat offset row * 4 holds only for this layout
    sig = types.UniTuple(types.int32, 4)(array, row)

    def codegen(context, builder, signature, args):
        arr, r = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        vec_t = ir.VectorType(ir.IntType(32), 4)
        ptr = builder.gep(data, [builder.mul(r, ir.Constant(ir.IntType(64), 4))])
        vec = builder.load(builder.bitcast(ptr, vec_t.as_pointer()), align=4)
        lanes = [builder.extract_element(vec, ir.Constant(ir.IntType(32), k)) for k in range(4)]
        return context.make_tuple(builder, signature.return_type, lanes)

    return sig, codegen


def _prefetch_bytes(builder, ptr, extra):
    """llvm.prefetch (read, high locality) of i8* `ptr` + `extra` bytes."""
    i32 = ir.IntType(32)
    fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32]),
                                        "llvm.prefetch.p0i8")
    at = builder.gep(ptr, [ir.Constant(ir.IntType(64), extra)]) if extra else ptr
    builder.call(fn, [at, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])


@intrinsic
def prefetch_pair(typingctx, array, offset):
    """prefetch of element `offset` and of the line 64 bytes beyond it (a leaf's first triangles span two lines).
    The 64 bytes are a constant here: written as `offset + 64 // array.itemsize` in Numba, the item size is a
    run-time field of the array and the walk divided by it (an integer division per child and node visit,
    0.86x the closest-hit walk's time without it on the bunny, benchmarks/README.md)."""
    sig = types.void(array, offset)

    def codegen(context, builder, signature, args):
        arr, off = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        ptr = builder.bitcast(builder.gep(data, [off]), ir.IntType(8).as_pointer())
        _prefetch_bytes(builder, ptr, 0)
        _prefetch_bytes(builder, ptr, 64)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def prefetch(typingctx, array, offset):
    """Ask the cache to fetch element `offset` (uint64, counted flat from the start of a C-contiguous array of any
    dimension) ahead of its use (llvm.prefetch, read, high locality); never faults, so any offset is allowed."""
    sig = types.void(array, offset)

    def codegen(context, builder, signature, args):
        arr, off = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        _prefetch_bytes(builder, builder.bitcast(builder.gep(data, [off]), ir.IntType(8).as_pointer()), 0)
        return context.get_dummy_value()

    return sig, codegen
