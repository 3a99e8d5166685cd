"""Bounding volume hierarchy: binned-SAH build and closest/any/all-hit traversal (Numba).

Layout (measured fastest of the variants tried, see benchmarks/README.md): a 4-wide BVH whose nodes hold their
children's boxes, float32, structure of arrays, so one node visit tests four boxes from one 96-byte block:

    bounds[node, row, lane]  float32 (N, 6, 4), rows = lo x, lo y, lo z, hi x, hi y, hi z (rounded outwards)
    child[node, lane]        int32   (N, 4):  > 0 inner node, 0 empty slot (its box sits at +inf),
                                              < 0 leaf = -(start * 8 + count) - 1

Node 0 is the root of the first tree, so 0 never names a child. A leaf's items are slots start..start+count of
the leaf arrays, stored in leaf order so a leaf reads one contiguous block:

    leaf_prim[slot]  int32: >= 0 triangle id, < 0 sphere -(s + 1) into the sphere arrays
    leaf_tri[slot]   float64 (9,): the triangle's vertices (unused for spheres)

Boxes are float32 to halve the traversal's memory traffic; the slab test itself runs in float64 against boxes
rounded outwards, with the far distance widened by a few ulps (Ize 2013), so rounding never culls a real hit.
Several trees (one per mesh) can share these arrays; a second, top-level tree over instances then gives the
two-level BVH of `query.py`: a mesh used twice is stored once.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .intersect import ray_shear, shear_axes, sphere_hit_in_object_space, watertight_triangle

TRIANGLE, SPHERE = 1, 2
MAX_LEAF = 4          # items per leaf (the build may go up to 7 when all centroids coincide)
N_BINS = 16           # SAH bins per axis
TRAVERSAL_COST = 2.0  # SAH: cost of a node visit (4 box tests) relative to one primitive test
FAR_WIDEN = 1e-15     # relative widening of the slab test's far distance: covers float64 rounding
RAY_CHUNK = 64        # rays per parallel work item: neighbouring (coherent) rays share a thread's cache
BLOCK = 8             # packets per parallel work item of the one-level kernels (amortises the scratch)

JIT = dict(cache=True, error_model="numpy", nogil=True)


# ----------------------------------------------------------------------------------------------------------- build

@nb.njit(**JIT)
def _area(lx, ly, lz, hx, hy, hz):
    ex, ey, ez = hx - lx, hy - ly, hz - lz
    if ex < 0.0:
        return 0.0
    return ex * ey + ey * ez + ez * ex


@nb.njit(**JIT)
def item_boxes(tris, sphere_lo, sphere_hi):
    """Boxes (n, 3) lo and hi of the triangles (F, 9) followed by the spheres' boxes (S, 3)."""
    f = tris.shape[0]
    n = f + sphere_lo.shape[0]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for i in range(f):
        for a in range(3):
            x, y, z = tris[i, a], tris[i, 3 + a], tris[i, 6 + a]
            lo[i, a] = min(x, y, z)
            hi[i, a] = max(x, y, z)
    for i in range(f, n):
        for a in range(3):
            lo[i, a] = sphere_lo[i - f, a]
            hi[i, a] = sphere_hi[i - f, a]
    return lo, hi


@nb.njit(**JIT)
def leaf_items(tris, order):
    """leaf_prim (triangle id, or -(sphere + 1)) and leaf_tri (the triangle's 9 coordinates, zeros for a
    sphere) in leaf order."""
    f = tris.shape[0]
    n = order.shape[0]
    leaf_prim = np.empty(n, np.int32)
    leaf_tri = np.zeros((n, 9))
    for j in range(n):
        p = order[j]
        if p < f:
            leaf_prim[j] = p
            for q in range(9):
                leaf_tri[j, q] = tris[p, q]
        else:
            leaf_prim[j] = -(p - f) - 1
    return leaf_prim, leaf_tri


