"""The two-level entry kernels (Numba): rays through meshes placed more than once, in packets where coherent.

Rays go in chunks of PACKET (consecutive rays, or 4 x 4 tiles of an image `width` wide, as trace.py's one-level
kernels take them). A coherent chunk walks the top-level tree over instances as a packet (packet_traverse's node test);
at an instance leaf its rays are moved into the instance's object space with instances.to_object's arithmetic, so t
stays what the one-ray two-level path computes, and the bottom-level tree is traversed with
packet.packet_traverse when the moved rays still share direction signs and shear axes (a rotation can change the
largest component), else one ray at a time through that instance. Incoherent chunks take the one-ray two-level walk
(nearest instance box first). Every ray does the one-ray path's arithmetic, so t, u, v agree to the bit; only the
visit order differs, which can change the primitive or instance named on an exact tie in t.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT, MISS, TRIANGLE
from .chunks import (
    _BEST,
    _DET,
    _DX,
    _DY,
    _DZ,
    _E1,
    _E2,
    _OX,
    _OY,
    _OZ,
    _PRIM,
    _TMIN,
    chunk_span,
    load_chunk,
    object_packet,
    packet_rows,
)
from .instances import next_instance, ray_slabs, to_object, top_walk
from .layout import PACKET, WIDTH, leaf_range, packet_spread_limit
from .packet import (
    _packet_far,
    hit_of_code,
    packet_extents,
    packet_node,
    packet_pop,
    packet_retired,
    packet_traverse,
    push_inner,
)
from .single import blas_any, blas_closest, descend, load_ray, pop_closer


@nb.njit(**JIT, inline="always")
def _scratch(stack_size, top_bounds, top_child):
    """Per-call scratch: both levels' stacks (nodes, entry distances), the world and object-space packet rows,
    both levels' child orders (key, order), ray indices, the packet's best hit so far (instance, primitive code as
    in packet.py's _PRIM row, u, v); and the top-level tree's packet_spread_limit."""
    return (np.empty(stack_size, np.int32), np.empty(stack_size), np.empty(stack_size, np.int32),
            np.empty(stack_size), packet_rows(), packet_rows(), np.empty(WIDTH), np.empty(WIDTH, np.int64),
            np.empty(WIDTH), np.empty(WIDTH, np.int64), np.empty(PACKET, np.int64), np.empty(PACKET, np.int64),
            np.empty(PACKET), np.empty(PACKET), np.empty(PACKET), packet_spread_limit(top_bounds, top_child))


@nb.njit(**JIT, inline="always")
def _trace_instance(k, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                    rr, ro, stack_node, stack_t, key, order, res_inst, res_prim, res_u, res_v, any_mode):
    """The packet rr against instance k: its closer hits recorded (rr's best, res_*), or (any_mode) the rays
    that hit something retired (best -inf)."""
    root = inst_root[k]
    coherent, nrx, nry, nrz, kx, ky, kz = object_packet(rr, ro, inst_w2o[k])
    if coherent:
        packet_traverse(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                        nrx, nry, nrz, kx, ky, kz, ro, stack_node, stack_t, key, order, np.bool_(any_mode))
        for r in range(PACKET):
            if any_mode:
                rr[_BEST + r] = ro[_BEST + r]
            elif ro[_PRIM + r] > -np.inf:
                rr[_BEST + r] = ro[_BEST + r]
                res_inst[r], res_prim[r] = k, ro[_PRIM + r]
                res_u[r], res_v[r] = ro[_E1 + r] / ro[_DET + r], ro[_E2 + r] / ro[_DET + r]
        return
    for r in range(PACKET):
        best = rr[_BEST + r]
        if best == -np.inf:
            continue  # retired (any-hit)
        px, py, pz, qx, qy, qz = ro[_OX + r], ro[_OY + r], ro[_OZ + r], ro[_DX + r], ro[_DY + r], ro[_DZ + r]
        if any_mode:
            if blas_any(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                        px, py, pz, qx, qy, qz, ro[_TMIN + r], best, stack_node):
                rr[_BEST + r] = -np.inf
            continue
        t, kind, prim, u, w = blas_closest(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius,
                                           sph_w2o, px, py, pz, qx, qy, qz, ro[_TMIN + r], best, stack_node,
                                           stack_t)
        if kind != MISS:
            rr[_BEST + r] = t
            res_inst[r], res_prim[r] = k, (prim if kind == TRIANGLE else -(prim + 1.0))
            res_u[r], res_v[r] = u, w


@nb.njit(**JIT)
def packet_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri,
                     sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node, top_t, stack_node,
                     stack_t, top_key, top_order, key, order, res_inst, res_prim, res_u, res_v, any_mode):
    """Walk the top-level tree with the coherent packet rr (set up by packet_setup), nearest instance boxes
    first, skipping boxes beyond every ray's best hit so far (packet_traverse's node test and stack); each
    instance met is traced by _trace_instance. res_inst must start at -1: it ends as the instance of each ray's
    closest hit (closest mode)."""
    ext = packet_extents(rr, nrx, nry, nrz)
    top_node[0] = 0  # the top-level tree's root
    top_t[0] = -np.inf
    sp = 1
    far = _packet_far(rr)
    while True:
        node, sp = packet_pop(top_node, top_t, sp, far)
        if node < 0:
            break
        n_in = packet_node(top_bounds, top_child, node, nrx, nry, nrz, ext, far, top_key, top_order)
        for q in range(n_in):
            c = top_child[node, top_order[q]]
            if c < 0:
                first, end = leaf_range(c)
                for j in range(first, end):
                    _trace_instance(top_leaf[j], inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri,
                                    sph_center, sph_radius, sph_w2o, rr, ro, stack_node, stack_t, key, order,
                                    res_inst, res_prim, res_u, res_v, any_mode)
                far = _packet_far(rr)
        sp = push_inner(top_child, node, top_key, top_order, n_in, top_node, top_t, sp)


@nb.njit(**JIT)
def _closest_rays(idx, m, origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root, inst_w2o,
                  bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, top_node, top_t, stack_node,
                  stack_t, t_out, inst_out, kind_out, prim_out, u_out, v_out):
    """Rays idx[:m] one at a time, the one-ray two-level walk (nearest instance box first), written out here: as
    an inline="always" helper called from the kernel, the same walk measured 5-15% slower on incoherent rays."""
    for q in range(m):
        i = idx[q]
        ox, oy, oz, dx, dy, dz = load_ray(origins, directions, i)
        lo = t_min[i]
        best = t_max[i]
        b_inst, b_kind, b_prim, b_u, b_v = -1, MISS, -1, 0.0, 0.0
        idx_, idy, idz, nrx, nry, nrz = ray_slabs(ox, oy, oz, dx, dy, dz)
        node, sp = 0, np.uint64(0)  # the top-level tree's root, an empty ordered stack (single.push_nearest_first)
        while True:
            leaf, sp = descend(top_bounds, top_child, node, top_node, top_t, sp, nrx, nry, nrz, ox, oy, oz, idx_,
                               idy, idz, lo, best)
            if leaf != 0:
                first, end = leaf_range(leaf)
                for j in range(first, end):
                    k = top_leaf[j]
                    px, py, pz, qx, qy, qz = to_object(inst_w2o[k], ox, oy, oz, dx, dy, dz)
                    t, kind, prim, u, w = blas_closest(bounds, child, inst_root[k], leaf_prim, leaf_tri,
                                                       sph_center, sph_radius, sph_w2o, px, py, pz, qx, qy, qz,
                                                       lo, best, stack_node, stack_t)
                    if kind != MISS:
                        best = t
                        b_inst, b_kind, b_prim, b_u, b_v = k, kind, prim, u, w
            node, sp = pop_closer(top_node, top_t, sp, best)
            if node == 0:
                break
        t_out[i], inst_out[i], kind_out[i] = (best if b_kind != MISS else np.inf), b_inst, b_kind
        prim_out[i], u_out[i], v_out[i] = b_prim, b_u, b_v


@nb.njit(**JIT)
def _any_rays(idx, m, origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root, inst_w2o,
              bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, top_node, stack_node, out):
    """Rays idx[:m] one at a time, the first hit ending a ray's search (written out, as in _closest_rays)."""
    for q in range(m):
        i = idx[q]
        ox, oy, oz, dx, dy, dz = load_ray(origins, directions, i)
        lo, hi = t_min[i], t_max[i]
        slabs = ray_slabs(ox, oy, oz, dx, dy, dz)
        hit = False
        walk = top_walk(top_node)
        while not hit:
            k, walk = next_instance(top_bounds, top_child, top_leaf, top_node, walk, slabs, ox, oy, oz, lo, hi)
            if k < 0:
                break
            px, py, pz, qx, qy, qz = to_object(inst_w2o[k], ox, oy, oz, dx, dy, dz)
            hit = blas_any(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                           px, py, pz, qx, qy, qz, lo, hi, stack_node)
        out[i] = hit


@nb.njit(**JIT)
def closest_hit_instances(origins, directions, t_min, t_max,
                          top_bounds, top_child, top_leaf, inst_root, inst_w2o,
                          bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, width,
                          t_out, inst_out, kind_out, prim_out, u_out, v_out, blk0, blk1):
    """Closest hit of each ray (in blocks blk0..blk1 of BLOCK chunks, see threads.run_blocks) over all
    instances: t (inf on a miss), instance (-1), kind, prim, u, v. width as in trace.closest_hit_bvh."""
    (top_node, top_t, stack_node, stack_t, rr, ro, top_key, top_order, key, order, idx, res_inst, res_prim, res_u,
     res_v, spread) = _scratch(stack_size, top_bounds, top_child)
    for c in range(*chunk_span(blk0, blk1, origins.shape[0])):
        m, packet, nrx, nry, nrz, _, _, _ = load_chunk(c, origins, directions, t_min, t_max, width, idx, rr, spread)
        if packet:
            res_inst[:] = -1
            packet_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim,
                             leaf_tri, sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node, top_t,
                             stack_node, stack_t, top_key, top_order, key, order, res_inst, res_prim, res_u, res_v,
                             False)
            for r in range(PACKET):
                i = idx[r]
                if res_inst[r] >= 0:
                    kind, prim = hit_of_code(res_prim[r])
                    t_out[i], inst_out[i], kind_out[i], prim_out[i] = rr[_BEST + r], res_inst[r], kind, prim
                    u_out[i], v_out[i] = res_u[r], res_v[r]
                else:
                    t_out[i], inst_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = \
                        np.inf, -1, MISS, -1, 0.0, 0.0
        else:
            _closest_rays(idx, m, origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root,
                          inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                          top_node, top_t, stack_node, stack_t, t_out, inst_out, kind_out, prim_out, u_out, v_out)


@nb.njit(**JIT)
def any_hit_instances(origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root, inst_w2o,
                      bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, width, out,
                      blk0, blk1):
    """out[i] = whether ray i (in blocks blk0..blk1) hits any instance with t_min < t < t_max; the first hit
    ends a ray's search (a packet's, once all its rays have hit)."""
    (top_node, top_t, stack_node, stack_t, rr, ro, top_key, top_order, key, order, idx, res_inst, res_prim, res_u,
     res_v, spread) = _scratch(stack_size, top_bounds, top_child)
    for c in range(*chunk_span(blk0, blk1, origins.shape[0])):
        m, packet, nrx, nry, nrz, _, _, _ = load_chunk(c, origins, directions, t_min, t_max, width, idx, rr, spread)
        if not packet:
            _any_rays(idx, m, origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root,
                      inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, top_node,
                      stack_node, out)
            continue
        packet_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri,
                         sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node, top_t, stack_node,
                         stack_t, top_key, top_order, key, order, res_inst, res_prim, res_u, res_v, True)
        for r in range(PACKET):
            out[idx[r]] = packet_retired(rr, r)
