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

from ..common import JIT, MISS, SPHERE, TRIANGLE
from ..intersect import shear_axes
from ..small_sort import insert_ascending
from .instances import to_object
from .layout import (
    BLOCK,
    FAR_WIDEN,
    HI_X,
    HI_Y,
    HI_Z,
    LO_X,
    LO_Y,
    LO_Z,
    NODE_FLOATS,
    PACKET,
    WIDTH,
    leaf_range,
    packet_spread_limit,
)
from .packet import (
    _BEST,
    _DET,
    _DX,
    _DY,
    _DZ,
    _E1,
    _E2,
    _EXT,
    _EXT_INV,
    _EXT_TMIN,
    _NROW,
    _OX,
    _OY,
    _OZ,
    _PRIM,
    _TMIN,
    _nonzero,
    _packet_far,
    _packet_slab,
    chunk_rays,
    packet_constants,
    packet_setup,
    packet_traverse,
)
from .single import blas_any, blas_closest, descend, load_ray, next_leaf, pop_closer, ray_setup


@nb.njit(**JIT, inline="always")
def _scratch(stack_size):
    """Per-call scratch: both levels' stacks (nodes, entry distances), the world and object-space packet rows,
    both levels' child orders (key, order), ray indices, and the packet's best hit so far (instance, primitive
    code as in packet.py's _PRIM row, u, v)."""
    return (np.empty(stack_size, np.int32), np.empty(stack_size), np.empty(stack_size, np.int32),
            np.empty(stack_size), np.empty(_NROW * PACKET), np.empty(_NROW * PACKET), np.empty(WIDTH),
            np.empty(WIDTH, np.int64), np.empty(WIDTH), np.empty(WIDTH, np.int64), np.empty(PACKET, np.int64),
            np.empty(PACKET, np.int64), np.empty(PACKET), np.empty(PACKET), np.empty(PACKET))


@nb.njit(**JIT, inline="always")
def _object_packet(rr, ro, w2o):
    """The packet rr moved into object space (rows of ro, t range and best so far copied): returns (coherent,
    nrx, nry, nrz, kx, ky, kz), coherent when the moved rays share direction signs and shear axes; only then
    are their extremes and per-ray constants computed, as packet.packet_setup computes them."""
    for k in range(PACKET):
        (ro[_OX + k], ro[_OY + k], ro[_OZ + k], ro[_DX + k], ro[_DY + k],
         ro[_DZ + k]) = to_object(w2o, rr[_OX + k], rr[_OY + k], rr[_OZ + k], rr[_DX + k], rr[_DY + k], rr[_DZ + k])
        ro[_TMIN + k], ro[_BEST + k] = rr[_TMIN + k], rr[_BEST + k]
    dx0, dy0, dz0 = ro[_DX], ro[_DY], ro[_DZ]
    kx0, ky0, kz0 = shear_axes(dx0, dy0, dz0)
    s0 = (dx0 < 0.0) + 2 * (dy0 < 0.0) + 4 * (dz0 < 0.0)
    bad = 0
    for k in range(PACKET):
        dx, dy, dz = ro[_DX + k], ro[_DY + k], ro[_DZ + k]
        ax, ay, az = abs(dx), abs(dy), abs(dz)
        kz = 0 if (ax >= ay) & (ax >= az) else (1 if ay >= az else 2)  # shear_axes' kz; kx, ky follow the signs
        bad += ((dx < 0.0) + 2 * (dy < 0.0) + 4 * (dz < 0.0) != s0) | (kz != kz0)
    if bad:
        return False, LO_X, LO_Y, LO_Z, kx0, ky0, kz0
    for axis in range(3):  # the extremes packet_traverse reads: origins, reciprocal directions, t_min
        lo = hi = ro[_OX + axis * PACKET]
        dlo = dhi = _nonzero(ro[_DX + axis * PACKET])
        for k in range(1, PACKET):
            lo, hi = min(lo, ro[_OX + axis * PACKET + k]), max(hi, ro[_OX + axis * PACKET + k])
            dk = _nonzero(ro[_DX + axis * PACKET + k])
            dlo, dhi = min(dlo, dk), max(dhi, dk)
        ro[_EXT + 2 * axis], ro[_EXT + 2 * axis + 1] = lo, hi
        ro[_EXT + _EXT_INV + 2 * axis], ro[_EXT + _EXT_INV + 2 * axis + 1] = 1.0 / dhi, 1.0 / dlo
    ro[_EXT + _EXT_TMIN] = rr[_EXT + _EXT_TMIN]
    nrx, nry, nrz = packet_constants(ro, kx0, ky0, kz0)
    return True, nrx, nry, nrz, kx0, ky0, kz0