@nb.njit(**JIT)
def build_bvh2(lo, hi, max_leaf, defer):
    """Binned-SAH binary BVH over boxes lo/hi (n, 3). Returns node arrays, the item order and the deferred nodes.

    Nodes: box (m, 6) float64, left/right (m,) int32 (-1 for leaves), start/count (m,) int32 into `order`.
    Each node bins its items' centroids into N_BINS per axis (fewer, 2 per item, for nodes of under 8 items),
    sweeps the bins for the cheapest SAH split, and becomes a leaf when that is cheaper (and it holds at most
    max_leaf items) or no split separates centroids.
    The items' boxes and centroids are kept in node order (moved with the partition), so every pass reads
    memory contiguously, and each node makes two passes over its items: binning, and the partition, which also
    gives the children their boxes and centroid bounds.
    With defer > 0, a node (other than the root) of at most `defer` items is left unbuilt and listed in the
    returned (k, 3) array as (node, first, end), so build_wide_bvh can build those subtrees on other threads.
    """
    n = lo.shape[0]
    cap = max(2 * n, 1)
    box = np.empty((cap, 6))
    left = np.full(cap, -1, np.int32)
    right = np.full(cap, -1, np.int32)
    start = np.zeros(cap, np.int32)
    count = np.zeros(cap, np.int32)
    order = np.arange(n).astype(np.int32)
    ib = np.empty((n, 9))       # per item, in node order: lo xyz, hi xyz, centroid xyz
    cb = np.empty((cap, 6))     # per node: centroid bounds
    for a in range(6):
        cb[0, a] = np.inf if a < 3 else -np.inf
        box[0, a] = np.inf if a < 3 else -np.inf
    for i in range(n):
        for a in range(3):
            lo_, hi_ = lo[i, a], hi[i, a]
            c = 0.5 * (lo_ + hi_)
            ib[i, a], ib[i, 3 + a], ib[i, 6 + a] = lo_, hi_, c
            box[0, a] = min(box[0, a], lo_)
            box[0, 3 + a] = max(box[0, 3 + a], hi_)
            cb[0, a] = min(cb[0, a], c)
            cb[0, 3 + a] = max(cb[0, 3 + a], c)

    bin_box = np.empty((3, N_BINS, 6))
    bin_cnt = np.zeros((3, N_BINS), np.int64)
    right_area = np.empty(N_BINS)
    right_cnt = np.empty(N_BINS, np.int64)
    scale = np.zeros(3)
    tmp = np.empty(9)
    stack = np.empty((128, 3), np.int64)   # node, first, end; depth-first keeps the stack at the tree depth
    m = 1
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, n
    sp = 1
    deferred = np.empty((cap if defer > 0 else 0, 3), np.int64)
    n_def = 0
    while sp > 0:
        sp -= 1
        node, first, end = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        cnt = end - first
        start[node] = first
        count[node] = cnt
        if cnt <= 1:
            continue
        if node != 0 and cnt <= defer:
            deferred[n_def, 0], deferred[n_def, 1], deferred[n_def, 2] = node, first, end
            n_def += 1
            continue
        nbins = min(N_BINS, max(4, 2 * cnt))  # small nodes: fewer bins, as good a split for less work
        # bin centroids on all three axes in one pass
        bin_cnt[:, :] = 0
        for a in range(3):
            for b in range(nbins):
                for k in range(3):
                    bin_box[a, b, k] = np.inf
                    bin_box[a, b, 3 + k] = -np.inf
        n_axes = 0
        for a in range(3):
            ext = cb[node, 3 + a] - cb[node, a]
            scale[a] = nbins * (1.0 - 1e-9) / ext if ext > 0.0 else 0.0
            if ext > 0.0:
                n_axes += 1
        if n_axes == 0:
            if cnt <= 7:
                continue  # coincident centroids: no plane separates them
        else:
            for j in range(first, end):
                for a in range(3):
                    if scale[a] == 0.0:
                        continue
                    b = int((ib[j, 6 + a] - cb[node, a]) * scale[a])
                    if b >= nbins:
                        b = nbins - 1
                    bin_cnt[a, b] += 1
                    for k in range(3):
                        bin_box[a, b, k] = min(bin_box[a, b, k], ib[j, k])
                        bin_box[a, b, 3 + k] = max(bin_box[a, b, 3 + k], ib[j, 3 + k])
        # sweep: right-to-left accumulates the right side, left-to-right evaluates each of the nbins-1 planes
        best_cost = np.inf
        best_axis = -1
        best_bin = 0
        for a in range(3):
            if scale[a] == 0.0:
                continue
            rl0 = rl1 = rl2 = np.inf
            rh0 = rh1 = rh2 = -np.inf
            rc = 0
            for b in range(nbins - 1, 0, -1):
                bb = bin_box[a, b]
                rl0, rl1, rl2 = min(rl0, bb[0]), min(rl1, bb[1]), min(rl2, bb[2])
                rh0, rh1, rh2 = max(rh0, bb[3]), max(rh1, bb[4]), max(rh2, bb[5])
                rc += bin_cnt[a, b]
                right_area[b] = _area(rl0, rl1, rl2, rh0, rh1, rh2)
                right_cnt[b] = rc
            ll0 = ll1 = ll2 = np.inf
            lh0 = lh1 = lh2 = -np.inf
            lc = 0
            for b in range(nbins - 1):
                bb = bin_box[a, b]
                ll0, ll1, ll2 = min(ll0, bb[0]), min(ll1, bb[1]), min(ll2, bb[2])
                lh0, lh1, lh2 = max(lh0, bb[3]), max(lh1, bb[4]), max(lh2, bb[5])
                lc += bin_cnt[a, b]
                if lc == 0 or right_cnt[b + 1] == 0:
                    continue
                cost = _area(ll0, ll1, ll2, lh0, lh1, lh2) * lc + right_area[b + 1] * right_cnt[b + 1]
                if cost < best_cost:
                    best_cost, best_axis, best_bin = cost, a, b
        parent_area = _area(box[node, 0], box[node, 1], box[node, 2], box[node, 3], box[node, 4], box[node, 5])
        leaf_cost = parent_area * cnt
        split_cost = parent_area * TRAVERSAL_COST + best_cost
        if best_axis >= 0 and cnt <= max_leaf and leaf_cost <= split_cost:
            continue
        l, r = m, m + 1
        m += 2
        left[node], right[node] = l, r
        for a in range(3):
            box[l, a] = box[r, a] = cb[l, a] = cb[r, a] = np.inf
            box[l, 3 + a] = box[r, 3 + a] = cb[l, 3 + a] = cb[r, 3 + a] = -np.inf
        if best_axis < 0:
            mid = first + cnt // 2  # too many coincident centroids to keep together: split the list in half
        else:
            # partition the items by bin; the children's boxes are the unions of their bins
            a = best_axis
            i = first
            k = end - 1
            lo_a = cb[node, a]
            sc = scale[a]
            while i <= k:
                b = int((ib[i, 6 + a] - lo_a) * sc)
                if b >= nbins:
                    b = nbins - 1
                c = l if b <= best_bin else r
                for q in range(3):
                    box[c, q] = min(box[c, q], ib[i, q])
                    box[c, 3 + q] = max(box[c, 3 + q], ib[i, 3 + q])
                    cb[c, q] = min(cb[c, q], ib[i, 6 + q])
                    cb[c, 3 + q] = max(cb[c, 3 + q], ib[i, 6 + q])
                if b <= best_bin:
                    i += 1
                else:
                    for q in range(9):
                        tmp[q] = ib[i, q]
                    for q in range(9):
                        ib[i, q] = ib[k, q]
                    for q in range(9):
                        ib[k, q] = tmp[q]
                    order[i], order[k] = order[k], order[i]
                    k -= 1
            mid = i
        if best_axis < 0:
            for j in range(first, end):
                c = l if j < mid else r
                for a in range(3):
                    box[c, a] = min(box[c, a], ib[j, a])
                    box[c, 3 + a] = max(box[c, 3 + a], ib[j, 3 + a])
                    cb[c, a] = min(cb[c, a], ib[j, 6 + a])
                    cb[c, 3 + a] = max(cb[c, 3 + a], ib[j, 6 + a])
        if sp + 2 > stack.shape[0]:
            grown = np.empty((2 * stack.shape[0], 3), np.int64)
            for q in range(sp):  # element by element: an array assignment compiles ~5 s of error formatting
                grown[q, 0], grown[q, 1], grown[q, 2] = stack[q, 0], stack[q, 1], stack[q, 2]
            stack = grown
        stack[sp, 0], stack[sp, 1], stack[sp, 2] = r, mid, end
        stack[sp + 1, 0], stack[sp + 1, 1], stack[sp + 1, 2] = l, first, mid
        sp += 2
    return box[:m], left[:m], right[:m], start[:m], count[:m], order, deferred[:n_def]


