"""The one-level kernels (Numba): batches of rays against one tree and the planes beside it.

Rays go in chunks of PACKET: a coherent chunk is traced as a packet (kernels/bvh/packet.py), any other one ray at a
time (kernels/bvh/single.py). The kernels are serial and nogil; threads.run_blocks spreads their blocks over
threads (cheaper to compile and to load from the cache than a parallel=True kernel).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT, MISS, PLANE
from .chunks import (
    _BEST,
    _DX,
    _DY,
    _DZ,
    _OX,
    _OY,
    _OZ,
    _TMIN,
    chunk_rays,
    chunk_span,
    packet_rows,
    packet_setup,
)
from .layout import PACKET, TILE, WIDTH, packet_spread_limit
from .packet import hit_of_code, packet_barycentrics, packet_hit, packet_retired, packet_traverse
from .single import blas_any, blas_closest, load_ray, planes_closest


def image_width(shape: tuple[int, ...]) -> int:
    """The `width` argument of closest_hit_bvh / any_hit_bvh for rays laid out as `shape` (leading dimensions):
    the image width when the rays form an image whose sides are multiples of 4 (4 x 4 tile packets), else 0."""
    if len(shape) >= 2 and shape[-1] % TILE == 0 and shape[-2] % TILE == 0 and shape[-1] > 0 and shape[-2] > 0:
        return int(shape[-1])
    return 0


@nb.njit(**JIT, inline="always")
def scratch(stack_size, bounds, child):
    """Per-call scratch of the one-level kernels, allocated once and reused by every packet and ray: the stack
    (nodes, entry distances), the packet rows, the packet's child order, ray indices, the packet's planes; and
    the tree's packet_spread_limit."""
    return (np.empty(stack_size, np.int32), np.empty(stack_size), packet_rows(), np.empty(WIDTH),
            np.empty(WIDTH, np.int64), np.empty(PACKET, np.int64), np.empty(PACKET, np.int32),
            packet_spread_limit(bounds, child))


@nb.njit(**JIT)
def closest_hit_bvh(origins, directions, t_min, t_max, bounds, child, leaf_prim, leaf_tri,
                    sph_center, sph_radius, sph_w2o, pl_normal, pl_offset, stack_size,
                    width, t_out, kind_out, prim_out, u_out, v_out, blk0, blk1):
    """Closest hit of rays in blocks blk0..blk1 (BLOCK * PACKET rays each) against one tree (root 0) and the
    planes beside it; fills the Hits arrays. Chunks of PACKET rays that are coherent go through
    packet_traverse, the others one ray at a time. Serial and nogil: run_blocks spreads the blocks over
    threads (cheaper to compile and to load from the cache than a parallel=True kernel)."""
    stack_node, stack_t, rr, key, order, idx, pprims, spread = scratch(stack_size, bounds, child)
    for c in range(*chunk_span(blk0, blk1, origins.shape[0])):
        m = chunk_rays(c, origins.shape[0], width, idx)
        coherent, nrx, nry, nrz, kx, ky, kz = packet_setup(origins, directions, t_min, t_max, idx, m, rr, spread)
        if coherent and m == PACKET:
            for k in range(PACKET):
                best, pprims[k] = planes_closest(pl_normal, pl_offset, rr[_OX + k], rr[_OY + k], rr[_OZ + k],
                                                 rr[_DX + k], rr[_DY + k], rr[_DZ + k], rr[_TMIN + k], rr[_BEST + k])
                rr[_BEST + k] = best
            packet_traverse(bounds, child, np.int32(0), leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                            nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, np.bool_(False))
            packet_barycentrics(rr)
            for k in range(PACKET):
                i = idx[k]
                t, code, u, v = packet_hit(rr, k)
                if code > -np.inf:
                    kind, prim = hit_of_code(code)
                    t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = t, kind, prim, u, v
                elif pprims[k] >= 0:
                    t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = t, PLANE, pprims[k], 0.0, 0.0
                else:
                    t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = np.inf, MISS, -1, 0.0, 0.0
            continue
        for q in range(m):
            i = idx[q]
            ox, oy, oz, dx, dy, dz = load_ray(origins, directions, i)
            lo = t_min[i]
            best, pprim = planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, lo, t_max[i])
            t, kind, prim, u, v = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius,
                                               sph_w2o, ox, oy, oz, dx, dy, dz, lo, best, stack_node, stack_t)
            if kind == MISS and pprim >= 0:
                t, kind, prim = best, PLANE, pprim
            t_out[i], kind_out[i], prim_out[i], u_out[i], v_out[i] = t, kind, prim, u, v


@nb.njit(**JIT)
def any_hit_bvh(origins, directions, t_min, t_max, bounds, child, leaf_prim, leaf_tri,
                sph_center, sph_radius, sph_w2o, pl_normal, pl_offset, stack_size, width, out, blk0, blk1):
    """out[i] = whether ray i (in blocks blk0..blk1) hits anything with t_min < t < t_max; planes first, then
    the tree (in packets when coherent, as in closest_hit_bvh)."""
    stack_node, stack_t, rr, key, order, idx, pprims, spread = scratch(stack_size, bounds, child)
    for c in range(*chunk_span(blk0, blk1, origins.shape[0])):
        m = chunk_rays(c, origins.shape[0], width, idx)
        coherent, nrx, nry, nrz, kx, ky, kz = packet_setup(origins, directions, t_min, t_max, idx, m, rr, spread)
        if not (coherent and m == PACKET):
            for q in range(m):
                i = idx[q]
                ox, oy, oz, dx, dy, dz = load_ray(origins, directions, i)
                _, pprim = planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, t_min[i], t_max[i])
                out[i] = pprim >= 0 or blas_any(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius,
                                                sph_w2o, ox, oy, oz, dx, dy, dz, t_min[i], t_max[i], stack_node)
            continue
        for k in range(PACKET):
            _, pprim = planes_closest(pl_normal, pl_offset, rr[_OX + k], rr[_OY + k], rr[_OZ + k],
                                      rr[_DX + k], rr[_DY + k], rr[_DZ + k], rr[_TMIN + k], rr[_BEST + k])
            if pprim >= 0:
                rr[_BEST + k] = -np.inf
        packet_traverse(bounds, child, np.int32(0), leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                        nrx, nry, nrz, kx, ky, kz, rr, stack_node, stack_t, key, order, np.bool_(True))
        for k in range(PACKET):
            out[idx[k]] = packet_retired(rr, k)
