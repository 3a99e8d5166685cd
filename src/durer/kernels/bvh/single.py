"""One ray through one BVH (Numba): the closest hit, any hit, or every hit, plus the unbounded planes beside it.

Children are visited nearest entry first; the slab test picks each axis's near plane by the direction's sign.
These are the building blocks of the one-level kernels (kernels/bvh/trace.py) and the two-level ones
(kernels/bvh/instances.py).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT, MISS, SPHERE, TRIANGLE
from ..intersect import intersect_plane, ray_shear, sphere_hit_in_object_space, watertight_triangle
from .layout import FAR_WIDEN, HI_X, HI_Y, HI_Z, LEAF_COUNT_BITS, LO_X, LO_Y, LO_Z, NODE_FLOATS, leaf_range
from .simd import entry4, prefetch, prefetch_pair, row4

# unsigned index constants of the node test: near row + far row of each axis, node size
_UX, _UY, _UZ = np.uint64(LO_X + HI_X), np.uint64(LO_Y + HI_Y), np.uint64(LO_Z + HI_Z)
_UNODE = np.uint64(NODE_FLOATS)
_U0, _U1, _U2, _U4, _U9, _U16 = (np.uint64(k) for k in (0, 1, 2, 4, 9, 16))
_NO_LEAVES = np.empty(0)  # prefetch_children's leaf_tri where the walk does not know the leaves


@nb.njit(**JIT, inline="always")
def load_ray(origins, directions, i):
    """Ray i of (N, 3) arrays as six scalars: ox, oy, oz, dx, dy, dz."""
    return origins[i, 0], origins[i, 1], origins[i, 2], directions[i, 0], directions[i, 1], directions[i, 2]


@nb.njit(**JIT, inline="always")
def ray_setup(ox, oy, oz, dx, dy, dz):
    """Per-ray constants: reciprocal direction and near-plane row offsets for the slab tests (by direction
    sign), and the shear of the triangle test. A zero direction component becomes 1e-300 for the slabs only,
    so (lo - o) / d is never 0 * inf = NaN."""
    idx = 1.0 / (dx if dx != 0.0 else 1e-300)
    idy = 1.0 / (dy if dy != 0.0 else 1e-300)
    idz = 1.0 / (dz if dz != 0.0 else 1e-300)
    nrx = LO_X if idx >= 0.0 else HI_X
    nry = LO_Y if idy >= 0.0 else HI_Y
    nrz = LO_Z if idz >= 0.0 else HI_Z
    kx, ky, kz, sx, sy, sz = ray_shear(dx, dy, dz)
    o = (ox, oy, oz)
    return idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, o[kx], o[ky], o[kz]


@nb.njit(**JIT, inline="always")
def node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi):
    """The entry distances (d0, d1, d2, d3) of the ray into the 4 child boxes of `node`, inf for a box it misses
    within [t_lo, t_hi] (its far distance widened by FAR_WIDEN). bounds is the flat float32 node array (24 floats
    a node: rows lo x, y, z, hi x, y, z of 4 lanes each); the near plane of each slab is picked by the direction's
    sign (row offsets nrx, nry, nrz from ray_setup), so no min/max of the two planes is needed. Empty lanes hold
    a box at +infinity and so always miss. The 4 lanes are tested at once in 4-wide vector code (kernels/bvh/simd.py);
    the offsets are unsigned, which spares Numba's negative-index wraparound."""
    base = np.uint64(node) * _UNODE
    rx, ry, rz = np.uint64(nrx), np.uint64(nry), np.uint64(nrz)
    return entry4(bounds, base + rx, base + (_UX - rx), base + ry, base + (_UY - ry), base + rz, base + (_UZ - rz),
                  (ox, oy, oz), (idx, idy, idz), t_lo, t_hi, FAR_WIDEN)


@nb.njit(**JIT, inline="always")
def _prefetch_child(bounds, leaf_tri, child, code):
    """Prefetch what child `code` points at: an inner node's 96-byte block of boxes (two cache lines) and its row
    of child codes (the next load the walk waits on there), or a leaf's first triangle (72 or 36 bytes) and the
    line after it when leaf_tri is given (empty: nodes only). A leaf's code selects node 0 and an inner node's leaf
    slot 0 for the other, so no branch: a prefetch never faults and a cached line costs nothing."""
    node = np.uint64(max(code, 0))
    base = node * _UNODE
    prefetch(bounds, base)
    prefetch(bounds, base + _U16)
    prefetch(child, node * _U4)
    if leaf_tri.shape[0] > 0:  # the first triangle's line and the next (float32 leaves: the next two triangles)
        prefetch_pair(leaf_tri, np.uint64((-min(code, -1) - 1) >> LEAF_COUNT_BITS) * _U9)