@nb.njit(**JIT)
def collapse_bvh4(box, left, right, start, count):
    """Turn a binary BVH into the 4-wide layout described at the top: each wide node takes up to four
    grandchildren, opening the largest-area inner child first. Returns bounds, child and the tree depth."""
    m = box.shape[0]
    bounds = np.empty((max(m, 1), 6, 4), np.float32)
    child = np.zeros((max(m, 1), 4), np.int32)
    src = np.empty(max(m, 1), np.int64)    # the binary node each wide node was made from
    depth = np.zeros(max(m, 1), np.int64)
    src[0] = 0
    nw = 1
    max_depth = 1
    slots = np.empty(4, np.int64)
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
            while ns < 4:
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
        for lane in range(4):
            if lane < ns:
                q = slots[lane]
                if count[q] == 0:  # an empty tree's root
                    for a in range(6):
                        bounds[w, a, lane] = np.inf
                    child[w, lane] = 0
                    continue
                for a in range(3):
                    bounds[w, a, lane] = np.nextafter(np.float32(box[q, a]), np.float32(-np.inf))
                    bounds[w, 3 + a, lane] = np.nextafter(np.float32(box[q, 3 + a]), np.float32(np.inf))
                if left[q] < 0:
                    child[w, lane] = -(start[q] * 8 + count[q]) - 1
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
    return bounds[:nw].copy(), child[:nw].copy(), max_depth


# ------------------------------------------------------------------------------------------------------- traversal

@nb.njit(**JIT, inline="always")
def ray_setup(ox, oy, oz, dx, dy, dz):
    """Per-ray constants: reciprocal direction and near-plane row offsets for the slab tests (by direction
    sign), and the shear of the triangle test. A zero direction component becomes 1e-300 for the slabs only,
    so (lo - o) / d is never 0 * inf = NaN."""
    idx = 1.0 / (dx if dx != 0.0 else 1e-300)
    idy = 1.0 / (dy if dy != 0.0 else 1e-300)
    idz = 1.0 / (dz if dz != 0.0 else 1e-300)
    nrx = 0 if idx >= 0.0 else 12
    nry = 4 if idy >= 0.0 else 16
    nrz = 8 if idz >= 0.0 else 20
    kx, ky, kz, sx, sy, sz = ray_shear(dx, dy, dz)
    o = (ox, oy, oz)
    return idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, o[kx], o[ky], o[kz]


@nb.njit(**JIT, inline="always")
def _lane(bounds, base, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi):
    """Entry distance into the box at flat offset `base` (a lane of a node), or inf if it misses [t_lo, t_hi].
    The near plane of each slab is picked by the direction's sign, so no min/max per slab is needed."""
    tn = t_lo
    tf = t_hi
    a = (bounds[base + nrx] - ox) * idx
    b = (bounds[base + 12 - nrx] - ox) * idx
    tn = a if a > tn else tn
    tf = b if b < tf else tf
    a = (bounds[base + nry] - oy) * idy
    b = (bounds[base + 20 - nry] - oy) * idy
    tn = a if a > tn else tn
    tf = b if b < tf else tf
    a = (bounds[base + nrz] - oz) * idz
    b = (bounds[base + 28 - nrz] - oz) * idz
    tn = a if a > tn else tn
    tf = b if b < tf else tf
    return tn if tn <= tf + abs(tf) * FAR_WIDEN else np.inf


@nb.njit(**JIT, inline="always")
def node_dists(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi, dist):
    """dist[lane] = entry distance of the ray into child box `lane` of `node`, inf if it misses [t_lo, t_hi].

    bounds is the flat float32 node array (24 floats a node: rows lo x, y, z, hi x, y, z of 4 lanes each).
    Empty lanes hold a box at +infinity and so always miss. (A min/max form with constant indices, written
    for LLVM's SLP vectoriser, was not vectorised and measured slower.)
    """
    base = node * 24
    for lane in range(4):
        dist[lane] = _lane(bounds, base + lane, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi)


@nb.njit(**JIT, inline="always")
def push_nearest_first(dist, codes, stack_node, stack_t, sp):
    """Order the lanes a node visit hit by entry distance (a 5-exchange sorting network); push all but the
    nearest, farthest first, and return (nearest child code or 0 if none was hit, new stack pointer)."""
    d0, d1, d2, d3 = dist[0], dist[1], dist[2], dist[3]
    l0, l1, l2, l3 = 0, 1, 2, 3
    if d1 < d0:
        d0, d1, l0, l1 = d1, d0, l1, l0
    if d3 < d2:
        d2, d3, l2, l3 = d3, d2, l3, l2
    if d2 < d0:
        d0, d2, l0, l2 = d2, d0, l2, l0
    if d3 < d1:
        d1, d3, l1, l3 = d3, d1, l3, l1
    if d2 < d1:
        d1, d2, l1, l2 = d2, d1, l2, l1
    if d0 == np.inf:
        return 0, sp
    if d3 < np.inf:
        stack_node[sp] = codes[l3]
        stack_t[sp] = d3
        sp += 1
    if d2 < np.inf:
        stack_node[sp] = codes[l2]
        stack_t[sp] = d2
        sp += 1
    if d1 < np.inf:
        stack_node[sp] = codes[l1]
        stack_t[sp] = d1
        sp += 1
    return codes[l0], sp


