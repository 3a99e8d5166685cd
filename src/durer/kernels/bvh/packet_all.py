"""Every hit of a coherent ray packet (Numba): count_intersections' and list_intersections' packet walk.

The all-hits counterpart of packet.packet_traverse and instance_packets.packet_instances: a coherent chunk of
PACKET rays (chunks.load_chunk's test) walks the top-level tree and each instance's tree together, each child box
tested once for the whole packet with the same interval bounds (packet.packet_node), with no culling by t but the
rays' t_max: every box any ray enters in its range is opened. The walk is unordered (no distance sort, no entry
distances on the stack). A leaf's triangles are tested against all 16 rays in a loop that LLVM vectorises, with the
arithmetic of the one-ray watertight test (packet._edges, the same shear constants) and its tie-break on edges and
vertices, so each ray gets exactly the hits the one-ray walk (single.blas_all) gives it, t, u, v to the bit, in
another order. An instance whose moved rays no longer share direction signs and shear axes is walked one ray at a
time (blas_all). Hits are counted per ray (cnt) and, with a buffer (cap > 0 hits a ray), stored ray by ray; a ray
with more than cap hits keeps counting (its caller walks it again alone).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT, SPHERE, TRIANGLE
from ..intersect import edge_tie, sphere_hit_in_object_space
from .chunks import _BEST, _DX, _DY, _DZ, _OX, _OY, _OZ, _SZ, _TMIN, object_packet
from .layout import PACKET, leaf_range
from .packet import _any_inside, _edges, _flat, _mixed, _packet_far, packet_extents, packet_node
from .single import blas_all

HIT_CAP = 16  # hits a ray keeps in a packet's list buffer (a ray with more is walked again alone)


@nb.njit(**JIT, inline="always")
def hit_buffers(cap):
    """A packet's hit buffers for cap hits a ray: count (PACKET,) int64, t, inst, kind, prim, u, v (PACKET * cap)."""
    n = PACKET * cap
    return (np.zeros(PACKET, np.int64), np.empty(n), np.empty(n, np.int32), np.empty(n, np.int8),
            np.empty(n, np.int32), np.empty(n), np.empty(n))


@nb.njit(**JIT, inline="always")
def _record(k, t, kind, prim, u, v, inst, cnt, bufs):
    """One more hit of ray k: counted, and stored in its part of the buffers while it has room."""
    _, bt, bi, bk, bp, bu, bv = bufs
    cap = bt.shape[0] // PACKET
    n = cnt[k]
    if n < cap:
        b = k * cap + n
        bt[b], bi[b], bk[b], bp[b], bu[b], bv[b] = t, inst, kind, prim, u, v
    cnt[k] = n + 1