@nb.njit(**JIT, inline="always")
def child_codes(child, node):
    """The 4 child codes of `node` (>= 0) as one 16-byte load (simd.row4)."""
    return row4(child, np.uint64(node))


@nb.njit(**JIT, inline="always")
def prefetch_children(bounds, leaf_tri, child, node):
    """Start loading all 4 children of `node` as soon as their codes are known, before the node test decides
    which to enter: the walk is a chain of dependent loads (node, child, node ...), and on incoherent rays the
    children that are pushed wait on the stack long enough for the prefetch to land. Measured 0.79-0.80x the
    time of the closest-hit walk without it (bunny and its 1.1M version, incoherent rays; benchmarks/README.md),
    even though it also fetches children that the test then rejects (prefetching only the entered ones was
    slower: the address then waits for the test). Returns the 4 codes (child_codes) for the caller's pushes."""
    c0, c1, c2, c3 = child_codes(child, node)
    _prefetch_child(bounds, leaf_tri, child, c0)
    _prefetch_child(bounds, leaf_tri, child, c1)
    _prefetch_child(bounds, leaf_tri, child, c2)
    _prefetch_child(bounds, leaf_tri, child, c3)
    return c0, c1, c2, c3


@nb.njit(**JIT, inline="always")
def _push(stack_node, stack_t, sp, code, d, lane, nearest):
    """Push child `code` (lane `lane`) with entry distance d when it was entered (d < inf) and is not the nearest,
    branch-free: the entry is always written and the pointer moves only for a real push (the stack keeps spare
    entries for that: stack_size_for). Straight-line code also lets Numba drop the reference counting of the
    arrays it is given (with branches it would not). The ordered stack's pointer sp is unsigned and entry k
    lives at index k + 1 (push_nearest_first)."""
    u = sp + _U1
    stack_node[u] = code
    stack_t[u] = d
    return sp + np.uint64(d < np.inf) * np.uint64(lane != nearest)


@nb.njit(**JIT, inline="always")
def push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp):
    """Step into the nearest child a visit entered (entry distances d0..d3, inf for a miss; child codes c0..c3),
    pushing the other entered ones; returns (nearest child code or 0 if none was entered, new stack pointer).

    Most visits enter one or two children (bunny, incoherent rays: 12% none, 51% one, 27% two), so the nearest
    is found by three branch-free selects and the others pushed in lane order, with one exchange afterwards so
    that the nearer of the two topmost entries is popped first; a full sort cost more in mispredicted branches
    than the better order of the rarer 3- and 4-child visits saved. The nearest code comes from the same selects
    (the codes are in registers: child_codes), not from a load that waits for them.

    The ordered stack (this, descend, pop_closer, blas_closest): sp (uint64) counts the entries, entry k is at
    index k + 1, and index 0 is a spare the exchange reads and writes when the stack is empty. Unsigned indices
    spare Numba's negative-index wraparound on every push and pop (with the two above: 0.81x the walk's time on
    the bunny, 0.93x on the 1.1M bunny, benchmarks/README.md)."""
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
    start = sp
    sp = _push(stack_node, stack_t, sp, c3, d3, 3, nearest)
    sp = _push(stack_node, stack_t, sp, c2, d2, 2, nearest)
    sp = _push(stack_node, stack_t, sp, c1, d1, 1, nearest)
    sp = _push(stack_node, stack_t, sp, c0, d0, 0, nearest)
    # the exchange, branch-free too: with fewer than two new entries it swaps the top entry with itself (index 0,
    # the spare, when the stack is empty)
    top = sp
    below = top - np.uint64(sp - start >= _U2)
    t_top, t_below = stack_t[top], stack_t[below]
    n_top, n_below = stack_node[top], stack_node[below]
    swap = t_top > t_below
    stack_t[top], stack_t[below] = min(t_top, t_below), max(t_top, t_below)
    stack_node[top] = n_below if swap else n_top
    stack_node[below] = n_top if swap else n_below
    return code, sp


