"""Where the one-ray closest-hit traversal (kernels/bvh/single.blas_closest) spends its time on incoherent rays.

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/profile_single.py [--mesh bun_zipper_subdiv2.ply]

A counting copy of blas_closest (same walk, same tests) records for each ray of benchmarks/single_ray.py's batch
the nodes it visits and the leaf slots it tests; the script prints the counts per ray (node visits, child boxes
entered per visit, stack pops and the ones dropped as farther than the hit, triangle tests), then the CPU time
per ray (median of --repeat) of:
  * the kernel itself (blas_closest over the batch, as trace.closest_hit_bvh calls it);
  * replaying only the recorded node tests (node_dists4 of each visited node, in the same order, so the same
    memory is touched), only the recorded triangle tests, and only the memory reads of both (the first word
    of each node and triangle);
so that kernel - node tests - triangle tests is what the walk itself costs (ordering, stack, branches).
Mesh: the Stanford bunny (Stanford Computer Graphics Laboratory), from ../shared/meshes.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from single_ray import cpu_ns_per_ray, incoherent_case

from durer.accel.bvh import build_tree
from durer.kernels.bvh.layout import NODE_FLOATS, leaf_range
from durer.kernels.bvh.single import blas_closest, child_codes, node_dists4, push_nearest_first, ray_setup
from durer.kernels.intersect import watertight_triangle


@nb.njit(cache=False)
def record(bounds, child, leaf_tri, o, d, stack_size, visits, slots, counts, entered):
    """The closest-hit walk of blas_closest (triangles only), recording visited nodes and tested slots: ray i's
    visits are visits[counts[i, 0] ...] and so on; counts[i] = (visit offset, slot offset, visits, hits per
    visit summed, pops, pops dropped, triangle tests, leaves); entered[k] counts the visits that entered k boxes."""
    stack_node = np.empty(stack_size, np.int32)
    stack_t = np.empty(stack_size)
    u1 = np.uint64(1)
    nv = 0
    ns = 0
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        counts[i, 0] = nv
        counts[i, 1] = ns
        best = np.inf
        sp = np.uint64(0)  # the ordered stack of push_nearest_first: entry k at index k + 1
        node = 0
        while True:
            if node >= 0:
                visits[nv] = node
                nv += 1
                counts[i, 2] += 1
                d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, 0.0, best)
                hit = (d0 < np.inf) + (d1 < np.inf) + (d2 < np.inf) + (d3 < np.inf)
                counts[i, 3] += hit
                entered[hit] += 1
                c0, c1, c2, c3 = child_codes(child, node)
                nxt, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
                if nxt != 0:
                    node = nxt
                    continue
            else:
                counts[i, 7] += 1
                first, end = leaf_range(node)
                for j in range(first, end):
                    slots[ns] = j
                    ns += 1
                    counts[i, 6] += 1
                    t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, 0.0, best)
                    if t < best:
                        best = t
            node = 0
            while sp > 0:
                counts[i, 4] += 1
                if stack_t[sp] <= best:
                    node = stack_node[sp]
                    sp -= u1
                    break
                sp -= u1
                counts[i, 5] += 1
            if node == 0:
                break
    return nv, ns


@nb.njit(cache=False)
def replay_nodes(bounds, o, d, visits, counts, t_hi):
    """node_dists4 of every recorded visit, ray by ray (the sum keeps the work)."""
    acc = 0.0
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        for k in range(counts[i, 0], counts[i, 0] + counts[i, 2]):
            d0, d1, d2, d3 = node_dists4(bounds, visits[k], nrx, nry, nrz, ox, oy, oz, idx, idy, idz, 0.0, t_hi[i])
            acc += min(min(d0, d1), min(d2, d3))
    return acc


@nb.njit(cache=False)
def replay_triangles(leaf_tri, o, d, slots, counts, t_hi):
    """watertight_triangle of every recorded slot, ray by ray."""
    acc = 0.0
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        for k in range(counts[i, 1], counts[i, 1] + counts[i, 6]):
            t, u, w = watertight_triangle(leaf_tri, slots[k] * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, 0.0,
                                          t_hi[i])
            acc += u if t < np.inf else 0.0
    return acc


@nb.njit(cache=False)
def replay_reads(bounds, leaf_tri, visits, slots, nv, ns):
    """Only the memory reads of the replays: the first float of each visited node and tested triangle."""
    acc = 0.0
    for k in range(nv):
        acc += bounds[visits[k] * NODE_FLOATS]
    for k in range(ns):
        acc += leaf_tri[slots[k] * 9]
    return acc


@nb.njit(cache=False)
def kernel(bounds, child, leaf_prim, leaf_tri, o, d, stack_size):
    """blas_closest over the batch, as bvh_trace.closest_hit_bvh calls it for incoherent chunks."""
    stack_node = np.empty(stack_size, np.int32)
    stack_t = np.empty(stack_size)
    e3, e1, e34 = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 4))
    acc = 0.0
    for i in range(o.shape[0]):
        t, kind, prim, u, v = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, e3, e1, e34, o[i, 0], o[i, 1],
                                           o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
        acc += t
    return acc


def cpu_ns(fn, n: int, repeat: int) -> float:
    """Median CPU time of the calling thread per ray, in ns (single_ray.cpu_ns_per_ray's median)."""
    return cpu_ns_per_ray(fn, n, repeat)[0]


def lines_report(bounds: np.ndarray, leaf_tri: np.ndarray, visits: np.ndarray, slots: np.ndarray, n: int) -> str:
    """Cache lines the recorded visits read, per ray: each visited node's boxes (NODE_FLOATS float32, two or three
    lines by the array's alignment) and its row of child codes, and each tested triangle (9 floats of leaf_tri);
    beside them the figure for 128-byte nodes (boxes and codes in one aligned block: two lines a visit)."""
    def spans(base: int, start: np.ndarray, size: int) -> np.ndarray:
        first = (base + start) // 64
        return (base + start + size - 1) // 64 - first + 1

    box = spans(bounds.ctypes.data, visits.astype(np.int64) * NODE_FLOATS * 4, NODE_FLOATS * 4).sum()
    tri = spans(leaf_tri.ctypes.data, slots.astype(np.int64) * 9 * leaf_tri.itemsize, 9 * leaf_tri.itemsize).sum()
    return (f"cache lines read per ray: node boxes {box / n:.1f} (bounds at {bounds.ctypes.data % 64} mod 64), "
            f"child rows {len(visits) / n:.1f}, triangles {tri / n:.1f} ({leaf_tri.dtype}); "
            f"with 128-byte nodes the nodes would read {2 * len(visits) / n:.1f}")


def main() -> None:
    args, mesh, o, d = incoherent_case(__doc__.split("\n")[0])
    tree = build_tree(np.asarray(mesh.triangles), np.zeros((0, 3)), np.zeros((0, 3)))
    bounds, child, leaf_tri = tree.bounds.reshape(-1), tree.child, tree.leaf_tri.reshape(-1)
    n = len(o)
    visits = np.empty(n * 200, np.int32)
    slots = np.empty(n * 200, np.int32)
    counts = np.zeros((n, 8), np.int64)
    entered = np.zeros(5, np.int64)
    nv, ns = record(bounds, child, leaf_tri, o, d, tree.stack_size, visits, slots, counts, entered)
    t_hi = np.full(n, np.inf)
    c = counts.mean(axis=0)
    print(f"{args.mesh}: {len(child)} nodes, {len(tree.leaf_prim)} leaf slots, depth {tree.depth}, {n} rays")
    print(f"per ray: node visits {c[2]:.2f}, child boxes entered per visit {c[3] / c[2]:.2f}, stack pops {c[4]:.2f}"
          f" (dropped as farther than the hit {c[5]:.2f}), leaves {c[7]:.2f}, triangle tests {c[6]:.2f}")
    share = ", ".join(f"{k}: {v / entered.sum():.0%}" for k, v in enumerate(entered))
    print(f"node visits entering k child boxes: {share}; node visits per ray, median "
          f"{np.median(counts[:, 2]):.0f}, 99th percentile {np.percentile(counts[:, 2], 99):.0f}")
    print(lines_report(bounds, leaf_tri, visits[:nv], slots[:ns], n))
    figures = {
        "kernel": cpu_ns(lambda: kernel(bounds, child, tree.leaf_prim, leaf_tri, o, d, tree.stack_size), n,
                         args.repeat),
        "node tests": cpu_ns(lambda: replay_nodes(bounds, o, d, visits, counts, t_hi), n, args.repeat),
        "triangle tests": cpu_ns(lambda: replay_triangles(leaf_tri, o, d, slots, counts, t_hi), n, args.repeat),
        "reads only": cpu_ns(lambda: replay_reads(bounds, leaf_tri, visits, slots, nv, ns), n, args.repeat),
    }
    walk = figures["kernel"] - figures["node tests"] - figures["triangle tests"]
    print(" ".join(f"{k}={v:.0f}ns" for k, v in figures.items()), f"walk (rest)={walk:.0f}ns",
          f"per node visit {figures['node tests'] / c[2]:.1f}ns, per triangle {figures['triangle tests'] / c[6]:.1f}ns")


if __name__ == "__main__":
    main()
