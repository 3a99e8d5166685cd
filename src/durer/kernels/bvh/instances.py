"""Two-level traversal (Numba): a top-level 4-wide BVH over instances, each pointing at a bottom-level tree.

An instance is (root node of a bottom-level tree in the shared arrays, 3x4 world-to-object matrix). At an instance
leaf the ray is moved into object space with its direction left unnormalised, so the bottom-level tree's t is the
world t and one mesh can appear many times while being stored once. The top-level tree uses the layout of
kernels/bvh/layout.py; its leaf slots name instances. Here: moving rays, normals, and every hit of a ray; the closest-
hit and any-hit kernels, which also take packets, are in kernels/bvh/instance_packets.py. The kernels are serial and
nogil, spread over threads by threads.run_blocks rather than parallel=True regions: a process forked after an OpenMP
region has run cannot use one again, and RaycastingScene must work in forked workers.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT, SPHERE, TRIANGLE
from .layout import BLOCK, PACKET, leaf_range
from .single import blas_all, load_ray, next_leaf, ray_setup

RAYS_PER_BLOCK = PACKET * BLOCK  # rays per work item of threads.run_blocks (serial nogil kernels, fork-safe)


@nb.njit(**JIT, inline="always")
def to_object(w2o, ox, oy, oz, dx, dy, dz):
    """The ray in an instance's object space (direction not renormalised, so t is unchanged)."""
    m = w2o
    return (m[0, 0] * ox + m[0, 1] * oy + m[0, 2] * oz + m[0, 3],
            m[1, 0] * ox + m[1, 1] * oy + m[1, 2] * oz + m[1, 3],
            m[2, 0] * ox + m[2, 1] * oy + m[2, 2] * oz + m[2, 3],
            m[0, 0] * dx + m[0, 1] * dy + m[0, 2] * dz,
            m[1, 0] * dx + m[1, 1] * dy + m[1, 2] * dz,
            m[2, 0] * dx + m[2, 1] * dy + m[2, 2] * dz)


@nb.njit(**JIT, inline="always")
def top_walk(top_node):
    """The start of a ray's unordered walk over the top-level tree (next_instance): its root on the stack
    top_node, no leaf open. The walk's state is (stack pointer, next slot of the open leaf, its end)."""
    top_node[0] = 0
    return 1, 0, 0


@nb.njit(**JIT, inline="always")
def next_instance(top_bounds, top_child, top_leaf, top_node, walk, slabs, ox, oy, oz, lo, hi):
    """The next instance whose box the ray enters within [lo, hi], in no particular order: (instance, or -1 when
    the walk is over, the walk's new state). slabs = ray_setup's reciprocal direction and near rows (idx, idy,
    idz, nrx, nry, nrz). The walk of the two-level any-hit and all-hits kernels (single.next_leaf over the tree
    of instances, then each slot of the leaf it returns)."""
    sp, j, end = walk
    idx, idy, idz, nrx, nry, nrz = slabs
    while j == end:
        leaf, sp = next_leaf(top_bounds, top_child, top_node, sp, nrx, nry, nrz, ox, oy, oz, idx, idy, idz, lo, hi)
        if leaf == 0:
            return -1, (sp, j, end)
        j, end = leaf_range(leaf)
    return top_leaf[j], (sp, j + 1, end)


@nb.njit(**JIT, inline="always")
def ray_slabs(ox, oy, oz, dx, dy, dz):
    """ray_setup's part for the slab tests alone: (idx, idy, idz, nrx, nry, nrz)."""
    idx, idy, idz, nrx, nry, nrz, _, _, _, _, _, _, _, _, _ = ray_setup(ox, oy, oz, dx, dy, dz)
    return idx, idy, idz, nrx, nry, nrz


