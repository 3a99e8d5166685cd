"""Leaves of up to 4 triangles side by side, tested in one vector pass (issue 21 item 2, session 19).

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/walk_leaf4.py [--mesh bun_zipper_subdiv2.ply]
        [--rays 262144] [--rounds 7]

Embree's Triangle4 idea in durer's walks: each leaf's triangles copied into one block of 40 float32 (9 rows of 4
lanes, v0 x y z, v1 x y z, v2 x y z, then the 4 triangle ids as int32 bits; 160 bytes, 5 rows of 32 bytes) and
tested by `tri4`, an LLVM intrinsic doing the watertight test of kernels/intersect.watertight_triangle on
<4 x double> lanes (each row a <4 x float> load widened, the per-ray axis permutation as row offsets; every lane the
scalar arithmetic in the same order, IEEE, no FMA, so t, u, v are the scalar test's to the bit). A lane with an edge
function of exactly 0 and no mixed signs (a ray on an edge or vertex, or an edge-on triangle) goes to the scalar test
(edge_tie's rule, kept). The leaves' child codes are re-encoded to name blocks (a leaf of 5-7 items takes two).

Rows, one process, one thread, CPU time of the thread, every variant in each round (the order reversed every other
round), medians of the per-round ratios to the first row of its group; results checked equal to the bit:
  * closest: single.blas_closest (A), a triangles-only copy of its walk with the scalar leaf loop (control), the
    same walk with tri4 leaves (B);
  * count: queued.blas_count as it was before session 19 (A, a verbatim copy), queued.blas_count (its leaves
    through leaf4.count_hits4 since session 19: the tri4g form), the copy without spheres (control, not inlined
    the same way: it measured 1.26x A), the copy with tri4 leaves, the copy with tri4g leaves.
A third form, tri4g, gathers the 4 lanes from the leaves' own flat array (leaf4.triangles4: no copy of the leaves).
Also the visits per ray (nodes, leaves, triangle slots) of the closest and the count walk on the same rays, which
is the count-against-closest profile of the section in benchmarks/README.md.
Mesh: the Stanford bunny (Stanford Computer Graphics Laboratory) from ../shared/meshes.
"""

from __future__ import annotations

import argparse

import numba as nb
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic
from raycases import SHARED, load_mesh, random_rays
from walk_variants import run_a, timed

from durer.accel.bvh import build_tree
from durer.kernels.bvh.layout import LEAF_COUNT_BITS, leaf_code, leaf_range
from durer.kernels.bvh.leaf4 import _watertight4  # the shipped lanes' arithmetic, edge-on rule included
from durer.kernels.bvh.queued import QUEUE_FIFO, blas_count, queue_start, ring_for
from durer.kernels.bvh.simd import _F64x4, _prefetch_bytes
from durer.kernels.bvh.single import node_dists4, prefetch_children, push_nearest_first, ray_setup
from durer.kernels.common import MISS, TRIANGLE
from durer.kernels.intersect import sphere_hit_in_object_space, watertight_triangle

_JIT = dict(error_model="numpy", nogil=True)
_U0, _U1, _U40 = np.uint64(0), np.uint64(1), np.uint64(40)
_NO_LEAVES = np.empty(0, np.float32)  # prefetch_children's "nodes only"
BLOCK = 40  # float32 a block: 36 coordinates + 4 ids
_F32x4 = ir.VectorType(ir.FloatType(), 4)
_I1x4 = ir.VectorType(ir.IntType(1), 4)


def _row(builder, data, offset):
    ptr = builder.bitcast(builder.gep(data, [offset]), _F32x4.as_pointer())
    return builder.fpext(builder.load(ptr, align=4), _F64x4)


