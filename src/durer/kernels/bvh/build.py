"""BVH construction (Numba): a binned-SAH binary tree, collapsed into the 4-wide layout of kernels/bvh/layout.py.

Large inputs build on several threads: the root serially, its two children's tops concurrently, then the subtrees
below them concurrently, each by the same kernel (build_nodes) working in place on its own rows of the shared
arrays. The large arrays are allocated by NumPy and filled by the kernels (NumPy asks for huge pages; Numba's
allocator does not).
"""

from __future__ import annotations

from concurrent.futures import as_completed

import numba as nb
import numpy as np

from ..common import JIT
from ..threads import thread_pool
from .layout import MAX_LEAF, WIDTH, leaf_code

N_BINS = 16           # SAH bins per axis
TRAVERSAL_COST = 2.0  # SAH: cost of a node visit (4 box tests) relative to one primitive test

@nb.njit(**JIT)
def _area(lx, ly, lz, hx, hy, hz):
    ex, ey, ez = hx - lx, hy - ly, hz - lz
    if ex < 0.0:
        return 0.0
    return ex * ey + ey * ez + ez * ex


@nb.njit(**JIT)
def _child_bounds(ib, first, end, box, c, fstack, slot):
    """box[c] and fstack[slot]: the bounds and centroid bounds of items first..end of ib (lo, hi, centroid rows)."""
    for a in range(3):
        box[c, a] = fstack[slot, a] = np.inf
        box[c, 3 + a] = fstack[slot, 3 + a] = -np.inf
    for j in range(first, end):
        for a in range(3):
            box[c, a] = min(box[c, a], ib[j, a])
            box[c, 3 + a] = max(box[c, 3 + a], ib[j, 3 + a])
            fstack[slot, a] = min(fstack[slot, a], ib[j, 6 + a])
            fstack[slot, 3 + a] = max(fstack[slot, 3 + a], ib[j, 6 + a])