@nb.njit(**JIT)
def blas_closest(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                 ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, stack_t, dist):
    """Closest hit in one tree: (t, kind, prim, u, v) with t = inf, kind 0 when nothing is hit before t_max.

    bounds float32 flat (N*24,), child int32 (N, 4), leaf_tri float64 flat (M*9,). Children are visited
    nearest entry first; the others wait on the stack with their entry distance and are dropped when a closer
    hit has been found meanwhile. stack_node, stack_t and dist (4,) are the caller's scratch.
    """
    best = t_max
    kind = 0
    prim = -1
    bu = 0.0
    bv = 0.0
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    sp = 0
    node = root
    while True:
        if node >= 0:
            node_dists(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, best, dist)
            nxt, sp = push_nearest_first(dist, child[node], stack_node, stack_t, sp)
            if nxt != 0:
                node = nxt
                continue
        else:
            v = -node - 1
            first = v >> 3
            for j in range(first, first + (v & 7)):
                p = leaf_prim[j]
                if p >= 0:
                    t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz,
                                                  t_min, best)
                    if t < best:
                        best, kind, prim, bu, bv = t, TRIANGLE, p, u, w
                else:
                    s = -p - 1
                    t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s],
                                                   sph_w2o[s], t_min, best)
                    if t < best:
                        best, kind, prim, bu, bv = t, SPHERE, s, 0.0, 0.0
        # pop the next subtree that can still hold a closer hit
        node = 0
        while sp > 0:
            sp -= 1
            if stack_t[sp] <= best:
                node = stack_node[sp]
                break
        if node == 0:
            break
    if kind == 0:
        best = np.inf
    return best, kind, prim, bu, bv


@nb.njit(**JIT)
def blas_any(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
             ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, dist):
    """True as soon as anything is hit with t_min < t < t_max (no ordering: the first hit ends the search)."""
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    stack_node[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        if node >= 0:
            node_dists(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max, dist)
            for lane in range(4):
                if dist[lane] < np.inf:
                    stack_node[sp] = child[node, lane]
                    sp += 1
        else:
            v = -node - 1
            first = v >> 3
            for j in range(first, first + (v & 7)):
                p = leaf_prim[j]
                if p >= 0:
                    t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz,
                                                  t_min, t_max)
                else:
                    s = -p - 1
                    t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s],
                                                   sph_w2o[s], t_min, t_max)
                if t < np.inf:
                    return True
    return False


@nb.njit(**JIT)
def blas_all(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
             ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, dist,
             out_t, out_prim, out_kind, out_u, out_v, n_out):
    """Every hit with t_min < t < t_max (a sphere counts twice when both roots are in range), appended to the
    out_* arrays from n_out on while they have room. Returns the new count, which may exceed the arrays'
    length: the caller then sizes them from the count and calls again."""
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    cap = out_t.shape[0]
    stack_node[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        if node >= 0:
            node_dists(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max, dist)
            for lane in range(4):
                if dist[lane] < np.inf:
                    stack_node[sp] = child[node, lane]
                    sp += 1
            continue
        v = -node - 1
        first = v >> 3
        for j in range(first, first + (v & 7)):
            p = leaf_prim[j]
            if p >= 0:
                t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz,
                                              t_min, t_max)
                if t < np.inf:
                    if n_out < cap:
                        out_t[n_out], out_prim[n_out], out_kind[n_out] = t, p, TRIANGLE
                        out_u[n_out], out_v[n_out] = u, w
                    n_out += 1
                continue
            s = -p - 1
            lo = t_min
            for _ in range(2):  # near root, then the far root beyond it
                t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s],
                                               sph_w2o[s], lo, t_max)
                if t == np.inf:
                    break
                if n_out < cap:
                    out_t[n_out], out_prim[n_out], out_kind[n_out] = t, s, SPHERE
                    out_u[n_out], out_v[n_out] = 0.0, 0.0
                n_out += 1
                lo = t
    return n_out


@nb.njit(**JIT)
def _planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, t_min, best):
    """Closest unbounded plane: (t, plane index) with t = best, index -1 if none is closer."""
    prim = -1
    for k in range(pl_offset.shape[0]):
        nx, ny, nz = pl_normal[k, 0], pl_normal[k, 1], pl_normal[k, 2]
        denom = nx * dx + ny * dy + nz * dz
        if denom == 0.0:
            continue
        t = (pl_offset[k] - (nx * ox + ny * oy + nz * oz)) / denom
        if t_min < t < best:
            best = t
            prim = k
    return best, prim


# ------------------------------------------------------------------------------------------------- ray packets
#
# Coherent rays (a chunk of PACKET rays whose directions share their signs and the watertight test's axis
# permutation, as camera and shadow rays do; consecutive rays, or a 4 x 4 tile of an image) are traversed
# together: a node visit tests each child box once for the whole packet, with interval bounds over the packet's
# origins and reciprocal directions that no ray's own slab test can beat (so nothing is culled that the one-ray
# path would enter), and a leaf's triangles are tested against all its rays in a loop that LLVM vectorises
# (AVX2: 4 float64 rays an instruction). Every ray does exactly the arithmetic of the one-ray path's watertight
# test with the same constants, so t, u, v agree to the bit; only the visit order differs, which can change the
# primitive named on an exact tie in t.
# Scratch rows of `rr` (float64, (_NROW, PACKET)):
(_OX, _OY, _OZ, _IX, _IY, _IZ, _TMIN, _BEST, _OKX, _OKY, _OKZ, _SX, _SY, _SZ, _E1, _E2, _DET, _DX, _DY, _DZ,
 _PRIM) = range(21)