@nb.njit(**JIT)
def rays_to_object(origins, directions, w2o, out_o, out_d):
    """All rays moved into one instance's object space, with the arithmetic of the two-level kernels (so a
    scene of one instance traced by the one-level kernels gets the same t to the bit)."""
    for i in range(origins.shape[0]):
        (out_o[i, 0], out_o[i, 1], out_o[i, 2], out_d[i, 0], out_d[i, 1],
         out_d[i, 2]) = to_object(w2o, origins[i, 0], origins[i, 1], origins[i, 2],
                                  directions[i, 0], directions[i, 1], directions[i, 2])


@nb.njit(**JIT, inline="always")
def hit_normal(ox, oy, oz, dx, dy, dz, t, k, kind, prim, inst_shape, tri_off, tri_normals, inst_w2o, inst_sign,
               sph_center):
    """Unit world-space normal of one closest hit (zero on a miss) of instance k. Triangles: the stored
    object-space normal by the instance's inverse transpose, flipped under a mirror as moved vertices would flip
    the winding; spheres: outward, from the hit point in object space."""
    if kind == TRIANGLE:
        j = tri_off[inst_shape[k]] + prim
        ax, ay, az = tri_normals[j, 0], tri_normals[j, 1], tri_normals[j, 2]
    elif kind == SPHERE:
        m = inst_w2o[k]
        px = ox + t * dx
        py = oy + t * dy
        pz = oz + t * dz
        ax = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3] - sph_center[prim, 0]
        ay = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3] - sph_center[prim, 1]
        az = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3] - sph_center[prim, 2]
    else:
        return 0.0, 0.0, 0.0
    m = inst_w2o[k]
    sign = inst_sign[k] if kind == TRIANGLE else 1.0
    nx = sign * (m[0, 0] * ax + m[1, 0] * ay + m[2, 0] * az)
    ny = sign * (m[0, 1] * ax + m[1, 1] * ay + m[2, 1] * az)
    nz = sign * (m[0, 2] * ax + m[1, 2] * ay + m[2, 2] * az)
    length = np.sqrt(nx * nx + ny * ny + nz * nz)
    if length > 0.0:
        nx, ny, nz = nx / length, ny / length, nz / length
    return nx, ny, nz


@nb.njit(**JIT)
def all_hits_instances(origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root, inst_w2o,
                       bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size,
                       offsets, out_t, out_inst, out_kind, out_prim, out_u, out_v, counts, blk0, blk1):
    """Every crossing of each ray (t_min < t < t_max). counts[i] gets ray i's number of hits; when out_t is
    long enough, its hits are written from offsets[i] on (in traversal order). Call once with empty outputs to
    count, then again with offsets = exclusive prefix sum of the counts to fill."""
    n = origins.shape[0]
    fill = out_t.shape[0] > 0
    top_node = np.empty(stack_size, np.int32)
    stack_node = np.empty(stack_size, np.int32)
    for i in range(blk0 * RAYS_PER_BLOCK, min(n, blk1 * RAYS_PER_BLOCK)):
        ox, oy, oz, dx, dy, dz = load_ray(origins, directions, i)
        lo, hi = t_min[i], t_max[i]
        slabs = ray_slabs(ox, oy, oz, dx, dy, dz)
        start = offsets[i] if fill else 0
        stop = offsets[i] + counts[i] if fill else 0
        ot, ok_, op, ou, ov = out_t[start:stop], out_kind[start:stop], out_prim[start:stop], \
            out_u[start:stop], out_v[start:stop]
        total = 0
        walk = top_walk(top_node)
        while True:
            k, walk = next_instance(top_bounds, top_child, top_leaf, top_node, walk, slabs, ox, oy, oz, lo, hi)
            if k < 0:
                break
            px, py, pz, qx, qy, qz = to_object(inst_w2o[k], ox, oy, oz, dx, dy, dz)
            before = total
            total = blas_all(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                             px, py, pz, qx, qy, qz, lo, hi, stack_node, ot, op, ok_, ou, ov, total)
            if fill:
                for q in range(before, min(total, stop - start)):
                    out_inst[start + q] = k
        counts[i] = total