@nb.njit(**JIT, inline="always")
def slot_hit(j, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, ox, oy, oz, dx, dy, dz, okx, oky, okz, kx, ky, kz,
             sx, sy, sz, t_min, t_max):
    """The hit of one leaf slot (a triangle, or a sphere in its object space) in (t_min, t_max): (t, kind, primitive,
    u, v), t = inf on a miss. The ray's watertight-test constants come from ray_setup."""
    p = leaf_prim[j]
    if p >= 0:
        t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max)
        return t, TRIANGLE, p, u, w
    s = -p - 1
    t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s], sph_w2o[s], t_min, t_max)
    return t, SPHERE, s, 0.0, 0.0


@nb.njit(**JIT, inline="always")
def next_leaf(bounds, child, stack_node, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi):
    """The unordered walk shared by any-hit and all-hits traversals (one or two levels): pop nodes, pushing the
    children whose boxes the ray enters within [t_lo, t_hi], until a leaf comes up. Returns (leaf code, or 0 when
    the stack is empty, new stack pointer); the caller pushes the root first (stack_node[0] = root, sp = 1)."""
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        if node < 0:
            return node, sp
        codes = prefetch_children(bounds, _NO_LEAVES, child, node)
        d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi)
        # a loop over the four scalars as a tuple, which LLVM unrolls: the same code and speed as the pushes written
        # out (paired render: 0.99); as an inlined helper per lane, branch-free 4% slower on the path tracer's
        # shadow rays, with a branch it kept the arrays' reference counts (benchmarks/README.md)
        for lane, d in enumerate((d0, d1, d2, d3)):
            if d < np.inf:
                stack_node[sp] = codes[lane]
                sp += 1
    return 0, sp


@nb.njit(**JIT, inline="always")
def descend(bounds, child, node, stack_node, stack_t, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, best):
    """The ordered walk of closest-hit traversals (one or two levels), downwards: from `node`, step into the
    nearest child the ray enters within [t_lo, best], pushing the others with their entry distance. Returns (the
    leaf reached, or 0 when the ray enters no child, new stack pointer); sp is the ordered stack's (uint64: see
    push_nearest_first)."""
    while node >= 0:
        c0, c1, c2, c3 = child_codes(child, node)
        d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, best)
        node, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
        if node == 0:
            return 0, sp
    return node, sp


@nb.njit(**JIT, inline="always")
def pop_closer(stack_node, stack_t, sp, best):
    """The ordered walk, sideways: pop the next deferred subtree whose entry distance is not beyond the closest hit
    so far (the others can no longer hold a closer hit). Returns (node, or 0 when none is left, stack pointer)."""
    while sp > _U0:
        if stack_t[sp] <= best:
            return stack_node[sp], sp - _U1
        sp -= _U1
    return np.int32(0), sp


@nb.njit(**JIT)
def blas_closest(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                 ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node, stack_t):
    """Closest hit in one tree: (t, kind, prim, u, v) with t = inf, kind 0 when nothing is hit before t_max.

    bounds float32 flat (N*24,), child int32 (N, 4), leaf_tri float64 flat (M*9,). Children are visited
    nearest entry first; the others wait on the stack with their entry distance and are dropped when a closer
    hit has been found meanwhile. stack_node and stack_t are the caller's scratch.
    """
    best = t_max
    kind = MISS
    prim = -1
    bu = 0.0
    bv = 0.0
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    # The nearest-first walk and the leaf test written out here rather than through descend/pop_closer and slot_hit
    # (which the other walks use): on incoherent rays this form measured 4-7% faster (benchmarks/README.md, issue 8).
    sp = _U0  # the ordered stack (push_nearest_first): entry k at index k + 1
    node = root
    while True:
        if node >= 0:
            c0, c1, c2, c3 = prefetch_children(bounds, leaf_tri, child, node)
            d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, best)
            nxt, sp = push_nearest_first(d0, d1, d2, d3, c0, c1, c2, c3, stack_node, stack_t, sp)
            if nxt != 0:
                node = nxt
                continue
        else:
            first, end = leaf_range(node)
            for j in range(first, end):
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