_NROW = 21
TILE = 4              # an image's rays are traced in TILE x TILE packets
PACKET = TILE * TILE


@nb.njit(**JIT, inline="always")
def chunk_rays(c, n, width, idx):
    """The rays of chunk c into idx; returns how many. width = 0: rays c * PACKET onwards, in order. width > 0
    (the rays are an image `width` wide, both sides multiples of TILE): the TILE x TILE tile c, row by row,
    whose rays are closer together than a 16 x 1 strip's, so a packet visits fewer nodes. (8 x 8 tiles of 64
    rays measured slower: more rays test each leaf.)"""
    if width == 0:
        i0 = c * PACKET
        m = min(n, i0 + PACKET) - i0
        for k in range(m):
            idx[k] = i0 + k
        return m
    tiles = width // TILE
    ty = c // tiles
    tx = c - ty * tiles
    for k in range(PACKET):
        idx[k] = (TILE * ty + k // TILE) * width + TILE * tx + k % TILE
    return PACKET


@nb.njit(**JIT)
def packet_setup(origins, directions, t_min, t_max, idx, n, rr):
    """Load rays idx[:n] into the scratch rows (padding rays never hit) and return (coherent, nrx, nry, nrz,
    kx, ky, kz): coherent when all n rays share direction signs and axis permutation. Only then are the
    per-ray constants computed (in a loop over rays that vectorises, with ray_setup's exact operations)."""
    i0 = idx[0]
    kx0, ky0, kz0 = shear_axes(directions[i0, 0], directions[i0, 1], directions[i0, 2])
    s0 = (directions[i0, 0] < 0.0) + 2 * (directions[i0, 1] < 0.0) + 4 * (directions[i0, 2] < 0.0)
    coherent = True
    for k in range(PACKET):
        i = idx[k] if k < n else i0
        dx, dy, dz = directions[i, 0], directions[i, 1], directions[i, 2]
        kx, ky, kz = shear_axes(dx, dy, dz)
        sgn = (dx < 0.0) + 2 * (dy < 0.0) + 4 * (dz < 0.0)
        if sgn != s0 or kx != kx0 or ky != ky0 or kz != kz0:
            coherent = False
            break
        rr[_OX, k], rr[_OY, k], rr[_OZ, k] = origins[i, 0], origins[i, 1], origins[i, 2]
        rr[_DX, k], rr[_DY, k], rr[_DZ, k] = dx, dy, dz
        if k < n:
            rr[_TMIN, k], rr[_BEST, k] = t_min[i], t_max[i]
        else:
            rr[_TMIN, k], rr[_BEST, k] = np.inf, -np.inf
    if not coherent:
        return False, 0, 4, 8, kx0, ky0, kz0
    for k in range(PACKET):
        dx, dy, dz = rr[_DX, k], rr[_DY, k], rr[_DZ, k]
        rr[_IX, k] = 1.0 / (dx if dx != 0.0 else 1e-300)
        rr[_IY, k] = 1.0 / (dy if dy != 0.0 else 1e-300)
        rr[_IZ, k] = 1.0 / (dz if dz != 0.0 else 1e-300)
        dkz = rr[_DX + kz0, k]
        rr[_SX, k] = rr[_DX + kx0, k] / dkz
        rr[_SY, k] = rr[_DX + ky0, k] / dkz
        rr[_SZ, k] = 1.0 / dkz
        rr[_OKX, k] = rr[_OX + kx0, k]
        rr[_OKY, k] = rr[_OX + ky0, k]
        rr[_OKZ, k] = rr[_OX + kz0, k]
        rr[_E1, k] = 0.0
        rr[_E2, k] = 0.0
        rr[_DET, k] = 1.0
        rr[_PRIM, k] = -np.inf
    # near-plane row offsets as in ray_setup (a zero component counts as positive there too)
    nrx = 12 if rr[_IX, 0] < 0.0 else 0
    nry = 16 if rr[_IY, 0] < 0.0 else 4
    nrz = 20 if rr[_IZ, 0] < 0.0 else 8
    return True, nrx, nry, nrz, kx0, ky0, kz0


@nb.njit(**JIT, inline="always")
def _packet_leaf(code, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, kx, ky, kz, rr, any_mode):
    """Test a leaf's items against all the packet's rays, in a loop over rays that vectorises; records closer
    hits (any_mode: a hit sets the ray's best to -inf, which retires it)."""
    v = -code - 1
    first = v >> 3
    for j in range(first, first + (v & 7)):
        p = leaf_prim[j]
        if p >= 0:
            base = j * 9
            fp = np.float64(p)
            ax0, ay0, az0 = leaf_tri[base + kx], leaf_tri[base + ky], leaf_tri[base + kz]
            bx0, by0, bz0 = leaf_tri[base + 3 + kx], leaf_tri[base + 3 + ky], leaf_tri[base + 3 + kz]
            cx0, cy0, cz0 = leaf_tri[base + 6 + kx], leaf_tri[base + 6 + ky], leaf_tri[base + 6 + kz]
            for k in range(PACKET):
                okx, oky, okz = rr[_OKX, k], rr[_OKY, k], rr[_OKZ, k]
                sx, sy, sz = rr[_SX, k], rr[_SY, k], rr[_SZ, k]
                az = az0 - okz
                bz = bz0 - okz
                cz = cz0 - okz
                ax = (ax0 - okx) - sx * az
                ay = (ay0 - oky) - sy * az
                bx = (bx0 - okx) - sx * bz
                by = (by0 - oky) - sy * bz
                cx = (cx0 - okx) - sx * cz
                cy = (cy0 - oky) - sy * cz
                e0 = cx * by - cy * bx
                e1 = ax * cy - ay * cx
                e2 = bx * ay - by * ax
                det = e0 + e1 + e2
                t = sz * (e0 * az + e1 * bz + e2 * cz) / det
                best = rr[_BEST, k]
                ok = ((det != 0.0) & (rr[_TMIN, k] < t) & (t < best)
                      & ~(((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0))))
                if any_mode:
                    rr[_BEST, k] = -np.inf if ok else best
                else:
                    rr[_BEST, k] = t if ok else best
                    rr[_E1, k] = e1 if ok else rr[_E1, k]
                    rr[_E2, k] = e2 if ok else rr[_E2, k]
                    rr[_DET, k] = det if ok else rr[_DET, k]
                    rr[_PRIM, k] = fp if ok else rr[_PRIM, k]
        else:
            s = -p - 1
            for k in range(PACKET):
                if rr[_BEST, k] > -np.inf:
                    best = rr[_BEST, k]
                    t = sphere_hit_in_object_space((rr[_OX, k], rr[_OY, k], rr[_OZ, k]),
                                                   (rr[_DX, k], rr[_DY, k], rr[_DZ, k]), sph_center[s],
                                                   sph_radius[s], sph_w2o[s], rr[_TMIN, k], best)
                    if t < best:
                        if any_mode:
                            rr[_BEST, k] = -np.inf
                        else:
                            rr[_BEST, k] = t
                            rr[_E1, k], rr[_E2, k], rr[_DET, k] = 0.0, 0.0, 1.0
                            rr[_PRIM, k] = -(s + 1.0)


@nb.njit(**JIT)
def packet_traverse(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                    nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, any_mode):
    """Traverse one tree with a coherent packet (see above). key (4,) float64 and order (4,) int64 are
    scratch. A node's child boxes are tested against the packet as a whole (_packet_slab: bounds over its rays,
    conservative to the bit), children are ordered by the packet's entry distance, which the stack keeps: a
    node is skipped when it lies beyond every ray's closest hit so far. Leaves met in a node are tested at once,
    against all the packet's rays (the triangle test is exact, so a ray outside the leaf's box just misses)."""
    # the packet's extremes: origins, reciprocal directions (one sign per axis), t_min
    oxl = oxh = rr[_OX, 0]
    oyl = oyh = rr[_OY, 0]
    ozl = ozh = rr[_OZ, 0]
    ixl = ixh = rr[_IX, 0]
    iyl = iyh = rr[_IY, 0]
    izl = izh = rr[_IZ, 0]
    tlo = rr[_TMIN, 0]
    for k in range(1, PACKET):
        oxl, oxh = min(oxl, rr[_OX, k]), max(oxh, rr[_OX, k])
        oyl, oyh = min(oyl, rr[_OY, k]), max(oyh, rr[_OY, k])
        ozl, ozh = min(ozl, rr[_OZ, k]), max(ozh, rr[_OZ, k])
        ixl, ixh = min(ixl, rr[_IX, k]), max(ixh, rr[_IX, k])
        iyl, iyh = min(iyl, rr[_IY, k]), max(iyh, rr[_IY, k])
        izl, izh = min(izl, rr[_IZ, k]), max(izh, rr[_IZ, k])
        tlo = min(tlo, rr[_TMIN, k])
    # the origin extreme that minimises the near plane's distance and the one that maximises the far one's
    onx, ofx = (oxh, oxl) if nrx == 0 else (oxl, oxh)
    ony, ofy = (oyh, oyl) if nry == 4 else (oyl, oyh)
    onz, ofz = (ozh, ozl) if nrz == 8 else (ozl, ozh)
    stack_node[0] = root
    stack_t[0] = -np.inf
    sp = 1
    far = _packet_far(rr)
    while sp > 0:
        sp -= 1
        if far == -np.inf:
            break  # every ray has retired (any-hit)
        if stack_t[sp] > far + abs(far) * FAR_WIDEN:
            continue  # no ray's box test could pass below this node (children lie inside its box)
        node = stack_node[sp]
        base = node * 24
        n_in = 0
        for lane in range(4):
            c = child[node, lane]
            if c == 0:
                continue
            b = base + lane
            tn, tf = tlo, far
            a, e = _packet_slab(bounds[b + nrx], bounds[b + 12 - nrx], onx, ofx, ixl, ixh)
            tn, tf = max(tn, a), min(tf, e)
            a, e = _packet_slab(bounds[b + nry], bounds[b + 20 - nry], ony, ofy, iyl, iyh)
            tn, tf = max(tn, a), min(tf, e)
            a, e = _packet_slab(bounds[b + nrz], bounds[b + 28 - nrz], onz, ofz, izl, izh)
            tn, tf = max(tn, a), min(tf, e)
            if not tn <= tf + abs(tf) * FAR_WIDEN:
                continue
            j = n_in
            while j > 0 and key[j - 1] > tn:   # insertion sort, nearest first
                key[j] = key[j - 1]
                order[j] = order[j - 1]
                j -= 1
            key[j] = tn
            order[j] = lane
            n_in += 1
        # leaves now (nearest first), inner children onto the stack farthest first
        for q in range(n_in):
            lane = order[q]
            c = child[node, lane]
            if c < 0:
                _packet_leaf(c, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, kx, ky, kz, rr, any_mode)
                far = _packet_far(rr)
        for q in range(n_in - 1, -1, -1):
            c = child[node, order[q]]
            if c > 0:
                stack_node[sp] = c
                stack_t[sp] = key[q]
                sp += 1


@nb.njit(**JIT, inline="always")
def _packet_slab(near_plane, far_plane, o_near, o_far, i_lo, i_hi):
    """Bounds on one slab's entry and exit distances over all rays of a packet: no ray enters before the first
    nor leaves after the second. The rays share the sign of the reciprocal direction i (in [i_lo, i_hi]); the
    distance (plane - o) * i is monotonic in o and bilinear, so its extremes sit at the extreme origin given
    and at i_lo or i_hi by the sign of plane - o. Rounding is monotonic too, so each bound is also one on every
    ray's own computed distance (the one-ray slab test's)."""
    v = np.float64(near_plane) - o_near
    w = np.float64(far_plane) - o_far
    return v * (i_lo if v >= 0.0 else i_hi), w * (i_hi if w >= 0.0 else i_lo)


@nb.njit(**JIT, inline="always")
def _packet_far(rr):
    """The farthest closest-hit-so-far among the packet's rays (-inf once all have retired)."""
    far = -np.inf
    for k in range(PACKET):
        b = rr[_BEST, k]
        far = b if b > far else far
    return far


# ----------------------------------------------------------------------------------------------- one-level kernels

@nb.njit(**JIT)
def closest_hit_bvh(origins, directions, t_min, t_max, bounds, child, leaf_prim, leaf_tri,
                    sph_center, sph_radius, sph_w2o, pl_normal, pl_offset, stack_size,
                    width, t_out, kind_out, prim_out, u_out, v_out, blk0, blk1):
    """Closest hit of rays in blocks blk0..blk1 (BLOCK * PACKET rays each) against one tree (root 0) and the
    planes beside it; fills the Hits arrays. Chunks of PACKET rays that are coherent go through
    packet_traverse, the others one ray at a time. Serial and nogil: run_blocks spreads the blocks over
    threads (cheaper to compile and to load from the cache than a parallel=True kernel)."""
    n = origins.shape[0]
    n_chunks = (n + PACKET - 1) // PACKET
    stack_node = np.empty(stack_size, np.int32)
    stack_t = np.empty(stack_size)
    dist = np.empty(4)
    rr = np.empty((_NROW, PACKET))
    pprims = np.empty(PACKET, np.int32)
    key = np.empty(4)
    order = np.empty(4, np.int64)
    idx = np.empty(PACKET, np.int64)
    for blk in range(blk0, blk1):
        for c in range(blk * BLOCK, min(n_chunks, (blk + 1) * BLOCK)):
            m = chunk_rays(c, n, width, idx)
            coherent, nrx, nry, nrz, kx, ky, kz = packet_setup(origins, directions, t_min, t_max, idx, m, rr)
            if coherent and m == PACKET:
                for k in range(PACKET):
                    best, pprims[k] = _planes_closest(pl_normal, pl_offset, rr[_OX, k], rr[_OY, k], rr[_OZ, k],
                                                      rr[_DX, k], rr[_DY, k], rr[_DZ, k], rr[_TMIN, k],
                                                      rr[_BEST, k])
                    rr[_BEST, k] = best
                packet_traverse(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, False)
                for k in range(PACKET):
                    i = idx[k]
                    pr = rr[_PRIM, k]  # triangle id, -(sphere + 1), or -inf: nothing in the tree was hit
                    if pr > -np.inf:
                        t_out[i] = rr[_BEST, k]
                        kind_out[i] = TRIANGLE if pr >= 0.0 else SPHERE
                        prim_out[i] = np.int32(pr) if pr >= 0.0 else np.int32(-pr - 1.0)
                        u_out[i] = rr[_E1, k] / rr[_DET, k]
                        v_out[i] = rr[_E2, k] / rr[_DET, k]
                    elif pprims[k] >= 0:
                        t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = rr[_BEST, k], 3, pprims[k], 0.0, 0.0
                    else:
                        t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = np.inf, 0, -1, 0.0, 0.0
                continue
            for q in range(m):
                i = idx[q]
                ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
                dx, dy, dz = directions[i, 0], directions[i, 1], directions[i, 2]
                lo = t_min[i]
                best, pprim = _planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, lo, t_max[i])
                t, kind, prim, u, v = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius,
                                                   sph_w2o, ox, oy, oz, dx, dy, dz, lo, best, stack_node, stack_t,
                                                   dist)
                if kind == 0 and pprim >= 0:
                    t, kind, prim = best, 3, pprim
                t_out[i] = t
                kind_out[i] = kind
                prim_out[i] = prim
                u_out[i] = u
                v_out[i] = v