def item_rows(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the build works on for boxes lo/hi (n, 3): ib (n, 9) (per item: lo xyz, hi xyz, centroid xyz; the
    build keeps it in node order), the root's box (6,) and the root's centroid bounds (6,). (items.indexed_items
    makes the same three for a mesh in its own pass over the triangles.)"""
    ib = np.empty((lo.shape[0], 9))  # NumPy's: see node_arrays
    return _item_rows(lo, hi, ib)


@nb.njit(**JIT)
def _item_rows(lo, hi, ib):
    n = lo.shape[0]
    root_box = np.empty(6)
    root_cb = np.empty(6)
    for a in range(3):
        root_cb[a] = root_box[a] = np.inf
        root_cb[3 + a] = root_box[3 + a] = -np.inf
    for i in range(n):
        for a in range(3):
            lo_, hi_ = lo[i, a], hi[i, a]
            c = 0.5 * (lo_ + hi_)
            ib[i, a], ib[i, 3 + a], ib[i, 6 + a] = lo_, hi_, c
            root_box[a] = min(root_box[a], lo_)
            root_box[3 + a] = max(root_box[3 + a], hi_)
            root_cb[a] = min(root_cb[a], c)
            root_cb[3 + a] = max(root_cb[3 + a], c)
    return ib, root_box, root_cb


def node_arrays(n: int, root_box: np.ndarray) -> tuple[np.ndarray, ...]:
    """order (n,) int32 (the item at each position, identity to start) and the node arrays for the 2n - 1
    nodes a binary tree over n items has at most (box (., 6), left, right, start, count), with the root's box
    in row 0. Uninitialised: the build writes each row it links, and rows never linked are never read.
    Allocated by NumPy, not in a kernel: NumPy asks for huge pages for large arrays (madvise), so touching them
    costs a page fault per 2 MB instead of per 4 kB (Numba's allocations got ~40k faults, a fifth of the 1.1M
    bunny's build CPU time, in system time)."""
    rows = max(2 * n - 1, 1)
    box = np.empty((rows, 6))
    box[0] = root_box
    return (np.arange(n, dtype=np.int32), box, np.empty(rows, np.int32), np.empty(rows, np.int32),
            np.empty(rows, np.int32), np.empty(rows, np.int32))


@nb.njit(**JIT)
def build_nodes(ib, order, box, left, right, start, count, root, first, end, root_cb, next_node, max_leaf, defer,
                deferred, deferred_cb):
    """Binned-SAH binary BVH over items first..end of ib/order (item_rows' and node_arrays', partitioned in place),
    its root at node `root` (box[root] already set, centroid bounds root_cb), new nodes numbered from next_node.
    Returns the node number after the last used and the number of nodes deferred.

    Nodes: box, left/right (-1 for leaves), start/count into `order`. Each node bins its items' centroids into
    N_BINS per axis (8 for nodes of under 16 items, 2 per item under 4: as good a tree for less work), sweeps
    the non-empty bins for the cheapest SAH split, and becomes a leaf when that is cheaper (and it holds at most
    max_leaf items; always at 2 items) or no split separates centroids. The items' boxes and centroids are kept
    in node order (moved with the partition), so every pass reads memory contiguously, and each node makes two
    passes over its items: binning, and the partition, which also gives the children their boxes and centroid
    bounds (these ride on the stack until the child is built). With defer > 0, a node (other than the root) of
    at most `defer` items is left unbuilt and listed in deferred (node, first, end) and deferred_cb (its
    centroid bounds), so build_wide_bvh can build it (this same kernel, in place, on another thread: each
    subtree touches only its own items and node rows).
    """
    inf = np.inf
    bins = np.empty((3 * N_BINS, 6))         # per axis a and bin b, row a * N_BINS + b: lo xyz, hi xyz
    bins[:, :3] = inf                        # empty; the sweep empties each bin it used again
    bins[:, 3:] = -inf
    bin_cnt = np.zeros(3 * N_BINS, np.int64)
    nz = np.empty(N_BINS, np.int64)          # one axis's non-empty bins
    right_area = np.empty(N_BINS)
    right_cnt = np.empty(N_BINS, np.int64)
    scale = np.zeros(3)
    stack = np.empty((128, 3), np.int64)   # node, first, end; depth-first keeps the stack at the tree depth
    fstack = np.empty((128, 6))            # each stacked node's centroid bounds
    m = next_node
    stack[0, 0], stack[0, 1], stack[0, 2] = root, first, end
    for a in range(6):
        fstack[0, a] = root_cb[a]
    sp = 1
    n_def = 0
    while sp > 0:
        sp -= 1
        node, first, end = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        cnt = end - first
        start[node] = first
        count[node] = cnt
        left[node] = right[node] = -1
        if cnt <= 1:
            continue
        if node != root and cnt <= defer:
            deferred[n_def, 0], deferred[n_def, 1], deferred[n_def, 2] = node, first, end
            for a in range(6):
                deferred_cb[n_def, a] = fstack[sp, a]
            n_def += 1
            continue
        if cnt <= 2 and cnt <= max_leaf:
            continue  # a leaf: splitting costs 2 visits of this box and more, keeping it 2 tests of it (exact in float)
        nbins = min(N_BINS if cnt >= 16 else 8, max(4, 2 * cnt))  # nodes of under 16 items: 8 bins or fewer
        n_axes = 0
        for a in range(3):
            ext = fstack[sp, 3 + a] - fstack[sp, a]
            scale[a] = nbins * (1.0 - 1e-9) / ext if ext > 0.0 else 0.0
            if ext > 0.0:
                n_axes += 1
        if n_axes == 0:
            if cnt <= 7:
                continue  # coincident centroids: no plane separates them
        else:
            # bin centroids on all three axes in one pass (an axis of no extent bins all in bin 0, unused)
            c0, c1, c2 = fstack[sp, 0], fstack[sp, 1], fstack[sp, 2]
            s0, s1, s2 = scale[0], scale[1], scale[2]
            top = nbins - 1
            for j in range(first, end):
                x0, y0, z0, x1, y1, z1 = ib[j, 0], ib[j, 1], ib[j, 2], ib[j, 3], ib[j, 4], ib[j, 5]
                b0 = min(int((ib[j, 6] - c0) * s0), top)
                b1 = min(int((ib[j, 7] - c1) * s1), top) + N_BINS
                b2 = min(int((ib[j, 8] - c2) * s2), top) + 2 * N_BINS
                for row in (b0, b1, b2):
                    bin_cnt[row] += 1
                    bins[row, 0] = min(bins[row, 0], x0)
                    bins[row, 1] = min(bins[row, 1], y0)
                    bins[row, 2] = min(bins[row, 2], z0)
                    bins[row, 3] = max(bins[row, 3], x1)
                    bins[row, 4] = max(bins[row, 4], y1)
                    bins[row, 5] = max(bins[row, 5], z1)
        # sweep the non-empty bins only (a plane after an empty bin costs what the plane before it does, and the
        # strict < keeps the earlier: the same choice as sweeping every bin, for less work on the many small
        # nodes): right-to-left accumulates the right side, left-to-right evaluates each plane; each bin used is
        # emptied again on the way (bins start empty, see above)
        best_cost = inf
        best_axis = -1
        best_bin = 0
        for a in range(3):
            base = a * N_BINS
            k = 0
            for b in range(nbins):
                if bin_cnt[base + b] > 0:
                    nz[k] = b
                    k += 1
            if scale[a] != 0.0 and k > 1:
                rl0 = rl1 = rl2 = inf
                rh0 = rh1 = rh2 = -inf
                rc = 0
                for q in range(k - 1, 0, -1):
                    bb = bins[base + nz[q]]
                    rl0, rl1, rl2 = min(rl0, bb[0]), min(rl1, bb[1]), min(rl2, bb[2])
                    rh0, rh1, rh2 = max(rh0, bb[3]), max(rh1, bb[4]), max(rh2, bb[5])
                    rc += bin_cnt[base + nz[q]]
                    right_area[q] = _area(rl0, rl1, rl2, rh0, rh1, rh2)
                    right_cnt[q] = rc
                ll0 = ll1 = ll2 = inf
                lh0 = lh1 = lh2 = -inf
                lc = 0
                for q in range(k - 1):
                    bb = bins[base + nz[q]]
                    ll0, ll1, ll2 = min(ll0, bb[0]), min(ll1, bb[1]), min(ll2, bb[2])
                    lh0, lh1, lh2 = max(lh0, bb[3]), max(lh1, bb[4]), max(lh2, bb[5])
                    lc += bin_cnt[base + nz[q]]
                    cost = _area(ll0, ll1, ll2, lh0, lh1, lh2) * lc + right_area[q + 1] * right_cnt[q + 1]
                    if cost < best_cost:
                        best_cost, best_axis, best_bin = cost, a, nz[q]
            for q in range(k):
                row = base + nz[q]
                bin_cnt[row] = 0
                bins[row, 0] = bins[row, 1] = bins[row, 2] = inf
                bins[row, 3] = bins[row, 4] = bins[row, 5] = -inf
        parent_area = _area(box[node, 0], box[node, 1], box[node, 2], box[node, 3], box[node, 4], box[node, 5])
        leaf_cost = parent_area * cnt
        split_cost = parent_area * TRAVERSAL_COST + best_cost
        if best_axis >= 0 and cnt <= max_leaf and leaf_cost <= split_cost:
            continue
        if sp + 2 > stack.shape[0]:
            grown = np.empty((2 * stack.shape[0], 3), np.int64)
            grown_f = np.empty((2 * stack.shape[0], 6))
            for q in range(sp + 1):  # element by element: an array assignment compiles ~5 s of error formatting
                grown[q, 0], grown[q, 1], grown[q, 2] = stack[q, 0], stack[q, 1], stack[q, 2]
                for a in range(6):
                    grown_f[q, a] = fstack[q, a]
            stack, fstack = grown, grown_f
        l, r = m, m + 1
        m += 2
        left[node], right[node] = l, r
        # the children go on the stack in the parent's place (sp: right, sp + 1: left, built first)
        if best_axis < 0:
            mid = first + cnt // 2  # too many coincident centroids to keep together: split the list in half
            _child_bounds(ib, mid, end, box, r, fstack, sp)
            _child_bounds(ib, first, mid, box, l, fstack, sp + 1)
        else:
            # partition the items by bin (in this order: a later halving split and the leaves' order follow it);
            # the children's boxes and centroid bounds grow in registers as each item is placed
            al0 = al1 = al2 = acl0 = acl1 = acl2 = inf
            ah0 = ah1 = ah2 = ach0 = ach1 = ach2 = -inf
            bl0 = bl1 = bl2 = bcl0 = bcl1 = bcl2 = inf
            bh0 = bh1 = bh2 = bch0 = bch1 = bch2 = -inf
            a = best_axis
            i = first
            k = end - 1
            lo_a = fstack[sp, a]
            sc = scale[a]
            top = nbins - 1
            while i <= k:
                x0, y0, z0, x1, y1, z1 = ib[i, 0], ib[i, 1], ib[i, 2], ib[i, 3], ib[i, 4], ib[i, 5]
                cx, cy, cz = ib[i, 6], ib[i, 7], ib[i, 8]
                if min(int((ib[i, 6 + a] - lo_a) * sc), top) <= best_bin:
                    al0, al1, al2 = min(al0, x0), min(al1, y0), min(al2, z0)
                    ah0, ah1, ah2 = max(ah0, x1), max(ah1, y1), max(ah2, z1)
                    acl0, acl1, acl2 = min(acl0, cx), min(acl1, cy), min(acl2, cz)
                    ach0, ach1, ach2 = max(ach0, cx), max(ach1, cy), max(ach2, cz)
                    i += 1
                else:
                    bl0, bl1, bl2 = min(bl0, x0), min(bl1, y0), min(bl2, z0)
                    bh0, bh1, bh2 = max(bh0, x1), max(bh1, y1), max(bh2, z1)
                    bcl0, bcl1, bcl2 = min(bcl0, cx), min(bcl1, cy), min(bcl2, cz)
                    bch0, bch1, bch2 = max(bch0, cx), max(bch1, cy), max(bch2, cz)
                    for q in range(9):
                        ib[i, q] = ib[k, q]
                    ib[k, 0], ib[k, 1], ib[k, 2], ib[k, 3], ib[k, 4], ib[k, 5] = x0, y0, z0, x1, y1, z1
                    ib[k, 6], ib[k, 7], ib[k, 8] = cx, cy, cz
                    order[i], order[k] = order[k], order[i]
                    k -= 1
            mid = i
            box[l, 0], box[l, 1], box[l, 2], box[l, 3], box[l, 4], box[l, 5] = al0, al1, al2, ah0, ah1, ah2
            box[r, 0], box[r, 1], box[r, 2], box[r, 3], box[r, 4], box[r, 5] = bl0, bl1, bl2, bh0, bh1, bh2
            fstack[sp, 0], fstack[sp, 1], fstack[sp, 2] = bcl0, bcl1, bcl2
            fstack[sp, 3], fstack[sp, 4], fstack[sp, 5] = bch0, bch1, bch2
            q = sp + 1
            fstack[q, 0], fstack[q, 1], fstack[q, 2] = acl0, acl1, acl2
            fstack[q, 3], fstack[q, 4], fstack[q, 5] = ach0, ach1, ach2
        stack[sp, 0], stack[sp, 1], stack[sp, 2] = r, mid, end
        stack[sp + 1, 0], stack[sp + 1, 1], stack[sp + 1, 2] = l, first, mid
        sp += 2
    return m, n_def


def build_bvh2(lo: np.ndarray, hi: np.ndarray, max_leaf: int = MAX_LEAF) -> tuple[np.ndarray, ...]:
    """The whole binary tree over boxes lo/hi (n, 3) on this thread (the serial build, for profiles): box, left,
    right, start, count (m rows: the build_nodes arrays above) and order (the item at each leaf position)."""
    ib, root_box, root_cb = item_rows(lo, hi)
    order, box, left, right, start, count = node_arrays(lo.shape[0], root_box)
    none = np.empty((0, 3), np.int64)
    m, _ = build_nodes(ib, order, box, left, right, start, count, 0, 0, lo.shape[0], root_cb, 1, max_leaf, 0,
                       none, np.empty((0, 6)))
    return box[:m], left[:m], right[:m], start[:m], count[:m], order


_NORMAL_ABOVE = np.float32(1.1754944e-38)  # the smallest normal float32: below the binade below has its spacing
_HUGE = np.float32(2.0**127)
_SHRINK = np.float32(1.0 - 2.0**-24)       # the largest float32 below 1


@nb.njit(**JIT, inline="always")
def _step_down(y):
    """np.nextafter(y, -inf) for a float32 y, to the bit, by one rounded float32 product or quotient where y is
    normal (y (1 - 2^-24) lies between y's neighbour below and half way to it, or on it for a power of two, and
    rounds to it; y / (1 - 2^-24) likewise to the neighbour of a negative y): libm's call took 6 ns, 29 of the
    1.1M bunny's 49 ms of collapse_bvh4. Checked against np.nextafter on every float32."""
    a = abs(y)
    if a > _NORMAL_ABOVE and a < _HUGE:
        return y * _SHRINK if y > 0 else y / _SHRINK
    return np.nextafter(y, np.float32(-np.inf))


def collapse_bvh4(box: np.ndarray, left: np.ndarray, right: np.ndarray, start: np.ndarray,
                  count: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Turn a binary BVH into the 4-wide layout described at the top: each wide node takes up to four
    grandchildren, opening the largest-area inner child first. Returns bounds, child and the tree depth.
    Each wide node but a lone leaf root is made from a distinct inner binary node, so that many rows suffice;
    they are NumPy's (huge pages: see node_arrays)."""
    rows = max(int(np.count_nonzero(left >= 0)), 1)
    bounds = np.empty((rows, 6, WIDTH), np.float32)
    child = np.empty((rows, WIDTH), np.int32)
    nw, depth = _collapse(box, left, right, start, count, bounds, child, np.empty(rows, np.int64),
                          np.empty(rows, np.int64))
    if nw < rows:
        bounds, child = bounds[:nw].copy(), child[:nw].copy()
    return bounds, child, depth


@nb.njit(**JIT)
def _collapse(box, left, right, start, count, bounds, child, src, depth):
    """collapse_bvh4 into bounds and child; src and depth: scratch (the binary node each wide node was made
    from, its depth). Returns the number of wide nodes and the tree depth."""
    m = box.shape[0]
    src[0] = 0
    depth[0] = 0
    nw = 1
    max_depth = 1
    slots = np.empty(WIDTH, np.int64)
    w = 0
    while w < nw:
        s = src[w]
        ns = 0
        if m == 0:
            pass
        elif left[s] < 0:       # a tree that is a single leaf: the root holds it in lane 0
            slots[0] = s
            ns = 1
        else:
            slots[0], slots[1] = left[s], right[s]
            ns = 2
            while ns < WIDTH:
                best = -1
                best_area = -1.0
                for k in range(ns):
                    q = slots[k]
                    if left[q] >= 0:
                        ar = _area(box[q, 0], box[q, 1], box[q, 2], box[q, 3], box[q, 4], box[q, 5])
                        if ar > best_area:
                            best_area, best = ar, k
                if best < 0:
                    break
                q = slots[best]
                slots[best] = left[q]
                slots[ns] = right[q]
                ns += 1
        for lane in range(WIDTH):
            if lane < ns:
                q = slots[lane]
                if count[q] == 0:  # an empty tree's root
                    for a in range(6):
                        bounds[w, a, lane] = np.inf
                    child[w, lane] = 0
                    continue
                for a in range(3):
                    bounds[w, a, lane] = _step_down(np.float32(box[q, a]))
                    bounds[w, 3 + a, lane] = -_step_down(-np.float32(box[q, 3 + a]))
                if left[q] < 0:
                    child[w, lane] = leaf_code(start[q], count[q])
                else:
                    child[w, lane] = nw
                    src[nw] = q
                    depth[nw] = depth[w] + 1
                    if depth[nw] + 1 > max_depth:
                        max_depth = depth[nw] + 1
                    nw += 1
            else:
                for a in range(6):
                    bounds[w, a, lane] = np.inf  # a box at infinity: every slab test misses it
                child[w, lane] = 0
        w += 1
    return nw, max_depth


PARALLEL_BUILD = 32_000  # items from which build_wide_bvh builds subtrees on several threads (the bunny, 69k, is)


def build_wide_bvh(lo: np.ndarray, hi: np.ndarray, max_leaf: int = MAX_LEAF):
    """Build the 4-wide BVH over boxes lo/hi (n, 3): (bounds, child, order, depth); see the module docstring.

    Large inputs on several threads (_build_threaded): the top of the tree is built (the root's two children's
    tops concurrently) until its open nodes hold at most n / (4 threads) items each; those subtrees are then
    built concurrently, in place (each on its own items' rows of
    the shared item arrays, its nodes at rows reserved for it: 2k - 2 for k items; rows left unused are never
    linked, and collapse_bvh4 follows links only). Each subtree sees its items in the order the serial build
    would, so the tree is the same as the serial one's.
    """
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    hi = np.ascontiguousarray(hi, dtype=np.float64)
    return build_wide_bvh_rows(*item_rows(lo, hi), max_leaf)


def build_wide_bvh_rows(ib: np.ndarray, root_box: np.ndarray, root_cb: np.ndarray, max_leaf: int = MAX_LEAF):
    """build_wide_bvh over item rows already made (item_rows' three arrays, or items.indexed_items'); ib is
    reordered in place."""
    n = ib.shape[0]
    threads = nb.get_num_threads()
    order, box, left, right, start, count = node_arrays(n, root_box)
    arrays = (ib, order, box, left, right, start, count)
    if n < PARALLEL_BUILD or threads < 2:
        m, _ = build_nodes(*arrays, 0, 0, n, root_cb, 1, max_leaf, 0, np.empty((0, 3), np.int64), np.empty((0, 6)))
    else:
        m = _build_threaded(arrays, n, root_cb, max_leaf, threads)
    bounds, child, depth = collapse_bvh4(box[:m], left[:m], right[:m], start[:m], count[:m])
    return bounds, child, order, int(depth)


def _build_threaded(arrays: tuple, n: int, root_cb: np.ndarray, max_leaf: int, threads: int) -> int:
    """build_wide_bvh_rows' tree on `threads` threads: the root alone, then each of its two children's tops (down
    to nodes of n / (4 threads) items) on a thread of its own, then, as each top is done, its subtrees. Every
    node's rows are reserved below its parent's: 2k - 2 for a node of k items, which is what any binary tree over
    them uses (a top with d unbuilt nodes and e one-item leaves uses 2(d + e) - 2 rows, its subtrees of s_i
    items 2 s_i - 2 each). Returns the rows used (some unlinked)."""
    pool = thread_pool(threads)
    none = np.empty((0, 3), np.int64), np.empty((0, 6))
    halves, halves_cb = np.empty((2, 3), np.int64), np.empty((2, 6))
    m, n_half = build_nodes(*arrays, 0, 0, n, root_cb, 1, max_leaf, n - 1, halves, halves_cb)
    sizes = halves[:n_half, 2] - halves[:n_half, 1]
    starts = m + np.concatenate([[0], np.cumsum(2 * sizes - 2)])

    def top(k: int) -> tuple[int, np.ndarray, np.ndarray]:
        node, first, end = (int(x) for x in halves[k])
        deferred, deferred_cb = np.empty((end - first, 3), np.int64), np.empty((end - first, 6))
        used, n_def = build_nodes(*arrays, node, first, end, halves_cb[k], int(starts[k]), max_leaf,
                                  n // (4 * threads), deferred, deferred_cb)
        return used, deferred[:n_def], deferred_cb[:n_def]

    futures = []
    for done in as_completed([pool.submit(top, k) for k in range(n_half)]):
        used, deferred, deferred_cb = done.result()
        sub = deferred[:, 2] - deferred[:, 1]
        offsets = used + np.concatenate([[0], np.cumsum(2 * sub - 2)])
        for k in np.argsort(-sub, kind="stable"):  # the largest first
            node, first, end = (int(x) for x in deferred[k])
            futures.append(pool.submit(build_nodes, *arrays, node, first, end, deferred_cb[k], int(offsets[k]),
                                       max_leaf, 0, *none))
    for f in futures:
        f.result()
    return int(starts[-1])