@intrinsic
def tri4(typingctx, blocks, base, offs, okx, oky, okz, sx, sy, sz, t_min, t_max, n):
    """The watertight test of the n (<= 4) triangles of the block at float32 offset `base` (uint64) of `blocks`:
    (t0..t3, u0..u3, v0..v3, tie) with t = inf for a lane that misses (or is beyond n), and tie a 4-bit mask of the
    lanes whose edge functions include an exact 0 and no mixed signs (the caller sends them to the scalar test).
    offs = (kx, ky, kz) as uint64 row offsets 4 * k."""
    f64 = types.float64
    sig = types.Tuple([f64] * 12 + [types.int64])(blocks, base, offs, okx, oky, okz, sx, sy, sz, t_min, t_max, n)

    def codegen(context, builder, signature, args):
        arr, b, o, *rest = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        i64 = ir.IntType(64)
        ks = [builder.extract_value(o, k) for k in range(3)]

        def at(vertex, k):
            return _row(builder, data, builder.add(b, builder.add(ir.Constant(i64, 12 * vertex), ks[k])))

        return _watertight4(context, builder, signature, at, *rest)

    return sig, codegen


@intrinsic
def tri4g(typingctx, leaf_tri, first, offs, okx, oky, okz, sx, sy, sz, t_min, t_max, n):
    """tri4 on the leaf's own triangles, gathered from the flat leaf_tri (9 coordinates a slot, float32 or float64)
    at slots first.. first + n - 1 (lanes beyond n read the last one again and are masked): no copy of the leaves.
    offs = (kx, ky, kz) as uint64."""
    f64 = types.float64
    sig = types.Tuple([f64] * 12 + [types.int64])(leaf_tri, first, offs, okx, oky, okz, sx, sy, sz, t_min, t_max,
                                                   n)

    def codegen(context, builder, signature, args):
        arr, f, o, *rest = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        i64 = ir.IntType(64)
        ks = [builder.extract_value(o, k) for k in range(3)]
        cnt = rest[-1]
        last = builder.sub(cnt, ir.Constant(i64, 1))
        slot_base = []
        for lane in range(4):
            lane_c = ir.Constant(i64, lane)
            pick = builder.select(builder.icmp_signed("<", lane_c, last), lane_c, last)
            slot_base.append(builder.mul(builder.add(f, pick), ir.Constant(i64, 9)))
        wide = signature.args[0].dtype == types.float32

        def at(vertex, k):
            vec = ir.Constant(_F64x4, ir.Undefined)
            for lane in range(4):
                idx = builder.add(slot_base[lane], builder.add(ir.Constant(i64, 3 * vertex), ks[k]))
                x = builder.load(builder.gep(data, [idx]))
                if wide:
                    x = builder.fpext(x, ir.DoubleType())
                vec = builder.insert_element(vec, x, ir.Constant(ir.IntType(32), lane))
            return vec

        return _watertight4(context, builder, signature, at, *rest)

    return sig, codegen


@intrinsic
def prefetch_block(typingctx, array, offset):
    """Prefetch the three lines a 160-byte block at element `offset` can span."""
    sig = types.void(array, offset)

    def codegen(context, builder, signature, args):
        arr, off = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        ptr = builder.bitcast(builder.gep(data, [off]), ir.IntType(8).as_pointer())
        for extra in (0, 64, 128):
            _prefetch_bytes(builder, ptr, extra)
        return context.get_dummy_value()

    return sig, codegen


