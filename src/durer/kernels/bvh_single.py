"""One ray through one BVH (Numba): the closest hit, any hit, or every hit, plus the unbounded planes beside it.

Children are visited nearest entry first; the slab test picks each axis's near plane by the direction's sign.
These are the building blocks of the one-level kernels (kernels/bvh_trace.py) and the two-level ones
(kernels/instances.py).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .intersect import intersect_plane, ray_shear, sphere_hit_in_object_space, watertight_triangle
from .layout import FAR_WIDEN, HI_X, HI_Y, HI_Z, JIT, LO_X, LO_Y, LO_Z, NODE_FLOATS, SPHERE, TRIANGLE, WIDTH, leaf_range


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
def _lane(bounds, base, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi):
    """Entry distance into the box at flat offset `base` (a lane of a node), or inf if it misses [t_lo, t_hi].
    The near plane of each slab is picked by the direction's sign, so no min/max per slab is needed."""
    tn = t_lo
    tf = t_hi
    a = (bounds[base + nrx] - ox) * idx
    b = (bounds[base + (LO_X + HI_X) - nrx] - ox) * idx
    tn = a if a > tn else tn
    tf = b if b < tf else tf
    a = (bounds[base + nry] - oy) * idy
    b = (bounds[base + (LO_Y + HI_Y) - nry] - oy) * idy
    tn = a if a > tn else tn
    tf = b if b < tf else tf
    a = (bounds[base + nrz] - oz) * idz
    b = (bounds[base + (LO_Z + HI_Z) - nrz] - oz) * idz
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
    base = node * NODE_FLOATS
    for lane in range(WIDTH):
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


@nb.njit(**JIT, inline="always")
def next_leaf(bounds, child, stack_node, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi, dist):
    """The unordered walk shared by any-hit and all-hits traversals (one or two levels): pop nodes, pushing the
    children whose boxes the ray enters within [t_lo, t_hi], until a leaf comes up. Returns (leaf code, or 0 when
    the stack is empty, new stack pointer); the caller pushes the root first (stack_node[0] = root, sp = 1)."""
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        if node < 0:
            return node, sp
        node_dists(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, t_hi, dist)
        for lane in range(WIDTH):
            if dist[lane] < np.inf:
                stack_node[sp] = child[node, lane]
                sp += 1
    return 0, sp


@nb.njit(**JIT, inline="always")
def descend(bounds, child, node, stack_node, stack_t, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, best,
            dist):
    """The ordered walk of closest-hit traversals (one or two levels), downwards: from `node`, step into the
    nearest child the ray enters within [t_lo, best], pushing the others with their entry distance. Returns (the
    leaf reached, or 0 when the ray enters no child, new stack pointer)."""
    while node >= 0:
        node_dists(bounds, node, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_lo, best, dist)
        node, sp = push_nearest_first(dist, child[node], stack_node, stack_t, sp)
        if node == 0:
            return 0, sp
    return node, sp


@nb.njit(**JIT, inline="always")
def pop_closer(stack_node, stack_t, sp, best):
    """The ordered walk, sideways: pop the next deferred subtree whose entry distance is not beyond the closest hit
    so far (the others can no longer hold a closer hit). Returns (node, or 0 when none is left, stack pointer)."""
    while sp > 0:
        sp -= 1
        if stack_t[sp] <= best:
            return stack_node[sp], sp
    return 0, sp


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
    leaf, sp = descend(bounds, child, root, stack_node, stack_t, 0, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min,
                       best, dist)
    while True:
        first, end = leaf_range(leaf) if leaf != 0 else (0, 0)
        for j in range(first, end):
            p = leaf_prim[j]
            if p >= 0:
                t, u, w = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, best)
                if t < best:
                    best, kind, prim, bu, bv = t, TRIANGLE, p, u, w
            else:
                s = -p - 1
                t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s],
                                               sph_w2o[s], t_min, best)
                if t < best:
                    best, kind, prim, bu, bv = t, SPHERE, s, 0.0, 0.0
        node, sp = pop_closer(stack_node, stack_t, sp, best)
        if node == 0:
            break
        leaf, sp = descend(bounds, child, node, stack_node, stack_t, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz,
                           t_min, best, dist)
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
    while True:
        leaf, sp = next_leaf(bounds, child, stack_node, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max,
                             dist)
        if leaf == 0:
            return False
        first, end = leaf_range(leaf)
        for j in range(first, end):
            p = leaf_prim[j]
            if p >= 0:
                t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max)
            else:
                s = -p - 1
                t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s],
                                               sph_w2o[s], t_min, t_max)
            if t < np.inf:
                return True


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
    while True:
        leaf, sp = next_leaf(bounds, child, stack_node, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, t_min, t_max,
                             dist)
        if leaf == 0:
            return n_out
        first, end = leaf_range(leaf)
        for j in range(first, end):
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