@nb.njit(**JIT, inline="always")
def _triangle_all(j, p, leaf_tri, kx, ky, kz, ro, inst, cnt, bufs, store):
    """Triangle slot j (triangle p) against every ray of the packet ro: the one-ray watertight test's hits."""
    base = j * 9
    ax0, ay0, az0 = (np.float64(leaf_tri[base + kx]), np.float64(leaf_tri[base + ky]),
                     np.float64(leaf_tri[base + kz]))
    bx0, by0, bz0 = (np.float64(leaf_tri[base + 3 + kx]), np.float64(leaf_tri[base + 3 + ky]),
                     np.float64(leaf_tri[base + 3 + kz]))
    cx0, cy0, cz0 = (np.float64(leaf_tri[base + 6 + kx]), np.float64(leaf_tri[base + 6 + ky]),
                     np.float64(leaf_tri[base + 6 + kz]))
    if not _any_inside(ax0, ay0, az0, bx0, by0, bz0, cx0, cy0, cz0, ro):
        return
    ties = 0
    mask = np.int64(0)  # store: the rays that hit, found by the vector loop and recorded after it
    for k in range(PACKET):
        az, bz, cz, ax, ay, bx, by, cx, cy, e0, e1, e2 = _edges(ro, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0,
                                                               cz0)
        det = e0 + e1 + e2
        t = ro[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
        on_edge = (e0 == 0.0) | (e1 == 0.0) | (e2 == 0.0)
        ties += on_edge
        flat = _flat(ro, k, det, ax, ay, az, bx, by, bz, cx, cy, cz)
        hit = ~flat & (ro[_TMIN + k] < t) & (t < ro[_BEST + k]) & ~on_edge & ~_mixed(e0, e1, e2)
        if store:
            mask |= np.int64(hit) << k
        else:
            cnt[k] += hit
    if mask:  # the hits' t, u, v again with the same arithmetic, ray by ray (few rays of a leaf's triangle)
        for k in range(PACKET):
            if (mask >> k) & 1:
                az, bz, cz, _, _, _, _, _, _, e0, e1, e2 = _edges(ro, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0,
                                                                   cz0)
                det = e0 + e1 + e2
                t = ro[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
                _record(k, t, TRIANGLE, p, e1 / det, e2 / det, inst, cnt, bufs)
    if ties:
        for k in range(PACKET):  # rays on an edge or a vertex: intersect.watertight_triangle's tie-break
            az, bz, cz, ax, ay, bx, by, cx, cy, e0, e1, e2 = _edges(ro, k, ax0, ay0, az0, bx0, by0, bz0, cx0, cy0,
                                                                   cz0)
            if not (e0 == 0.0 or e1 == 0.0 or e2 == 0.0) or _mixed(e0, e1, e2):
                continue
            if not edge_tie(e0, e1, e2, ax, ay, bx, by, cx, cy):
                continue
            det = e0 + e1 + e2
            if _flat(ro, k, det, ax, ay, az, bx, by, bz, cx, cy, cz):
                continue
            t = ro[_SZ + k] * (e0 * az + e1 * bz + e2 * cz) / det
            if ro[_TMIN + k] < t < ro[_BEST + k]:
                _record(k, t, TRIANGLE, p, e1 / det, e2 / det, inst, cnt, bufs)


@nb.njit(**JIT, inline="always")
def _sphere_all(s, sph_center, sph_radius, sph_w2o, ro, inst, cnt, bufs):
    """Sphere s against every ray of the packet: both roots in range, near one first (as single.blas_all)."""
    for k in range(PACKET):
        lo = ro[_TMIN + k]
        for _ in range(2):
            t = sphere_hit_in_object_space((ro[_OX + k], ro[_OY + k], ro[_OZ + k]),
                                           (ro[_DX + k], ro[_DY + k], ro[_DZ + k]), sph_center[s], sph_radius[s],
                                           sph_w2o[s], lo, ro[_BEST + k])
            if t == np.inf:
                break
            _record(k, t, SPHERE, s, 0.0, 0.0, inst, cnt, bufs)
            lo = t


@nb.njit(**JIT)
def packet_all_traverse(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                        nrx, nry, nrz, kx, ky, kz, ro, stack_node, key, order, inst, bufs):
    """Every hit of the coherent packet ro (object space, packet_setup's rows) in the tree at `root`, recorded as
    instance `inst` into bufs (hit_buffers; store when its buffers are not empty)."""
    cnt = bufs[0]
    store = bufs[1].shape[0] > 0
    ext = packet_extents(ro, nrx, nry, nrz)
    far = _packet_far(ro)  # the largest t_max: boxes are culled by the rays' range alone
    stack_node[0] = root
    sp = 1
    while sp > 0:
        sp -= 1
        node = stack_node[sp]
        n_in = packet_node(bounds, child, node, nrx, nry, nrz, ext, far, key, order)
        for q in range(n_in):
            c = child[node, order[q]]
            if c > 0:
                stack_node[sp] = c
                sp += 1
                continue
            first, end = leaf_range(c)
            for j in range(first, end):
                p = leaf_prim[j]
                if p >= 0:
                    _triangle_all(j, p, leaf_tri, kx, ky, kz, ro, inst, cnt, bufs, store)
                else:
                    _sphere_all(-p - 1, sph_center, sph_radius, sph_w2o, ro, inst, cnt, bufs)


@nb.njit(**JIT, inline="always")
def _instance_all(k, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, rr,
                  ro, stack_node, key, order, bufs):
    """Every hit of the packet rr in instance k: as a packet when the moved rays stay coherent, else ray by ray."""
    cnt, bt, bi, bk, bp, bu, bv = bufs
    cap = bt.shape[0] // PACKET
    coherent, nrx, nry, nrz, kx, ky, kz = object_packet(rr, ro, inst_w2o[k])
    if coherent:
        packet_all_traverse(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                            nrx, nry, nrz, kx, ky, kz, ro, stack_node, key, order, k, bufs)
        return
    for r in range(PACKET):
        a, b = r * cap, (r + 1) * cap
        before = cnt[r]
        cnt[r] = blas_all(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                          ro[_OX + r], ro[_OY + r], ro[_OZ + r], ro[_DX + r], ro[_DY + r], ro[_DZ + r],
                          ro[_TMIN + r], ro[_BEST + r], stack_node, bt[a:b], bp[a:b], bk[a:b], bu[a:b], bv[a:b],
                          before)
        for h in range(before, min(cnt[r], cap)):
            bi[a + h] = k


@nb.njit(**JIT)
def packet_all_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri,
                         sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node, stack_node, top_key,
                         top_order, key, order, bufs):
    """Every hit of the coherent packet rr (world space, packet_setup's rows) over all instances: the counts in
    bufs[0] (reset here), the hits in the other buffers when they have room."""
    bufs[0][:] = 0
    ext = packet_extents(rr, nrx, nry, nrz)
    far = _packet_far(rr)
    top_node[0] = 0  # the top-level tree's root
    sp = 1
    while sp > 0:
        sp -= 1
        node = top_node[sp]
        n_in = packet_node(top_bounds, top_child, node, nrx, nry, nrz, ext, far, top_key, top_order)
        for q in range(n_in):
            c = top_child[node, top_order[q]]
            if c > 0:
                top_node[sp] = c
                sp += 1
                continue
            first, end = leaf_range(c)
            for j in range(first, end):
                _instance_all(top_leaf[j], inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center,
                              sph_radius, sph_w2o, rr, ro, stack_node, key, order, bufs)
