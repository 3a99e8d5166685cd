"""The query API's passes (Numba): load, check, trace and write out one band of the user's rays at a time.

Each work item (threads.run_pieces hands out bands k0..k1) copies a band of rays into float64 scratch while
checking it (bands.load_band), traces the scratch with the ordinary kernels (trace.py's one-level packet kernels,
or instance_packets' two-level ones when a shape is placed twice) and writes every output the user gets straight from
the scratch while it is in cache: t, instance and primitive ids, barycentrics and world-space normals. A band
with a bad ray is not traced (the caller raises). The arithmetic is the kernels' own, so the answers are those of
tracing the whole batch converted to float64 up front, to the bit.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT, MISS, SPHERE, TRIANGLE
from .bands import band_scratch, load_band, ray_at
from .chunks import load_chunk
from .instance_packets import _scratch, any_hit_instances, closest_hit_instances
from .instances import all_hits_instances, hit_normal, next_instance, ray_slabs, to_object, top_walk
from .layout import BLOCK, PACKET
from .packet_all import HIT_CAP, hit_buffers, packet_all_instances
from .queued import blas_count, ring_for
from .single import blas_all, load_ray
from .trace import any_hit_bvh, closest_hit_bvh


@nb.njit(**JIT, inline="always")
def n_blocks_of(m):
    """Blocks (BLOCK packets of PACKET rays: the traced kernels' unit of work) covering m rays."""
    return (m + PACKET * BLOCK - 1) // (PACKET * BLOCK)


@nb.njit(**JIT, inline="always")
def _write_hits(origins, directions, r0, m, t, kind, u, v, inst_out, prim_out, inst_shape, tri_off, tri_normals,
                inst_w2o, inst_sign, sph_center, t_out, uv_out, normal_out):
    """Finish rays r0..r0+m, whose instance and (shape-local) primitive ids are in the outputs and whose t, kind,
    u, v are in band scratch (float64): t, barycentrics and world-space normals (instances.hit_normal, from the
    world ray) computed in float64 and stored in the outputs' type (float32 outputs get them rounded once), and
    primitive 0 for a sphere. One pass over the band, while its scratch is in cache."""
    for j in range(m):
        i = r0 + j
        t_out[i] = t[j]
        uv_out[i, 0], uv_out[i, 1] = u[j], v[j]
        kj = kind[j]
        if kj == MISS:
            normal_out[i, 0], normal_out[i, 1], normal_out[i, 2] = 0.0, 0.0, 0.0
            continue
        if kj == SPHERE:  # only a sphere's normal needs the world ray (read again from the user's arrays)
            ox, oy, oz, dx, dy, dz = ray_at(origins, directions, i)
            normal_out[i, 0], normal_out[i, 1], normal_out[i, 2] = hit_normal(
                ox, oy, oz, dx, dy, dz, t[j], inst_out[i], kj, prim_out[i], inst_shape, tri_off,
                tri_normals, inst_w2o, inst_sign, sph_center)
            prim_out[i] = 0
        else:
            normal_out[i, 0], normal_out[i, 1], normal_out[i, 2] = hit_normal(
                0.0, 0.0, 0.0, 0.0, 0.0, 0.0, t[j], inst_out[i], kj, prim_out[i], inst_shape, tri_off,
                tri_normals, inst_w2o, inst_sign, sph_center)


@nb.njit(**JIT, inline="always")
def _write_lone_hits(origins, directions, r0, m, t, kind, u, v, inst_out, prim_out, inst_shape, tri_off,
                     tri_normals, inst_w2o, inst_sign, sph_center, t_out, uv_out, normal_out):
    """_write_hits for a lone instance (every hit instance 0's, ids already in the outputs): its matrix, sign and
    first triangle read once a band, and every ray's normal computed without a branch on its kind (a miss or a
    sphere reads triangle 0's normal and stores zeros), by hit_normal's operations in its order, so the same
    bits; then sphere hits, if any, as _write_hits does them. Measured 0.95x (1.1M camera rays) and 0.96x
    (bunny, incoherent) the CPU time of cast_rays' pass through _write_hits (benchmarks/README.md)."""
    w = inst_w2o[0]
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = (w[0, 0], w[0, 1], w[0, 2], w[1, 0], w[1, 1], w[1, 2],
                                                   w[2, 0], w[2, 1], w[2, 2])
    sign = inst_sign[0]
    off = np.uint64(tri_off[inst_shape[0]])
    others = 0
    for j in range(m):
        i = r0 + j
        t_out[i] = t[j]
        uv_out[i, 0], uv_out[i, 1] = u[j], v[j]
        tri = kind[j] == TRIANGLE
        others += (kind[j] != TRIANGLE) & (kind[j] != MISS)
        q = off + np.uint64(prim_out[i] if tri else 0)
        ax, ay, az = tri_normals[q, 0], tri_normals[q, 1], tri_normals[q, 2]
        nx = sign * (m00 * ax + m10 * ay + m20 * az)
        ny = sign * (m01 * ax + m11 * ay + m21 * az)
        nz = sign * (m02 * ax + m12 * ay + m22 * az)
        length = np.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 0.0:
            nx, ny, nz = nx / length, ny / length, nz / length
        normal_out[i, 0], normal_out[i, 1], normal_out[i, 2] = (nx, ny, nz) if tri else (0.0, 0.0, 0.0)
    if others:
        for j in range(m):
            if kind[j] == SPHERE:
                i = r0 + j
                ox, oy, oz, dx, dy, dz = ray_at(origins, directions, i)
                normal_out[i, 0], normal_out[i, 1], normal_out[i, 2] = hit_normal(
                    ox, oy, oz, dx, dy, dz, t[j], 0, SPHERE, prim_out[i], inst_shape, tri_off, tri_normals, inst_w2o,
                    inst_sign, sph_center)
                prim_out[i] = 0


@nb.njit(**JIT)
def closest_one_level(origins, directions, t_min, t_max, w2o, moved, tree, width, band, tri_inst, tri_local,
                      sph_inst, sph_prim, inst_shape, tri_off, tri_normals, inst_w2o, inst_sign, blas_sph_center,
                      t_out, inst_out, prim_out, uv_out, normal_out, first, k0, k1):
    """cast_rays through one tree (trace.closest_hit_bvh; tree = its arguments, bounds .. stack size): a lone
    instance's own tree (its rays moved into its object space when `moved`), or the world tree of several
    instances, whose triangle and sphere ids tri_inst / tri_local / sph_inst / sph_prim map back to (instance,
    primitive); with none (empty maps) every hit is instance 0's. Bands k0..k1 of `band` rays; first[k]: band k's
    problems (bands.load_band). The query kernels take a tree as one tuple and pass it on spread (*tree): one
    unboxing a band, and the traversal kernels keep their positional arrays."""
    mapped = tri_inst.shape[0] + sph_inst.shape[0] > 0
    o, d, lo, hi = band_scratch(band)
    t, kind, u, v = np.empty(band), np.empty(band, np.int8), np.empty(band), np.empty(band)
    for k in range(k0, k1):
        r0, m, clean = load_band(origins, directions, t_min, t_max, w2o, moved, k, band, o, d, lo, hi, first)
        if not clean:
            continue
        closest_hit_bvh(o[:m], d[:m], lo[:m], hi[:m], *tree, width, t[:m], kind[:m], prim_out[r0:r0 + m], u[:m],
                        v[:m], 0, n_blocks_of(m))
        if not mapped:
            for j in range(m):
                inst_out[r0 + j] = -1 if kind[j] == MISS else 0
            _write_lone_hits(origins, directions, r0, m, t, kind, u, v, inst_out, prim_out, inst_shape, tri_off,
                             tri_normals, inst_w2o, inst_sign, blas_sph_center, t_out, uv_out, normal_out)
            continue
        for j in range(m):
            i = r0 + j
            p = prim_out[i]
            if kind[j] == MISS:
                inst_out[i] = -1
            elif kind[j] == TRIANGLE:
                inst_out[i], prim_out[i] = tri_inst[p], tri_local[p]
            else:
                inst_out[i], prim_out[i] = sph_inst[p], sph_prim[p]
        _write_hits(origins, directions, r0, m, t, kind, u, v, inst_out, prim_out, inst_shape, tri_off, tri_normals,
                    inst_w2o, inst_sign, blas_sph_center, t_out, uv_out, normal_out)


@nb.njit(**JIT, inline="always")
def _world_band(origins, directions, t_min, t_max, tree, k, band, o, d, lo, hi, first):
    """bands.load_band for the two-level kernels (tree = their tree arguments, top level first): world rays."""
    inst_w2o = tree[4]
    return load_band(origins, directions, t_min, t_max, inst_w2o[0], False, k, band, o, d, lo, hi, first)


@nb.njit(**JIT)
def closest_two_level(origins, directions, t_min, t_max, tree, width, band, inst_shape, tri_off, tri_normals,
                      inst_sign, t_out, inst_out, prim_out, uv_out, normal_out, first, k0, k1):
    """cast_rays through the two-level tree (instance_packets.closest_hit_instances; tree = its arguments, top
    level first, through the stack size), when a shape is placed twice; width as in closest_one_level."""
    inst_w2o, sph_center = tree[4], tree[9]
    o, d, lo, hi = band_scratch(band)
    t, kind, u, v = np.empty(band), np.empty(band, np.int8), np.empty(band), np.empty(band)
    for k in range(k0, k1):
        r0, m, clean = _world_band(origins, directions, t_min, t_max, tree, k, band, o, d, lo, hi, first)
        if not clean:
            continue
        closest_hit_instances(o[:m], d[:m], lo[:m], hi[:m], *tree, width, t[:m], inst_out[r0:r0 + m], kind[:m],
                              prim_out[r0:r0 + m], u[:m], v[:m], 0, n_blocks_of(m))
        _write_hits(origins, directions, r0, m, t, kind, u, v, inst_out, prim_out, inst_shape, tri_off, tri_normals,
                    inst_w2o, inst_sign, sph_center, t_out, uv_out, normal_out)


@nb.njit(**JIT)
def occluded_one_level(origins, directions, t_min, t_max, w2o, moved, tree, width, band, out, first, k0, k1):
    """test_occlusions through one tree (trace.any_hit_bvh), as closest_one_level."""
    o, d, lo, hi = band_scratch(band)
    for k in range(k0, k1):
        r0, m, clean = load_band(origins, directions, t_min, t_max, w2o, moved, k, band, o, d, lo, hi, first)
        if clean:
            any_hit_bvh(o[:m], d[:m], lo[:m], hi[:m], *tree, width, out[r0:r0 + m], 0, n_blocks_of(m))


@nb.njit(**JIT)
def occluded_two_level(origins, directions, t_min, t_max, tree, width, band, out, first, k0, k1):
    """test_occlusions through the two-level tree (instance_packets.any_hit_instances), as closest_two_level."""
    o, d, lo, hi = band_scratch(band)
    for k in range(k0, k1):
        r0, m, clean = _world_band(origins, directions, t_min, t_max, tree, k, band, o, d, lo, hi, first)
        if clean:
            any_hit_instances(o[:m], d[:m], lo[:m], hi[:m], *tree, width, out[r0:r0 + m], 0, n_blocks_of(m))


@nb.njit(**JIT)
def crossings_two_level(origins, directions, t_min, t_max, tree, band, offsets, out_t, out_inst, out_kind, out_prim,
                        out_u, out_v, counts, first, k0, k1):
    """count_intersections / list_intersections (instances.all_hits_instances; tree as in closest_two_level):
    counts[i] of every ray, and with outputs long enough its hits from offsets[i] on (offsets into the whole
    batch's outputs)."""
    o, d, lo, hi = band_scratch(band)
    for k in range(k0, k1):
        r0, m, clean = _world_band(origins, directions, t_min, t_max, tree, k, band, o, d, lo, hi, first)
        if clean:
            all_hits_instances(o[:m], d[:m], lo[:m], hi[:m], *tree, offsets[r0:r0 + m], out_t, out_inst, out_kind,
                               out_prim, out_u, out_v, counts[r0:r0 + m], 0, n_blocks_of(m))


@nb.njit(**JIT)
def _ray_hits(o, d, j, lo, hi, tree, top_node, stack_node, bufs):
    """Every hit of ray j of the band scratch o, d with lo < t < hi, by the one-ray two-level walk
    (instances.next_instance, single.blas_all): returns the count; the hits go into bufs' t, inst, kind, prim, u,
    v arrays from 0 on while they have room (empty: counting alone). Called, not inlined: its arguments are the
    band's float64 scratch whatever the caller's rays, so the walk compiles once instead of once per ray layout
    of each query kernel (eleven in the test suite)."""
    (top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center,
     sph_radius, sph_w2o, _) = tree
    _, bt, bi, bk, bp, bu, bv = bufs
    room = bt.shape[0]
    ox, oy, oz, dx, dy, dz = load_ray(o, d, j)
    slabs = ray_slabs(ox, oy, oz, dx, dy, dz)
    total = 0
    walk = top_walk(top_node)
    while True:
        q, walk = next_instance(top_bounds, top_child, top_leaf, top_node, walk, slabs, ox, oy, oz, lo, hi)
        if q < 0:
            return total
        px, py, pz, qx, qy, qz = to_object(inst_w2o[q], ox, oy, oz, dx, dy, dz)
        before = total
        total = blas_all(bounds, child, inst_root[q], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                         px, py, pz, qx, qy, qz, lo, hi, stack_node, bt, bp, bk, bu, bv, total)
        for h in range(before, min(total, room)):
            bi[h] = q


@nb.njit(**JIT)
def _chunk_counts(o, d, lo, hi, idx, m, tree, top_node, ring, counts):
    """counts[idx[q]] = every hit of ray idx[q] (q < m) of the band scratch o, d with lo < t < hi: the one-ray
    two-level walk (instances.next_instance) into each instance's tree by the queued count-only walk
    (queued.blas_count: no hit stored). Called once a chunk, not inlined: its arguments are the band's float64
    scratch whatever the caller's rays, so it compiles once, and the tree's arrays are passed once per chunk
    rather than once per ray."""
    (top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center,
     sph_radius, sph_w2o, _) = tree
    for q in range(m):
        j = idx[q]
        ox, oy, oz, dx, dy, dz = load_ray(o, d, j)
        slabs = ray_slabs(ox, oy, oz, dx, dy, dz)
        total = 0
        walk = top_walk(top_node)
        while True:
            k, walk = next_instance(top_bounds, top_child, top_leaf, top_node, walk, slabs, ox, oy, oz, lo[j], hi[j])
            if k < 0:
                break
            px, py, pz, qx, qy, qz = to_object(inst_w2o[k], ox, oy, oz, dx, dy, dz)
            total += blas_count(bounds, child, inst_root[k], leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                px, py, pz, qx, qy, qz, lo[j], hi[j], ring)
        counts[j] = total


@nb.njit(**JIT)
def count_crossings(origins, directions, t_min, t_max, tree, band, width, counts, first, k0, k1):
    """count_intersections (tree as in closest_two_level): counts[i] of every ray of bands k0..k1. Coherent
    chunks of PACKET rays (4 x 4 tiles when the rays are an image `width` wide) go through
    packet_all.packet_all_instances, the others through the one-ray count-only walk (_chunk_counts): the same
    hits either way."""
    (top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim, leaf_tri, sph_center,
     sph_radius, sph_w2o, stack_size) = tree
    (top_node, _, stack_node, _, rr, ro, top_key, top_order, key, order, idx, _, _, _, _,
     spread) = _scratch(stack_size, top_bounds, top_child)
    ring = ring_for(stack_size)
    bufs = hit_buffers(0)
    cnt = bufs[0]
    o, d, lo, hi = band_scratch(band)
    for k in range(k0, k1):
        r0, m, clean = _world_band(origins, directions, t_min, t_max, tree, k, band, o, d, lo, hi, first)
        if not clean:
            continue
        for c in range((m + PACKET - 1) // PACKET):
            mm, packet, nrx, nry, nrz, _, _, _ = load_chunk(c, o[:m], d[:m], lo[:m], hi[:m], width, idx, rr, spread)
            if packet:
                packet_all_instances(top_bounds, top_child, top_leaf, inst_root, inst_w2o, bounds, child, leaf_prim,
                                     leaf_tri, sph_center, sph_radius, sph_w2o, nrx, nry, nrz, rr, ro, top_node,
                                     stack_node, top_key, top_order, key, order, bufs)
                for r in range(PACKET):
                    counts[r0 + idx[r]] = cnt[r]
                continue
            _chunk_counts(o, d, lo, hi, idx, mm, tree, top_node, ring, counts[r0:r0 + m])


@nb.njit(**JIT, inline="always")
def _before(ta, ia, ka, pa, tb, ib, kb, pb):
    """Whether hit a comes before hit b of the same ray: by t, then instance, kind and primitive, a total order
    (no two hits of a ray share all four but a sphere's two roots, whose t differ), so the packet and the one-ray
    walk, which meet a ray's hits in different orders, list them the same."""
    if ta != tb:
        return ta < tb
    if ia != ib:
        return ia < ib
    if ka != kb:
        return ka < kb
    return pa < pb


@nb.njit(**JIT, inline="always")
def _sort_hits(t, inst, kind, prim, u, v, a, b):
    """Hits a..b of one ray sorted by _before in place (insertion sort: a ray has a few hits, so this beats one
    global lexsort)."""
    for i in range(a + 1, b):
        ti, ni, ki, pi, ui, vi = t[i], inst[i], kind[i], prim[i], u[i], v[i]
        j = i - 1
        while j >= a and _before(ti, ni, ki, pi, t[j], inst[j], kind[j], prim[j]):
            t[j + 1], inst[j + 1], kind[j + 1], prim[j + 1], u[j + 1], v[j + 1] = t[j], inst[j], kind[j], prim[j], \
                u[j], v[j]
            j -= 1
        t[j + 1], inst[j + 1], kind[j + 1], prim[j + 1], u[j + 1], v[j + 1] = ti, ni, ki, pi, ui, vi


@nb.njit(**JIT)
def _grown(a, used, cap):
    out = np.empty(cap, a.dtype)
    out[:used] = a[:used]
    return out


@nb.njit(**JIT)
def hit_lists_two_level(origins, directions, t_min, t_max, tree, band, counts, first, k0, k1):
    """list_intersections in one pass (tree as in closest_two_level): bands k0..k1 write counts[i] and return
    their hits, ray by ray in ray order and sorted by (t, instance, kind, primitive) within a ray (_sort_hits), as
    (number, t, inst, kind, prim, u, v) arrays of their own, grown by doubling. Coherent chunks of PACKET
    consecutive rays go through packet_all.packet_all_instances with HIT_CAP hits a ray (a ray with more is
    walked again alone), the others through the one-ray walk (_ray_hits; a ray that overflows the arrays is
    walked again). Replaces a counting pass, a filling pass and a global lexsort."""
    (top_bounds, top_child, top_leaf, _, _, _, _, _, _, _, _, _, stack_size) = tree
    n = origins.shape[0]
    cap = max(256, 4 * (min(n, k1 * band) - k0 * band))
    bt, bi, bk = np.empty(cap), np.empty(cap, np.int32), np.empty(cap, np.int8)
    bp, bu, bv = np.empty(cap, np.int32), np.empty(cap), np.empty(cap)
    used = 0
    (top_node, _, stack_node, _, rr, ro, top_key, top_order, key, order, idx, _, _, _, _,
     spread) = _scratch(stack_size, top_bounds, top_child)
    pk = hit_buffers(HIT_CAP)
    pc, pt, pi, pkd, pp, pu, pv = pk
    o, d, lo, hi = band_scratch(band)
    for k in range(k0, k1):
        r0, m, clean = _world_band(origins, directions, t_min, t_max, tree, k, band, o, d, lo, hi, first)
        if not clean:
            continue
        for c in range((m + PACKET - 1) // PACKET):
            mm, packet, nrx, nry, nrz, _, _, _ = load_chunk(c, o[:m], d[:m], lo[:m], hi[:m], 0, idx, rr, spread)
            if packet:
                packet_all_instances(*tree[:12], nrx, nry, nrz, rr, ro, top_node, stack_node, top_key, top_order,
                                     key, order, pk)
            for q in range(mm):
                j = idx[q]
                total = pc[q] if packet else HIT_CAP + 1
                if cap - used < total:  # grow (a one-ray walk grows below when it overflows)
                    cap = max(2 * cap, used + 2 * total)
                    bt, bi, bk = _grown(bt, used, cap), _grown(bi, used, cap), _grown(bk, used, cap)
                    bp, bu, bv = _grown(bp, used, cap), _grown(bu, used, cap), _grown(bv, used, cap)
                if total <= HIT_CAP:  # element by element: a ray has a few hits, six slice copies cost more
                    a = q * HIT_CAP - used
                    for h in range(used, used + total):
                        bt[h], bi[h], bk[h], bp[h], bu[h], bv[h] = pt[a + h], pi[a + h], pkd[a + h], pp[a + h], \
                            pu[a + h], pv[a + h]
                else:
                    while True:
                        room = (pc, bt[used:], bi[used:], bk[used:], bp[used:], bu[used:], bv[used:])
                        total = _ray_hits(o, d, j, lo[j], hi[j], tree, top_node, stack_node, room)
                        if total <= cap - used:
                            break
                        cap = max(2 * cap, used + 2 * total)
                        bt, bi, bk = _grown(bt, used, cap), _grown(bi, used, cap), _grown(bk, used, cap)
                        bp, bu, bv = _grown(bp, used, cap), _grown(bu, used, cap), _grown(bv, used, cap)
                _sort_hits(bt, bi, bk, bp, bu, bv, used, used + total)
                counts[r0 + j] = total
                used += total
    return used, bt[:used], bi[:used], bk[:used], bp[:used], bu[:used], bv[:used]
