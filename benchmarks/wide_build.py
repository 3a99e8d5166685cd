"""Is a tree built wide worth building? Node visits per ray on three trees over the same binary SAH build
(issue 21 item 2, session 19).

    NUMBA_NUM_THREADS=1 PYTHONPATH=src python benchmarks/wide_build.py [--mesh bun_zipper_subdiv2.ply] [--rays N]

The trees, all over kernels/bvh/build.build_bvh2's binary binned-SAH tree of the mesh (the build durer ships):
  * binary: that tree as it is (2 lanes a node used), for the visit count the collapse saves;
  * greedy 4-wide: build.collapse_bvh4 (what durer ships: each wide node opens its largest-area inner child until it
    has 4 children; the same rule as Embree's wide builders, which split the largest child by binned SAH);
  * SAH-optimal 4-wide: the 4-wide tree of least SAH cost over the same binary tree (the dynamic programme of Ylitie,
    Karras & Laine 2017, "Efficient incoherent ray traversal on GPUs through compressed wide BVHs", for width 4:
    every node picks the cut of at most 4 subtrees below it that minimises the cost, and any subtree of at most
    MAX_LEAF items may become a leaf); SAH constants of the build (a node visit 2, a triangle test 1).
For each: its SAH cost (per unit root area), node count, and per ray, on raycases.random_rays, the closest walk's
(single.blas_closest's order) node visits, leaves and triangle tests, and the count walk's (queued.blas_count's),
and the time of each walk over the batch (one thread, medians of --rounds, interleaved; CPU time of the thread).
Mesh: the Stanford bunny (Stanford Computer Graphics Laboratory) from ../shared/meshes.
"""

from __future__ import annotations

import argparse

import numba as nb
import numpy as np
from raycases import SHARED, load_mesh, random_rays
from walk_variants import timed

from durer.kernels.bvh.build import TRAVERSAL_COST, build_bvh2, collapse_bvh4
from durer.kernels.bvh.items import item_boxes
from durer.kernels.bvh.layout import MAX_LEAF, leaf_code, leaf_range, stack_size_for
from durer.kernels.bvh.queued import QUEUE_FIFO, queue_start, ring_for
from durer.kernels.bvh.single import node_dists4, prefetch_children, push_nearest_first, ray_setup
from durer.kernels.intersect import watertight_triangle

_JIT = dict(error_model="numpy", nogil=True)
_U0, _U1 = np.uint64(0), np.uint64(1)


def area(b: np.ndarray) -> float:
    e = np.maximum(b[3:] - b[:3], 0.0)
    return float(e[0] * e[1] + e[1] * e[2] + e[2] * e[0])


def ranges(left, right, start, count):
    """Each binary node's item range (first, n) and box area."""
    m = len(left)
    first, n = np.array(start, np.int64), np.array(count, np.int64)
    for q in range(m - 1, -1, -1):  # children after parents in build order
        if left[q] >= 0:
            first[q] = min(first[left[q]], first[right[q]])
            n[q] = n[left[q]] + n[right[q]]
    return first, n


def optimal_cuts(box, left, right, start, count, width=4):
    """The SAH-optimal `width`-wide tree over the binary one: for each node, as a wide node, its children (a cut of
    at most `width` binary nodes), or None where it is a leaf."""
    m = len(left)
    first, n = ranges(left, right, start, count)
    ar = np.array([area(box[q]) for q in range(m)])
    big = np.inf
    cost = np.full(m, big)           # C(q): q as a leaf or wide node
    as_leaf = np.zeros(m, bool)
    f = np.full((m, width + 1), big)  # F(q, k): q's subtree covered by at most k nodes
    split = np.zeros((m, width + 1), np.int64)  # j: F(left, j) + F(right, k - j); 0: q itself
    order = sorted(range(m), key=lambda q: n[q])  # children before parents (fewer items)
    for q in order:
        if left[q] < 0:
            cost[q] = ar[q] * n[q]
            as_leaf[q] = True
        else:
            lq, rq = left[q], right[q]
            best_open = min(f[lq, j] + f[rq, width - j] for j in range(1, width))
            cost[q] = TRAVERSAL_COST * ar[q] + best_open
            if n[q] <= MAX_LEAF and ar[q] * n[q] <= cost[q]:
                cost[q] = ar[q] * n[q]
                as_leaf[q] = True
        f[q, 1] = cost[q]
        for k in range(2, width + 1):
            f[q, k], split[q, k] = cost[q], 0
            if left[q] >= 0 and not as_leaf[q]:
                for j in range(1, k):
                    c = f[left[q], j] + f[right[q], k - j]
                    if c < f[q, k]:
                        f[q, k], split[q, k] = c, j

    def cut(q, k):
        if k == 1 or split[q, k] == 0:
            return [q]
        j = split[q, k]
        return cut(left[q], j) + cut(right[q], k - j)

    def children(q):
        best_j = min(range(1, width), key=lambda j: f[left[q], j] + f[right[q], width - j])
        return cut(left[q], best_j) + cut(right[q], width - best_j)

    return as_leaf, children, first, n, cost[0] / ar[0]