@nb.njit(**JIT, inline="always")
def _trace_instance(k, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                    rr, ro, stack_node, stack_t, key, order, res_inst, res_prim, res_u, res_v, any_mode):
    """The packet rr against instance k: its closer hits recorded (rr's best, res_*), or (any_mode) the rays
    that hit something retired (best -inf)."""
    root = inst_root[k]
    coherent, nrx, nry, nrz, kx, ky, kz = _object_packet(rr, ro, inst_w2o[k])
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
    first, skipping boxes beyond every ray's best hit so far; each instance met is traced by _trace_instance.
    res_inst must start at -1: it ends as the instance of each ray's closest hit (closest mode)."""
    # the packet's extremes (packet_setup): origins, reciprocal directions (one sign per axis), t_min
    oxl, oxh, oyl, oyh, ozl, ozh = rr[_EXT], rr[_EXT + 1], rr[_EXT + 2], rr[_EXT + 3], rr[_EXT + 4], rr[_EXT + 5]
    ixl, ixh = rr[_EXT + _EXT_INV], rr[_EXT + _EXT_INV + 1]
    iyl, iyh = rr[_EXT + _EXT_INV + 2], rr[_EXT + _EXT_INV + 3]
    izl, izh = rr[_EXT + _EXT_INV + 4], rr[_EXT + _EXT_INV + 5]
    tlo = rr[_EXT + _EXT_TMIN]
    onx, ofx = (oxh, oxl) if nrx == LO_X else (oxl, oxh)
    ony, ofy = (oyh, oyl) if nry == LO_Y else (oyl, oyh)
    onz, ofz = (ozh, ozl) if nrz == LO_Z else (ozl, ozh)
    top_node[0] = 0  # the top-level tree's root
    top_t[0] = -np.inf
    sp = 1
    far = _packet_far(rr)
    while sp > 0:
        sp -= 1
        if far == -np.inf:
            break  # every ray has retired (any-hit)
        if top_t[sp] > far + abs(far) * FAR_WIDEN:
            continue
        node = top_node[sp]
        base = node * NODE_FLOATS
        n_in = 0
        for lane in range(WIDTH):  # the child boxes against the packet as a whole, as packet_traverse tests them
            if top_child[node, lane] == 0:
                continue
            b = base + lane
            tn, tf = tlo, far
            a, e = _packet_slab(top_bounds[b + nrx], top_bounds[b + (LO_X + HI_X) - nrx], onx, ofx, ixl, ixh)
            tn, tf = max(tn, a), min(tf, e)
            a, e = _packet_slab(top_bounds[b + nry], top_bounds[b + (LO_Y + HI_Y) - nry], ony, ofy, iyl, iyh)
            tn, tf = max(tn, a), min(tf, e)
            a, e = _packet_slab(top_bounds[b + nrz], top_bounds[b + (LO_Z + HI_Z) - nrz], onz, ofz, izl, izh)
            tn, tf = max(tn, a), min(tf, e)
            if tn <= tf + abs(tf) * FAR_WIDEN:
                n_in = insert_ascending(top_key, top_order, n_in, tn, lane)  # nearest first
        for q in range(n_in):
            c = top_child[node, top_order[q]]
            if c < 0:
                first, end = leaf_range(c)
                for j in range(first, end):
                    _trace_instance(top_leaf[j], inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri,
                                    sph_center, sph_radius, sph_w2o, rr, ro, stack_node, stack_t, key, order,
                                    res_inst, res_prim, res_u, res_v, any_mode)
                far = _packet_far(rr)
        for q in range(n_in - 1, -1, -1):  # inner children onto the stack, farthest first
            c = top_child[node, top_order[q]]
            if c > 0:
                top_node[sp] = c
                top_t[sp] = top_key[q]
                sp += 1


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
        idx_, idy, idz, nrx, nry, nrz, _, _, _, _, _, _, _, _, _ = ray_setup(ox, oy, oz, dx, dy, dz)
        node, sp = 0, 0  # the top-level tree's root
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
        idx_, idy, idz, nrx, nry, nrz, _, _, _, _, _, _, _, _, _ = ray_setup(ox, oy, oz, dx, dy, dz)
        hit = False
        top_node[0] = 0
        sp = 1
        while not hit:
            leaf, sp = next_leaf(top_bounds, top_child, top_node, sp, nrx, nry, nrz, ox, oy, oz, idx_, idy, idz,
                                 lo, hi)
            if leaf == 0:
                break
            first, end = leaf_range(leaf)
            for j in range(first, end):
                k = top_leaf[j]
                px, py, pz, qx, qy, qz = to_object(inst_w2o[k], ox, oy, oz, dx, dy, dz)
                if blas_any(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                            px, py, pz, qx, qy, qz, lo, hi, stack_node):
                    hit = True
                    break
        out[i] = hit


