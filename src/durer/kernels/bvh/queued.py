"""The unordered all-hits walk with its pending nodes in a queue (Numba): counts, signed crossings, parity.

A walk that must open every box its ray enters (counting hits, signed crossings, parity) may visit the pending
nodes in any order. single.blas_all keeps them on a stack: the child pushed last is popped at once, before the
load its parent's prefetch started has landed, so every visit waits on one memory latency. Here the pending
nodes wait in a ring queue instead and are visited first in, first out: a child's prefetch (issued when its
parent is visited) has the whole queue's worth of other visits to land. While the queue holds more than
QUEUE_FIFO nodes, the newest is taken instead (a stack): a depth-first descent adds at most three nodes a level,
so the ring never holds more than QUEUE_FIFO + 3 + the tree's stack size (ring_for sizes it so). Bunny, 512k
incoherent rays, one thread, the walk alone: 0.87-0.98x the time of the stack walk (loaded machine), the same hits.
On coherent rays (occupancy's Morton-sorted points) the stack walk was faster: kernels/points/crossings.py keeps it.

blas_count counts the hits single.blas_all finds (every hit with t_min < t < t_max, a sphere's two roots twice),
with the same tests, so the same hits, and stores nothing (count_intersections' one-ray path); a leaf of a tree
without spheres goes through leaf4.count_hits4 (its triangles 4 at a time in one vector pass, the same answers).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from ..intersect import sphere_hit_in_object_space, watertight_triangle
from .layout import leaf_range
from .leaf4 import count_hits4
from .single import node_dists4, prefetch_children, ray_setup

QUEUE_FIFO = 64  # queued nodes up to which the walk takes the oldest (beyond: the newest, depth first)


@nb.njit(**JIT, inline="always")
def ring_for(stack_size):
    """A ring queue for walks of a tree whose stack walk needs stack_size entries: a power of two with room for
    QUEUE_FIFO nodes, one visit's pushes and a depth-first descent (module docstring)."""
    need = QUEUE_FIFO + 8 + max(stack_size, 1)
    size = 1
    while size < need:
        size *= 2
    return np.empty(size, np.int32)


@nb.njit(**JIT, inline="always")
def queue_start(ring, root):
    """The walk's state (head, tail) with `root` queued."""
    ring[0] = root
    return np.uint64(0), np.uint64(1)


@nb.njit(**JIT, inline="always")
def blas_count(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, ox, oy, oz, dx, dy, dz,
               t_min, t_max, ring):
    """How many hits single.blas_all finds (t_min < t < t_max; a sphere passed through counts twice), from the
    same tests, with none stored. The walk written out, each leaf tested where it is taken from the queue (a
    helper returning leaf by leaf, as single.next_leaf, measured 1.05-1.14x slower)."""
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
        if sph_center.shape[0] == 0:  # triangles only: up to 4 a vector pass (leaf4.py: 0.82-0.94x the time)
            n += count_hits4(leaf_tri, first, end, kx, ky, kz, okx, oky, okz, sx, sy, sz, t_min, t_max)
            continue
        for j in range(first, end):
            p = leaf_prim[j]
            if p >= 0:
                t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max)
                n += np.int64(t < np.inf)
                continue
            s = -p - 1
            lo = t_min
            for _ in range(2):  # a sphere: its near root, then the far root beyond it
                t = sphere_hit_in_object_space((ox, oy, oz), (dx, dy, dz), sph_center[s], sph_radius[s], sph_w2o[s],
                                               lo, t_max)
                if t == np.inf:
                    break
                n += 1
                lo = t
    return n