def make_blocks(child: np.ndarray, leaf_prim: np.ndarray, leaf_tri: np.ndarray):
    """(child4, blocks, slot_of): the child codes re-encoded as leaf_code(block, count), the float32 blocks (flat,
    32-byte aligned) and each block's first slot in the original leaf arrays (for the scalar tie test)."""
    codes = child[child < 0]
    v = -codes.astype(np.int64) - 1
    first, count = v >> LEAF_COUNT_BITS, v & ((1 << LEAF_COUNT_BITS) - 1)
    nblk = int(np.sum((count + 3) // 4))
    buf = np.zeros(nblk * BLOCK + 8, np.float32)
    s = (-buf.ctypes.data % 32) // 4
    blocks = buf[s:s + nblk * BLOCK]
    view = blocks.reshape(nblk, BLOCK)
    ids = view[:, 36:40].view(np.int32)
    view[:, :36] = np.nan
    ids[:] = -1
    nb_leaf = (count + 3) // 4
    k0 = np.concatenate([[0], np.cumsum(nb_leaf)[:-1]])  # each leaf's first block
    new_codes = np.array([leaf_code(int(k), int(c)) for k, c in zip(k0, count, strict=True)], child.dtype)
    leaf_of = np.repeat(np.arange(len(count)), count)   # per item: its leaf, its index in the leaf
    j = np.arange(len(leaf_of)) - np.repeat(np.cumsum(count) - count, count)
    blk, lane = k0[leaf_of] + j // 4, j % 4
    slot = first[leaf_of] + j
    tri = leaf_tri.reshape(-1, 9)
    for vert in range(3):
        for ax in range(3):
            view[blk, 12 * vert + 4 * ax + lane] = tri[slot, 3 * vert + ax]
    ids[blk, lane] = leaf_prim[slot]
    slot_of = np.empty(nblk, np.int64)
    bl = np.repeat(k0, nb_leaf) + (np.arange(nblk) - np.repeat(np.cumsum(nb_leaf) - nb_leaf, nb_leaf))
    slot_of[bl] = np.repeat(first, nb_leaf) + 4 * (np.arange(nblk) - np.repeat(np.cumsum(nb_leaf) - nb_leaf, nb_leaf))
    child4 = child.copy()
    child4[child < 0] = new_codes
    return child4, blocks, slot_of


@nb.njit(**_JIT, inline="always")
def _prefetch_kids(bounds, blocks, child, node, use_blocks, leaf_tri):
    """single.prefetch_children with a leaf child's block (3 lines) instead of its first triangle."""
    if use_blocks:
        c0, c1, c2, c3 = prefetch_children(bounds, _NO_LEAVES, child, node)
        for c in (c0, c1, c2, c3):
            prefetch_block(blocks, np.uint64((-min(c, -1) - 1) >> LEAF_COUNT_BITS) * _U40)
        return c0, c1, c2, c3
    return prefetch_children(bounds, leaf_tri, child, node)


def make_closest(use_blocks: bool, gather: bool = False):
    """A triangles-only copy of single.blas_closest, its leaves tested by tri4 (use_blocks), tri4g (gather) or the
    scalar loop."""

    @nb.njit(**_JIT, inline="always")
    def walk(bounds, child, leaf_prim, leaf_tri, blocks, slot_of, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node,
             stack_t):
        best = t_max
        kind = MISS
        prim = -1
        bu = 0.0
        bv = 0.0
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        offs = (np.uint64(4 * kx), np.uint64(4 * ky), np.uint64(4 * kz))
        offg = (np.uint64(kx), np.uint64(ky), np.uint64(kz))
        ids = blocks.view(np.int32)
        sp = _U0
        node = np.int32(0)
        while True:
            if node >= 0:
                c0, c1, c2, c3 = _prefetch_kids(bounds, blocks, child, node, use_blocks, leaf_tri)
                d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, best)
                nxt, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
                if nxt != 0:
                    node = nxt
                    continue
            elif use_blocks:
                blk, end = leaf_range(node)
                n = end - blk
                while n > 0:
                    base = np.uint64(blk) * _U40
                    r = tri4(blocks, base, offs, okx, oky, okz, sx, sy, sz, t_min, best, np.int64(min(n, 4)))
                    tie = r[12]
                    lanes = ((r[0], r[4], r[8]), (r[1], r[5], r[9]), (r[2], r[6], r[10]), (r[3], r[7], r[11]))
                    for lane in range(4):
                        t, u, w = lanes[lane]
                        if (tie >> lane) & 1:
                            t, u, w = watertight_triangle(leaf_tri, (slot_of[blk] + lane) * 9, okx, oky, okz, kx, ky,
                                                          kz, sx, sy, sz, t_min, best)
                        if t < best:
                            best, kind, prim, bu, bv = t, TRIANGLE, ids[base + np.uint64(36 + lane)], u, w
                    n -= 4
                    blk += 1
            elif gather:
                first, end = leaf_range(node)
                while first < end:
                    r = tri4g(leaf_tri, np.int64(first), offg, okx, oky, okz, sx, sy, sz, t_min, best,
                              np.int64(min(end - first, 4)))
                    tie = r[12]
                    lanes = ((r[0], r[4], r[8]), (r[1], r[5], r[9]), (r[2], r[6], r[10]), (r[3], r[7], r[11]))
                    for lane in range(4):
                        t, u, w = lanes[lane]
                        if (tie >> lane) & 1:
                            t, u, w = watertight_triangle(leaf_tri, (first + lane) * 9, okx, oky, okz, kx, ky, kz, sx,
                                                          sy, sz, t_min, best)
                        if t < best:
                            best, kind, prim, bu, bv = t, TRIANGLE, leaf_prim[first + lane], u, w
                    first += 4
            else:
                first, end = leaf_range(node)
                for j in range(first, end):
                    t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, best)
                    if t < best:
                        best, kind, prim, bu, bv = t, TRIANGLE, leaf_prim[j], u, w
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

    @nb.njit(**_JIT)
    def run(bounds, child, leaf_prim, leaf_tri, blocks, slot_of, o, d, stack_size, out):
        stack_node = np.empty(stack_size + 1, np.int32)
        stack_t = np.empty(stack_size + 1)
        for i in range(o.shape[0]):
            t, kind, prim, u, v = walk(bounds, child, leaf_prim, leaf_tri, blocks, slot_of, o[i, 0], o[i, 1], o[i, 2],
                                       d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
            out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v

    return walk, run


def make_count(use_blocks: bool, gather: bool = False):
    """A triangles-only copy of queued.blas_count, its leaves tested by tri4 (use_blocks), tri4g (gather) or the
    scalar loop."""

    @nb.njit(**_JIT, inline="always")
    def walk(bounds, child, leaf_prim, leaf_tri, blocks, slot_of, ox, oy, oz, dx, dy, dz, t_min, t_max, ring):
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        offs = (np.uint64(4 * kx), np.uint64(4 * ky), np.uint64(4 * kz))
        offg = (np.uint64(kx), np.uint64(ky), np.uint64(kz))
        mask = np.uint64(ring.shape[0] - 1)
        one = np.uint64(1)
        head, tail = queue_start(ring, np.int32(0))
        n = 0
        while head != tail:
            if tail - head > np.uint64(QUEUE_FIFO):
                tail -= one
                node = ring[tail & mask]
            else:
                node = ring[head & mask]
                head += one
            if node >= 0:
                c0, c1, c2, c3 = _prefetch_kids(bounds, blocks, child, node, use_blocks, leaf_tri)
                d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max)
                ring[tail & mask] = c0
                tail += np.uint64(d0 < np.inf)
                ring[tail & mask] = c1
                tail += np.uint64(d1 < np.inf)
                ring[tail & mask] = c2
                tail += np.uint64(d2 < np.inf)
                ring[tail & mask] = c3
                tail += np.uint64(d3 < np.inf)
                continue
            if use_blocks:
                blk, end = leaf_range(node)
                m = end - blk
                while m > 0:
                    r = tri4(blocks, np.uint64(blk) * _U40, offs, okx, oky, okz, sx, sy, sz, t_min, t_max,
                             np.int64(min(m, 4)))
                    n += (np.int64(r[0] < np.inf) + np.int64(r[1] < np.inf) + np.int64(r[2] < np.inf)
                          + np.int64(r[3] < np.inf))
                    tie = r[12]
                    if tie:
                        for lane in range(4):
                            if (tie >> lane) & 1:
                                t, _, _ = watertight_triangle(leaf_tri, (slot_of[blk] + lane) * 9, okx, oky, okz, kx,
                                                              ky, kz, sx, sy, sz, t_min, t_max)
                                n += np.int64(t < np.inf)
                    m -= 4
                    blk += 1
            elif gather:
                first, end = leaf_range(node)
                while first < end:
                    r = tri4g(leaf_tri, np.int64(first), offg, okx, oky, okz, sx, sy, sz, t_min, t_max,
                              np.int64(min(end - first, 4)))
                    n += (np.int64(r[0] < np.inf) + np.int64(r[1] < np.inf) + np.int64(r[2] < np.inf)
                          + np.int64(r[3] < np.inf))
                    tie = r[12]
                    if tie:
                        for lane in range(4):
                            if (tie >> lane) & 1:
                                t, _, _ = watertight_triangle(leaf_tri, (first + lane) * 9, okx, oky, okz, kx, ky, kz,
                                                              sx, sy, sz, t_min, t_max)
                                n += np.int64(t < np.inf)
                    first += 4
            else:
                first, end = leaf_range(node)
                for j in range(first, end):
                    t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min,
                                                  t_max)
                    n += np.int64(t < np.inf)
        return n

    @nb.njit(**_JIT)
    def run(bounds, child, leaf_prim, leaf_tri, blocks, slot_of, o, d, stack_size, out):
        ring = ring_for(stack_size)
        for i in range(o.shape[0]):
            out[i] = walk(bounds, child, leaf_prim, leaf_tri, blocks, slot_of, o[i, 0], o[i, 1], o[i, 2], d[i, 0],
                          d[i, 1], d[i, 2], 0.0, np.inf, ring)

    return walk, run