@nb.njit(**JIT)
def closest_hit_instances(origins, directions, t_min, t_max,
                          top_bounds, top_child, top_leaf, inst_root, inst_w2o,
                          bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, width,
                          t_out, inst_out, kind_out, prim_out, u_out, v_out, blk0, blk1):
    """Closest hit of each ray (in blocks blk0..blk1 of BLOCK chunks, see threads.run_blocks) over all
    instances: t (inf on a miss), instance (-1), kind, prim, u, v. width as in trace.closest_hit_bvh."""
    n = origins.shape[0]
    n_chunks = (n + PACKET - 1) // PACKET
    (top_node, top_t, stack_node, stack_t, rr, ro, top_key, top_order, key, order, idx,
     res_inst, res_prim, res_u, res_v) = _scratch(stack_size)
    spread = packet_spread_limit(top_bounds, top_child)
    for blk in range(blk0, blk1):
        for c in range(blk * BLOCK, min(n_chunks, (blk + 1) * BLOCK)):
            m = chunk_rays(c, n, width, idx)
            coherent, nrx, nry, nrz, _, _, _ = packet_setup(origins, directions, t_min, t_max, idx, m, rr, spread)
            if coherent and m == PACKET:
                res_inst[:] = -1
                packet_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim,
                                 leaf_tri, sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node, top_t,
                                 stack_node, stack_t, top_key, top_order, key, order, res_inst, res_prim,
                                 res_u, res_v, False)
                for r in range(PACKET):
                    i = idx[r]
                    if res_inst[r] >= 0:
                        pr = res_prim[r]
                        t_out[i], inst_out[i] = rr[_BEST + r], res_inst[r]
                        kind_out[i] = TRIANGLE if pr >= 0.0 else SPHERE
                        prim_out[i] = np.int32(pr) if pr >= 0.0 else np.int32(-pr - 1.0)
                        u_out[i], v_out[i] = res_u[r], res_v[r]
                    else:
                        t_out[i], inst_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = \
                            np.inf, -1, MISS, -1, 0.0, 0.0
                continue
            _closest_rays(idx, m, origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root,
                          inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                          top_node, top_t, stack_node, stack_t, t_out, inst_out, kind_out, prim_out, u_out,
                          v_out)


@nb.njit(**JIT)
def any_hit_instances(origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root, inst_w2o,
                      bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size, width, out,
                      blk0, blk1):
    """out[i] = whether ray i (in blocks blk0..blk1) hits any instance with t_min < t < t_max; the first hit
    ends a ray's search (a packet's, once all its rays have hit)."""
    n = origins.shape[0]
    n_chunks = (n + PACKET - 1) // PACKET
    (top_node, top_t, stack_node, stack_t, rr, ro, top_key, top_order, key, order, idx,
     res_inst, res_prim, res_u, res_v) = _scratch(stack_size)
    spread = packet_spread_limit(top_bounds, top_child)
    for blk in range(blk0, blk1):
        for c in range(blk * BLOCK, min(n_chunks, (blk + 1) * BLOCK)):
            m = chunk_rays(c, n, width, idx)
            coherent, nrx, nry, nrz, _, _, _ = packet_setup(origins, directions, t_min, t_max, idx, m, rr, spread)
            if coherent and m == PACKET:
                packet_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim,
                                 leaf_tri, sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node, top_t,
                                 stack_node, stack_t, top_key, top_order, key, order, res_inst, res_prim,
                                 res_u, res_v, True)
                for r in range(PACKET):
                    out[idx[r]] = rr[_BEST + r] == -np.inf
                continue
            _any_rays(idx, m, origins, directions, t_min, t_max, top_bounds, top_child, top_leaf, inst_root,
                      inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, top_node,
                      stack_node, out)
