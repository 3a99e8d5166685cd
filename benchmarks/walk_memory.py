"""The walk's memory, measured (issue 21 item 2, session 18): page size, node alignment and 128-byte nodes.

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/walk_memory.py [--mesh bun_zipper_subdiv2.ply]
        [--rays 262144] [--rounds 9]

single.blas_closest over 262,144 incoherent rays (benchmarks/raycases.random_rays), one thread, CPU time of the
thread, every variant in each round (the order reversed every other round), medians of the per-round ratios to the
first row; every variant's (t, kind, prim, u, v) checked equal to the bit:
  * the tree as built, its boxes copied to start a 64-byte line (each 96-byte node then spans two lines);
  * the same with the boxes at 16 bytes past a line (half the nodes span three lines, and the children's prefetch
    of base and base + 64 bytes leaves the third unfetched);
  * the tree's four arrays copied onto 2 MiB pages (accel/pages.on_huge_pages);
  * 128-byte nodes: the 24 float32 of the boxes, the 4 int32 child codes and 16 bytes of padding in one block
    starting a line (two lines a node; the codes read from the block, no child array), the walk otherwise
    blas_closest's for triangles.
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
from durer.accel.pages import on_huge_pages
from durer.kernels.bvh.layout import FAR_WIDEN, HI_X, HI_Y, HI_Z, LEAF_COUNT_BITS, LO_X, LO_Y, LO_Z, leaf_range
from durer.kernels.bvh.simd import entry4, prefetch, prefetch_pair
from durer.kernels.bvh.single import push_nearest_first, ray_setup
from durer.kernels.common import MISS, TRIANGLE
from durer.kernels.intersect import watertight_triangle

_JIT = dict(error_model="numpy", nogil=True)
_UX, _UY, _UZ = np.uint64(LO_X + HI_X), np.uint64(LO_Y + HI_Y), np.uint64(LO_Z + HI_Z)
_U0, _U1, _U9, _U16, _U24 = (np.uint64(k) for k in (0, 1, 9, 16, 24))
_UN = np.uint64(32)



@intrinsic
def codes_at(typingctx, array, off):
    """The 4 int32 child codes at float32 element `off` (uint64) of a 128-byte node block, one 16-byte load."""
    sig = types.UniTuple(types.int32, 4)(array, off)
    def codegen(context, builder, signature, args):
        arr, r = args
        data = cgutils.create_struct_proxy(signature.args[0])(context, builder, value=arr).data
        vec_t = ir.VectorType(ir.IntType(32), 4)
        ptr = builder.bitcast(builder.gep(data, [r]), vec_t.as_pointer())
        vec = builder.load(ptr, align=16)
        return context.make_tuple(builder, signature.return_type,
                                  [builder.extract_element(vec, ir.Constant(ir.IntType(32), k)) for k in range(4)])
    return sig, codegen

def pack(bounds: np.ndarray, child: np.ndarray) -> np.ndarray:
    """The 128-byte node array (flat float32, 32 a node, starting a 64-byte line): boxes, then codes, then pad."""
    n = len(child)
    buf = np.zeros(n * 32 + 16, np.float32)
    s = (-buf.ctypes.data % 64) // 4
    nodes = buf[s:s + n * 32].reshape(n, 32)
    nodes[:, :24] = bounds.reshape(n, 24)
    nodes[:, 24:28] = child.view(np.float32)
    assert nodes.ctypes.data % 64 == 0
    return nodes.reshape(-1)

@nb.njit(**_JIT, inline="always")
def pf_child(nodes, leaf_tri, code):
    """single._prefetch_child for 128-byte nodes: the node's two lines (codes included), or a leaf's first lines."""
    base = np.uint64(max(code, 0)) * _UN
    prefetch(nodes, base)
    prefetch(nodes, base + _U16)
    prefetch_pair(leaf_tri, np.uint64((-min(code, -1) - 1) >> LEAF_COUNT_BITS) * _U9)

@nb.njit(**_JIT)
def walk_packed(nodes, root, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, stack_t):
    """single.blas_closest (triangles only) over 128-byte nodes."""
    best = t_max
    kind = MISS
    prim = -1
    bu = 0.0
    bv = 0.0
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    rx, ry, rz = np.uint64(nrx), np.uint64(nry), np.uint64(nrz)
    sp = _U0
    node = root
    while True:
        if node >= 0:
            base = np.uint64(node) * _UN
            c0, c1, c2, c3 = codes_at(nodes, base + _U24)
            pf_child(nodes, leaf_tri, c0)
            pf_child(nodes, leaf_tri, c1)
            pf_child(nodes, leaf_tri, c2)
            pf_child(nodes, leaf_tri, c3)
            d0, d1, d2, d3 = entry4(nodes, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry), base + rz,
                                    base + (_UZ - rz), (ox, oy, oz), (idx, idy, idz), t_min, best, FAR_WIDEN)
            nxt, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
            if nxt != 0:
                node = nxt
                continue
        else:
            first, end = leaf_range(node)
            for j in range(first, end):
                p = leaf_prim[j]
                t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, best)
                if t < best:
                    best, kind, prim, bu, bv = t, TRIANGLE, p, u, w
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
def run_b(nodes, leaf_prim, leaf_tri, o, d, stack_size, out):
    """walk_memory's run_a: walk_packed over the batch; out (n, 5) = t, kind, prim, u, v."""
    stack_node = np.empty(stack_size + 1, np.int32)
    stack_t = np.empty(stack_size + 1)
    for i in range(o.shape[0]):
        t, kind, prim, u, v = walk_packed(nodes, np.int32(0), leaf_prim, leaf_tri, o[i, 0], o[i, 1], o[i, 2],
                                          d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v



def at_offset(a: np.ndarray, off: int) -> np.ndarray:
    """A copy of `a` whose data starts `off` bytes past a 64-byte line."""
    buf = np.empty(a.nbytes + 128, np.uint8)
    s = (off - buf.ctypes.data) % 64
    out = buf[s:s + a.nbytes].view(a.dtype).reshape(a.shape)
    out[...] = a
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh", default="bun_zipper.ply")
    ap.add_argument("--rays", type=int, default=262_144)
    ap.add_argument("--rounds", type=int, default=9)
    a = ap.parse_args()
    mesh = load_mesh(SHARED / "meshes", a.mesh)
    o, d = random_rays(mesh, a.rays)
    tree = build_tree(np.asarray(mesh.triangles), np.zeros((0, 3)), np.zeros((0, 3)))
    b, rest = tree.bounds.reshape(-1), (tree.child, tree.leaf_prim, tree.leaf_tri.reshape(-1))
    flat = (b, *rest)
    huge = on_huge_pages(tuple(np.ascontiguousarray(x) for x in flat))
    nodes = pack(tree.bounds, tree.child)
    ss = tree.stack_size
    aligned, past = (at_offset(b, 0), *rest), (at_offset(b, 16), *rest)
    variants = {
        "boxes 64-byte aligned": lambda out: run_a(*aligned, o, d, ss, out),
        "boxes 16 bytes past a line": lambda out: run_a(*past, o, d, ss, out),
        "tree on 2 MiB pages": lambda out: run_a(*huge, o, d, ss, out),
        "128-byte nodes": lambda out: run_b(nodes, tree.leaf_prim, rest[2], o, d, ss, out),
    }
    print(f"{a.mesh}: {len(tree.child)} nodes, leaves {tree.leaf_tri.dtype}, {a.rays} rays", flush=True)
    outs = {k: np.empty((len(o), 5)) for k in variants}
    for k, fn in variants.items():
        fn(outs[k])
    first = next(iter(variants))
    times = {k: [] for k in variants}
    for r in range(a.rounds):
        for k in (list(variants) if r % 2 == 0 else list(variants)[::-1]):
            times[k].append(timed(lambda k=k: variants[k](outs[k])))
    for k in variants:
        same = np.array_equal(outs[k].view(np.int64), outs[first].view(np.int64))
        ratio = np.median(np.array(times[k]) / np.array(times[first]))
        print(f"{k:28s} {np.median(times[k]) / len(o) * 1e9:5.0f} ns/ray  ratio {ratio:.3f}  same to the bit: {same}")


if __name__ == "__main__":
    main()