@nb.njit(**_JIT, inline="always")
def blas_count_before(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, ox, oy, oz, dx, dy,
                      dz, t_min, t_max, ring):
    """queued.blas_count as it was before session 19 (every leaf slot through the scalar test), verbatim."""
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    mask = np.uint64(ring.shape[0] - 1)
    one = np.uint64(1)
    head, tail = queue_start(ring, root)
    n = 0
    while head != tail:
        if tail - head > np.uint64(QUEUE_FIFO):  # long queue: depth first from its newest end
            tail -= one
            node = ring[tail & mask]
        else:
            node = ring[head & mask]
            head += one
        if node >= 0:
            prefetch_children(bounds, leaf_tri, child, node)
            d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max)
            ring[tail & mask] = child[node, 0]
            tail += np.uint64(d0 < np.inf)
            ring[tail & mask] = child[node, 1]
            tail += np.uint64(d1 < np.inf)
            ring[tail & mask] = child[node, 2]
            tail += np.uint64(d2 < np.inf)
            ring[tail & mask] = child[node, 3]
            tail += np.uint64(d3 < np.inf)
            continue
        first, end = leaf_range(node)
        for j in range(first, end):
            p = leaf_prim[j]
            if p >= 0:
                t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max)
                n += np.int64(t < np.inf)
                continue
            s = -p - 1
            lo = t_min
            for _ in range(2):
                t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s], sph_w2o[s],
                                               lo, t_max)
                if t == np.inf:
                    break
                n += 1
                lo = t
    return n