def emit(box, root, is_leaf, children, first, n, width=4):
    """The layout.py arrays (bounds (N, 6, 4) float32 rounded outwards, child (N, 4)) of the wide tree whose nodes
    are given by is_leaf(q) and children(q) over binary nodes; leaves name slots first..first+n of the build order."""
    nodes = [root]
    rows_b, rows_c = [], []
    w = 0
    while w < len(nodes):
        q = nodes[w]
        b = np.full((6, 4), np.inf, np.float32)
        c = np.zeros(4, np.int32)
        for lane, k in enumerate(children(q)):
            lo = np.nextafter(box[k, :3].astype(np.float32), np.float32(-np.inf))
            hi = np.nextafter(box[k, 3:].astype(np.float32), np.float32(np.inf))
            b[:3, lane], b[3:, lane] = lo, hi
            if is_leaf(k):
                c[lane] = leaf_code(int(first[k]), int(n[k]))
            else:
                c[lane] = len(nodes)
                nodes.append(k)
        rows_b.append(b)
        rows_c.append(c)
        w += 1
    return np.array(rows_b), np.array(rows_c)


def sah_of(bounds, child):
    """The wide tree's SAH cost per unit root area (a node visit TRAVERSAL_COST, a triangle 1)."""
    b = bounds.astype(np.float64)
    with np.errstate(invalid="ignore"):  # empty lanes: inf - inf
        e = np.where(child[:, None, :] != 0, np.maximum(b[:, 3:] - b[:, :3], 0), 0)
    a = e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]
    root = b[0]
    lo = np.min(np.where(child[0] != 0, root[:3], np.inf), axis=1)
    hi = np.max(np.where(child[0] != 0, root[3:], -np.inf), axis=1)
    ea = hi - lo
    ra = ea[0] * ea[1] + ea[1] * ea[2] + ea[2] * ea[0]
    _, cnt = leaf_range_np(child)
    inner = child > 0
    return (TRAVERSAL_COST * (ra + a[inner].sum()) + (a[child < 0] * cnt[child < 0]).sum()) / ra


def leaf_range_np(child):
    v = -child.astype(np.int64) - 1
    return v >> 3, np.where(child < 0, v & 7, 0)


@nb.njit(**_JIT)
def closest_counts(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out, stats):
    """single.blas_closest's walk (triangles only) over the batch, counting node visits, leaves and triangles."""
    stack_node = np.empty(stack_size + 1, np.int32)
    stack_t = np.empty(stack_size + 1)
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        best = np.inf
        prim = -1
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
        sp = _U0
        node = np.int32(0)
        while True:
            if node >= 0:
                stats[0] += 1
                c0, c1, c2, c3 = prefetch_children(bounds, leaf_tri, child, node)
                d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, 0.0, best)
                nxt, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
                if nxt != 0:
                    node = nxt
                    continue
            else:
                stats[1] += 1
                first, end = leaf_range(node)
                for j in range(first, end):
                    stats[2] += 1
                    t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, 0.0, best)
                    if t < best:
                        best, prim = t, leaf_prim[j]
            node = 0
            while sp > _U0:
                if stack_t[sp] <= best:
                    node = stack_node[sp]
                    sp -= _U1
                    break
                sp -= _U1
            if node == 0:
                break
        out[i, 0], out[i, 1] = best, prim


@nb.njit(**_JIT)
def count_counts(bounds, child, leaf_tri, o, d, stack_size, out, stats):
    """queued.blas_count's walk (triangles only) over the batch, counting node visits, leaves and triangles."""
    ring = ring_for(stack_size)
    mask = np.uint64(ring.shape[0] - 1)
    one = np.uint64(1)
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
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
                stats[0] += 1
                c0, c1, c2, c3 = prefetch_children(bounds, leaf_tri, child, node)
                d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, 0.0, np.inf)
                ring[tail & mask] = c0
                tail += np.uint64(d0 < np.inf)
                ring[tail & mask] = c1
                tail += np.uint64(d1 < np.inf)
                ring[tail & mask] = c2
                tail += np.uint64(d2 < np.inf)
                ring[tail & mask] = c3
                tail += np.uint64(d3 < np.inf)
                continue
            stats[1] += 1
            first, end = leaf_range(node)
            for j in range(first, end):
                stats[2] += 1
                t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, 0.0, np.inf)
                n += np.int64(t < np.inf)
        out[i] = n