@nb.njit(**JIT)
def any_hit_bvh(origins, directions, t_min, t_max, bounds, child, leaf_prim, leaf_tri,
                sph_center, sph_radius, sph_w2o, pl_normal, pl_offset, stack_size, width, out, blk0, blk1):
    """out[i] = whether ray i (in blocks blk0..blk1) hits anything with t_min < t < t_max; planes first, then
    the tree (in packets when coherent, as in closest_hit_bvh)."""
    n = origins.shape[0]
    n_chunks = (n + PACKET - 1) // PACKET
    stack_node = np.empty(stack_size, np.int32)
    stack_t = np.empty(stack_size)
    dist = np.empty(4)
    rr = np.empty((_NROW, PACKET))
    key = np.empty(4)
    order = np.empty(4, np.int64)
    idx = np.empty(PACKET, np.int64)
    for blk in range(blk0, blk1):
        for c in range(blk * BLOCK, min(n_chunks, (blk + 1) * BLOCK)):
            m = chunk_rays(c, n, width, idx)
            coherent, nrx, nry, nrz, kx, ky, kz = packet_setup(origins, directions, t_min, t_max, idx, m, rr)
            if coherent and m == PACKET:
                for k in range(PACKET):
                    _, pprim = _planes_closest(pl_normal, pl_offset, rr[_OX, k], rr[_OY, k], rr[_OZ, k],
                                               rr[_DX, k], rr[_DY, k], rr[_DZ, k], rr[_TMIN, k], rr[_BEST, k])
                    if pprim >= 0:
                        rr[_BEST, k] = -np.inf
                packet_traverse(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, True)
                for k in range(PACKET):
                    out[idx[k]] = rr[_BEST, k] == -np.inf
                continue
            for q in range(m):
                i = idx[q]
                ox, oy, oz = origins[i, 0], origins[i, 1], origins[i, 2]
                dx, dy, dz = directions[i, 0], directions[i, 1], directions[i, 2]
                _, pprim = _planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, t_min[i], t_max[i])
                if pprim >= 0:
                    out[i] = True
                else:
                    out[i] = blas_any(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                      ox, oy, oz, dx, dy, dz, t_min[i], t_max[i], stack_node, dist)