@nb.njit(**_JIT)
def run_count_before(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out):
    """blas_count_before over the batch, as run_count_a."""
    ring = ring_for(stack_size)
    e3, e1, e34 = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 4))
    for i in range(o.shape[0]):
        out[i] = blas_count_before(bounds, child, np.int32(0), leaf_prim, leaf_tri, e3, e1, e34, o[i, 0], o[i, 1],
                                   o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, ring)


@nb.njit(**_JIT)
def run_count_a(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out):
    """queued.blas_count over the batch, as count_intersections' one-ray path calls it."""
    ring = ring_for(stack_size)
    e3, e1, e34 = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 4))
    for i in range(o.shape[0]):
        out[i] = blas_count(bounds, child, np.int32(0), leaf_prim, leaf_tri, e3, e1, e34, o[i, 0], o[i, 1], o[i, 2],
                            d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, ring)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh", default="bun_zipper.ply")
    ap.add_argument("--rays", type=int, default=262_144)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--asm", action="store_true", help="print the vector instructions of the tri4 closest walk")
    ap.add_argument("--only", choices=["closest", "count"], help="one group of rows")
    a = ap.parse_args()
    mesh = load_mesh(SHARED / "meshes", a.mesh)
    o, d = random_rays(mesh, a.rays)
    tree = build_tree(np.asarray(mesh.triangles), np.zeros((0, 3)), np.zeros((0, 3)))
    b, child, lp, lt = tree.bounds.reshape(-1), tree.child, tree.leaf_prim, tree.leaf_tri.reshape(-1)
    child4, blocks, slot_of = make_blocks(child, lp, tree.leaf_tri)
    ss = tree.stack_size
    print(f"{a.mesh}: {len(child)} nodes, leaves {tree.leaf_tri.dtype} {tree.leaf_tri.nbytes / 1e6:.2f} MB, "
          f"blocks {len(slot_of)} ({blocks.nbytes / 1e6:.2f} MB), {a.rays} rays", flush=True)
    _, run_c = make_closest(False)
    _, run_b = make_closest(True)
    _, cnt_c = make_count(False)
    _, cnt_b = make_count(True)
    _, run_g = make_closest(False, True)
    _, cnt_g = make_count(False, True)
    groups = {
        "closest": (5, np.float64, {
            "single.blas_closest": lambda out: run_a(b, child, lp, lt, o, d, ss, out),
            "copy, scalar leaves": lambda out: run_c(b, child, lp, lt, blocks, slot_of, o, d, ss, out),
            "copy, tri4 leaves": lambda out: run_b(b, child4, lp, lt, blocks, slot_of, o, d, ss, out),
            "copy, tri4 gathered": lambda out: run_g(b, child, lp, lt, blocks, slot_of, o, d, ss, out)}),
        "count": (None, np.int64, {
            "blas_count before (copy)": lambda out: run_count_before(b, child, lp, lt, o, d, ss, out),
            "queued.blas_count": lambda out: run_count_a(b, child, lp, lt, o, d, ss, out),
            "copy, scalar leaves": lambda out: cnt_c(b, child, lp, lt, blocks, slot_of, o, d, ss, out),
            "copy, tri4 leaves": lambda out: cnt_b(b, child4, lp, lt, blocks, slot_of, o, d, ss, out),
            "copy, tri4 gathered": lambda out: cnt_g(b, child, lp, lt, blocks, slot_of, o, d, ss, out)}),
    }
    for name, (cols, dtype, variants) in groups.items():
        if a.only and name != a.only:
            continue
        outs = {k: np.empty((len(o), cols) if cols else len(o), dtype) for k in variants}
        for k, fn in variants.items():
            fn(outs[k])
        first = next(iter(variants))
        times = {k: [] for k in variants}
        for r in range(a.rounds):
            for k in (list(variants) if r % 2 == 0 else list(variants)[::-1]):
                times[k].append(timed(lambda fn=variants[k], out=outs[k]: fn(out)))
        for k in variants:
            same = np.array_equal(outs[k].view(np.int64), outs[first].view(np.int64))
            ratio = np.median(np.array(times[k]) / np.array(times[first]))
            print(f"{name:8s} {k:22s} {np.median(times[k]) / len(o) * 1e9:5.0f} ns/ray  ratio {ratio:.3f}  "
                  f"same to the bit: {same}", flush=True)
    if a.asm:
        sig = next(iter(run_b.signatures))
        text = run_b.inspect_asm(sig)
        ops = [w for w in ("vsubpd", "vmulpd", "vdivpd", "vcmppd", "vcvtps2pd", "vaddpd") if w in text]
        print("tri4 vector instructions:", {w: text.count(w) for w in ops})


if __name__ == "__main__":
    main()