def depth_of(child):
    depth = np.zeros(len(child), np.int64)
    for w in range(len(child)):
        for c in child[w]:
            if c > 0:
                depth[c] = depth[w] + 1
    return int(depth.max()) + 1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mesh", default="bun_zipper.ply")
    ap.add_argument("--rays", type=int, default=262_144)
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args()
    mesh = load_mesh(SHARED / "meshes", a.mesh)
    o, d = random_rays(mesh, a.rays)
    tris = np.ascontiguousarray(mesh.triangles, dtype=np.float64).reshape(-1, 9)
    lo, hi = item_boxes(tris, np.zeros((0, 3)), np.zeros((0, 3)))
    box, left, right, start, count, order = build_bvh2(lo, hi)
    first, n = ranges(left, right, start, count)
    leaf_tri = tris[order].astype(np.float32).reshape(-1)
    leaf_prim = np.asarray(order, np.int32)
    trees = {}
    trees["binary"] = emit(box, 0, lambda q: left[q] < 0, lambda q: [left[q], right[q]], first, n)
    trees["greedy 4-wide (shipped)"] = collapse_bvh4(box, left, right, start, count)[:2]
    as_leaf, children, first2, n2, cost = optimal_cuts(box, left, right, start, count)
    trees["SAH-optimal 4-wide"] = emit(box, 0, lambda q: as_leaf[q], children, first2, n2)
    ref = None
    runs = {}
    for name, (bounds, child) in trees.items():
        bflat = np.ascontiguousarray(bounds, np.float32).reshape(-1)
        child = np.ascontiguousarray(child, np.int32)
        ss = stack_size_for(depth_of(child))
        out = np.empty((len(o), 2))
        cnt = np.empty(len(o), np.int64)
        s1, s2 = np.zeros(3, np.int64), np.zeros(3, np.int64)
        closest_counts(bflat, child, leaf_prim, leaf_tri, o, d, ss, out, s1)
        count_counts(bflat, child, leaf_tri, o, d, ss, cnt, s2)
        if ref is None:
            ref = (out.copy(), cnt.copy())
        same = np.array_equal(out[:, 0], ref[0][:, 0]) and np.array_equal(cnt, ref[1])
        leaves = (child < 0).sum()
        print(f"{name:26s} SAH {sah_of(bounds, child):6.1f}  nodes {len(child):6d} leaves {leaves:6d} depth "
              f"{depth_of(child):3d} | closest: visits {s1[0] / len(o):5.2f} leaves {s1[1] / len(o):5.2f} tris "
              f"{s1[2] / len(o):5.2f} | count: visits {s2[0] / len(o):5.2f} leaves {s2[1] / len(o):5.2f} tris "
              f"{s2[2] / len(o):5.2f} | same t and counts: {same}", flush=True)
        runs[name] = (bflat, child, ss, out, cnt)
    times = {k: ([], []) for k in runs}
    z = np.zeros(3, np.int64)
    for r in range(a.rounds):
        for k in (list(runs) if r % 2 == 0 else list(runs)[::-1]):
            bf, ch, ss, out, cnt = runs[k]
            times[k][0].append(timed(lambda bf=bf, ch=ch, ss=ss, out=out: closest_counts(bf, ch, leaf_prim, leaf_tri,
                                                                                          o, d, ss, out, z)))
            times[k][1].append(timed(lambda bf=bf, ch=ch, ss=ss, cnt=cnt: count_counts(bf, ch, leaf_tri, o, d, ss,
                                                                                        cnt, z)))
    ref_k = "greedy 4-wide (shipped)"
    for k in runs:
        rc = np.median(np.array(times[k][0]) / np.array(times[ref_k][0]))
        rn = np.median(np.array(times[k][1]) / np.array(times[ref_k][1]))
        print(f"{k:26s} closest {np.median(times[k][0]) / len(o) * 1e9:5.0f} ns/ray ({rc:.3f}x shipped)  count "
              f"{np.median(times[k][1]) / len(o) * 1e9:5.0f} ns/ray ({rn:.3f}x shipped)", flush=True)


if __name__ == "__main__":
    main()
