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
from .instance_packets import any_hit_instances, closest_hit_instances
from .instances import all_hits_instances, hit_normal
from .layout import BLOCK, PACKET
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
        for j in range(m):
            i = r0 + j
            p = prim_out[i]
            if kind[j] == MISS:
                inst_out[i] = -1
            elif not mapped:
                inst_out[i] = 0
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