def image_width(shape: tuple[int, ...]) -> int:
    """The `width` argument of closest_hit_bvh / any_hit_bvh for rays laid out as `shape` (leading dimensions):
    the image width when the rays form an image whose sides are multiples of 4 (4 x 4 tile packets), else 0."""
    if len(shape) >= 2 and shape[-1] % TILE == 0 and shape[-2] % TILE == 0 and shape[-1] > 0 and shape[-2] > 0:
        return int(shape[-1])
    return 0


def n_blocks(n_rays: int) -> int:
    """Work items of closest_hit_bvh / any_hit_bvh for n_rays rays."""
    return -(-int(n_rays) // (PACKET * BLOCK))


_POOLS: dict = {}


def run_blocks(kernel, n_rays: int, *args) -> None:
    """kernel(*args, blk0, blk1) over all blocks, on numba.get_num_threads() threads (the kernels are nogil):
    a few pieces per thread from a shared pool, so an unlucky slow piece does not idle the other thread."""
    total = n_blocks(n_rays)
    threads = min(nb.get_num_threads(), total)
    if threads <= 1:
        kernel(*args, 0, total)
        return
    from concurrent.futures import ThreadPoolExecutor

    pool = _POOLS.get(threads)
    if pool is None:
        pool = _POOLS[threads] = ThreadPoolExecutor(threads, thread_name_prefix="durer-bvh")
    pieces = min(total, 8 * threads)
    edges = [total * k // pieces for k in range(pieces + 1)]
    for f in [pool.submit(kernel, *args, edges[k], edges[k + 1]) for k in range(pieces)]:
        f.result()


def stack_size_for(depth: int) -> int:
    """Traversal stack entries a tree of this depth can need: three deferred children per level, plus slack."""
    return 3 * int(depth) + 8


PARALLEL_BUILD = 100_000  # items from which build_wide_bvh builds subtrees on several threads


def _build_subtree(lo, hi, max_leaf, items):
    return build_bvh2(lo[items], hi[items], max_leaf, 0)


def build_wide_bvh(lo: np.ndarray, hi: np.ndarray, max_leaf: int = MAX_LEAF):
    """Build the 4-wide BVH over boxes lo/hi (n, 3): (bounds, child, order, depth); see the module docstring.

    Large inputs on several threads: the top of the tree is built until its open nodes hold at most n / (4
    threads) items each; those subtrees are then built concurrently (build_bvh2 is nogil) and stitched in. Each
    subtree sees its items in the order the serial build would, so the tree is the same as the serial one's.
    """
    lo = np.ascontiguousarray(lo, dtype=np.float64)
    hi = np.ascontiguousarray(hi, dtype=np.float64)
    n = lo.shape[0]
    threads = nb.get_num_threads()
    if n < PARALLEL_BUILD or threads < 2:
        box, left, right, start, count, order, _ = build_bvh2(lo, hi, max_leaf, 0)
    else:
        from concurrent.futures import ThreadPoolExecutor

        box, left, right, start, count, order, deferred = build_bvh2(lo, hi, max_leaf, n // (4 * threads))
        pool = _POOLS.get(threads)
        if pool is None:
            pool = _POOLS[threads] = ThreadPoolExecutor(threads, thread_name_prefix="durer-bvh")
        big_first = np.argsort(deferred[:, 1] - deferred[:, 2], kind="stable")
        futures = {int(k): pool.submit(_build_subtree, lo, hi, max_leaf, order[deferred[k, 1]:deferred[k, 2]])
                   for k in big_first}
        parts = [box], [left], [right], [start], [count]
        m = len(box)
        for k in range(len(deferred)):
            node, first, end = (int(x) for x in deferred[k])
            sb, sl, sr, ss, sc, so, _ = futures[k].result()
            # subtree node 0 takes the deferred node's place, the others are appended from m on
            remap = lambda c, m=m: np.where(c > 0, c + (m - 1), c).astype(np.int32)  # noqa: E731
            box[node], left[node], right[node] = sb[0], remap(sl[:1])[0], remap(sr[:1])[0]
            start[node], count[node] = ss[0] + first, sc[0]
            parts[0].append(sb[1:])
            parts[1].append(remap(sl[1:]))
            parts[2].append(remap(sr[1:]))
            parts[3].append((ss[1:] + first).astype(np.int32))
            parts[4].append(sc[1:])
            order[first:end] = order[first:end][so]
            m += len(sb) - 1
        box, left, right, start, count = (np.concatenate(p) for p in parts)
    bounds, child, depth = collapse_bvh4(box, left, right, start, count)
    return bounds, child, order, int(depth)


__all__ = ["build_wide_bvh", "run_blocks", "image_width", "n_blocks", "item_boxes", "leaf_items", "closest_hit_bvh",
           "any_hit_bvh", "blas_closest", "blas_any", "blas_all", "push_nearest_first", "node_dists", "ray_setup",
           "stack_size_for"]
