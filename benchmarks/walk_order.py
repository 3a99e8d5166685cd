"""Child order in the closest walk: a branch-free sorting network against the nearest-by-selects push (issue 21
item 2, session 19).

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/walk_order.py [--mesh bun_zipper_subdiv2.ply] [--rounds 7]

single.blas_closest steps into the nearest entered child (three selects on the 4 entry distances, the code picked
from registers), pushes the other entered ones in lane order and exchanges the top two. The variant sorts the 4
(distance, code) pairs with the 5 compare-exchanges of a 4-input sorting network (min/max and selects, no branch),
steps into the first and pushes the others farthest first (always written, the pointer moved where entered), so
every pop takes the nearest pending child and nothing waits on an exchange's load. Both are triangles-only copies
of the walk, paired with it in one process (one thread, CPU time of the thread, 262,144 raycases.random_rays, the
order of the variants reversed every other round, medians of the per-round ratios to single.blas_closest); t is
checked equal to the bit (prim, u, v may differ only on ties: a ray meeting two triangles at one t).
Mesh: the Stanford bunny (Stanford Computer Graphics Laboratory) from ../shared/meshes.
"""

from __future__ import annotations

import argparse

import numba as nb
import numpy as np
from raycases import SHARED, load_mesh, random_rays
from walk_variants import run_a, timed

from durer.accel.bvh import build_tree
from durer.kernels.bvh.layout import leaf_range
from durer.kernels.bvh.single import node_dists4, prefetch_children, push_nearest_first, ray_setup
from durer.kernels.common import MISS, TRIANGLE
from durer.kernels.intersect import watertight_triangle

_JIT = dict(error_model="numpy", nogil=True)
_U0, _U1 = np.uint64(0), np.uint64(1)


@nb.njit(**_JIT, inline="always")
def _cx(da, ca, db, cb):
    """Compare-exchange: the pair with the smaller distance first."""
    s = db < da
    return (db if s else da), (cb if s else ca), (da if s else db), (ca if s else cb)


@nb.njit(**_JIT, inline="always")
def push_sorted(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp):
    """The sorting-network form of push_nearest_first: (nearest entered code or 0, new stack pointer)."""
    d0, c0, d1, c1 = _cx(d0, c0, d1, c1)
    d2, c2, d3, c3 = _cx(d2, c2, d3, c3)
    d0, c0, d2, c2 = _cx(d0, c0, d2, c2)
    d1, c1, d3, c3 = _cx(d1, c1, d3, c3)
    d1, c1, d2, c2 = _cx(d1, c1, d2, c2)
    u = sp + _U1
    stack_node[u] = c3
    stack_t[u] = d3
    sp += np.uint64(d3 < np.inf)
    u = sp + _U1
    stack_node[u] = c2
    stack_t[u] = d2
    sp += np.uint64(d2 < np.inf)
    u = sp + _U1
    stack_node[u] = c1
    stack_t[u] = d1
    sp += np.uint64(d1 < np.inf)
    return (c0 if d0 < np.inf else np.int32(0)), sp


def make_walk(sorted_push: bool):
    @nb.njit(**_JIT, inline="always")
    def walk(bounds, child, leaf_prim, leaf_tri, ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, stack_t):
        best = t_max
        kind = MISS
        prim = -1
        bu = 0.0
        bv = 0.0
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        sp = _U0
        node = np.int32(0)
        while True:
            if node >= 0:
                c0, c1, c2, c3 = prefetch_children(bounds, leaf_tri, child, node)
                d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, best)
                if sorted_push:
                    nxt, sp = push_sorted(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
                else:
                    nxt, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
                if nxt != 0:
                    node = nxt
                    continue
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
    def run(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out):
        stack_node = np.empty(stack_size + 1, np.int32)
        stack_t = np.empty(stack_size + 1)
        for i in range(o.shape[0]):
            t, kind, prim, u, v = walk(bounds, child, leaf_prim, leaf_tri, o[i, 0], o[i, 1], o[i, 2], d[i, 0],
                                       d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
            out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v

    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh", default="bun_zipper.ply")
    ap.add_argument("--rays", type=int, default=262_144)
    ap.add_argument("--rounds", type=int, default=7)
    a = ap.parse_args()
    mesh = load_mesh(SHARED / "meshes", a.mesh)
    o, d = random_rays(mesh, a.rays)
    tree = build_tree(np.asarray(mesh.triangles), np.zeros((0, 3)), np.zeros((0, 3)))
    b, child, lp, lt = tree.bounds.reshape(-1), tree.child, tree.leaf_prim, tree.leaf_tri.reshape(-1)
    ss = tree.stack_size
    copy, net = make_walk(False), make_walk(True)
    variants = {
        "single.blas_closest": lambda out: run_a(b, child, lp, lt, o, d, ss, out),
        "copy (nearest by selects)": lambda out: copy(b, child, lp, lt, o, d, ss, out),
        "sorting network": lambda out: net(b, child, lp, lt, o, d, ss, out),
    }
    print(f"{a.mesh}: {len(child)} nodes, {a.rays} rays", flush=True)
    outs = {k: np.empty((len(o), 5)) for k in variants}
    for k, fn in variants.items():
        fn(outs[k])
    first = next(iter(variants))
    times = {k: [] for k in variants}
    for r in range(a.rounds):
        for k in (list(variants) if r % 2 == 0 else list(variants)[::-1]):
            times[k].append(timed(lambda k=k: variants[k](outs[k])))
    for k in variants:
        same_t = np.array_equal(outs[k][:, 0].view(np.int64), outs[first][:, 0].view(np.int64))
        ties = int(np.sum(np.any(outs[k].view(np.int64) != outs[first].view(np.int64), axis=1)))
        ratio = np.median(np.array(times[k]) / np.array(times[first]))
        print(f"{k:28s} {np.median(times[k]) / len(o) * 1e9:5.0f} ns/ray  ratio {ratio:.3f}  t to the bit: {same_t}, "
              f"rays differing in (prim, u, v) only: {ties}", flush=True)


if __name__ == "__main__":
    main()