@nb.njit(**JIT, _nrt=False)  # allocates nothing; with reference counting, the sphere test's row views cost a count
def blas_any(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
             ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node):
    """True as soon as anything is hit with t_min < t < t_max (no ordering: the first hit ends the search).

    The unordered walk written out (next_leaf is the two-level kernels' form of it): the stack pointer unsigned,
    an entered child pushed branch-free from the codes the prefetch read (the entry is always written, the
    pointer moves when the box is entered; the stack keeps spare entries: stack_size_for). Paired against
    next_leaf's pushes (a branch per entered box, the codes loaded again, and the arrays' reference counts Numba
    kept for that helper): 0.64x the time with t_max = inf, 0.72x on unoccluded shadow rays (bunny,
    benchmarks/README.md)."""
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    stack_node[0] = root
    sp = _U1
    while sp > _U0:
        sp -= _U1
        node = stack_node[sp]
        if node >= 0:
            c0, c1, c2, c3 = prefetch_children(bounds, _NO_LEAVES, child, node)
            d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max)
            stack_node[sp] = c0
            sp += np.uint64(d0 < np.inf)
            stack_node[sp] = c1
            sp += np.uint64(d1 < np.inf)
            stack_node[sp] = c2
            sp += np.uint64(d2 < np.inf)
            stack_node[sp] = c3
            sp += np.uint64(d3 < np.inf)
            continue
        first, end = leaf_range(node)
        for j in range(first, end):
            if slot_hit(j, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, ox, oy, oz, dx, dy, dz, okx, oky, okz,
                        kx, ky, kz, sx, sy, sz, t_min, t_max)[0] < np.inf:
                return True
    return False


@nb.njit(**JIT, inline="always")
def blas_all(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
             ox, oy, oz, dx, dy, dz, t_min, t_max, stack_node,
             out_t, out_prim, out_kind, out_u, out_v, n_out):
    """Every hit with t_min < t < t_max (a sphere counts twice when both roots are in range), appended to the
    out_* arrays from n_out on while they have room. Returns the new count, which may exceed the arrays'
    length: the caller then sizes them from the count and calls again. Inlined into its callers, which call it once
    per ray and instance: a call passes 13 arrays, each reference-counted on entry and exit (the parity test of
    1M points ran 10% faster inlined).

    The unordered walk written out (not next_leaf): an entered child is pushed branch-free (the entry is always
    written, the pointer moves when the box is entered; the stack keeps spare entries: stack_size_for), and a
    node's children, leaves' first triangles included, are prefetched as in blas_closest; leaves are tested as
    they are popped."""
    idx, idy, idz, nrx, nry, nrz, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(ox, oy, oz, dx, dy, dz)
    cap = out_t.shape[0]
    stack_node[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        if node >= 0:  # an inner node (the root may be node 0; empty slots are never pushed)
            prefetch_children(bounds, leaf_tri, child, node)
            d0, d1, d2, d3 = node_dists4(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max)
            stack_node[sp] = child[node, 0]
            sp += np.int64(d0 < np.inf)
            stack_node[sp] = child[node, 1]
            sp += np.int64(d1 < np.inf)
            stack_node[sp] = child[node, 2]
            sp += np.int64(d2 < np.inf)
            stack_node[sp] = child[node, 3]
            sp += np.int64(d3 < np.inf)
            continue
        first, end = leaf_range(node)
        for j in range(first, end):
            p = leaf_prim[j]
            if p >= 0:
                t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max)
                if t < np.inf:
                    if n_out < cap:
                        out_t[n_out], out_prim[n_out], out_kind[n_out] = t, p, TRIANGLE
                        out_u[n_out], out_v[n_out] = u, w
                    n_out += 1
                continue
            s = -p - 1
            lo = t_min
            for _ in range(2):  # a sphere: its near root, then the far root beyond it
                t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s], sph_w2o[s],
                                               lo, t_max)
                if t == np.inf:
                    break
                if n_out < cap:
                    out_t[n_out], out_prim[n_out], out_kind[n_out] = t, s, SPHERE
                    out_u[n_out], out_v[n_out] = 0.0, 0.0
                n_out += 1
                lo = t
    return n_out


@nb.njit(**JIT)
def planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, t_min, best):
    """Closest unbounded plane: (t, plane index) with t = best, index -1 if none is closer."""
    prim = -1
    for k in range(pl_offset.shape[0]):
        t = intersect_plane(ox, oy, oz, dx, dy, dz, pl_normal[k, 0], pl_normal[k, 1], pl_normal[k, 2], pl_offset[k],
                            t_min, best)
        if t < best:
            best = t
            prim = k
    return best, prim


