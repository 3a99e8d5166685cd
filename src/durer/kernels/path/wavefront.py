"""One whole bounce of the path tracer's wavefront in one Numba loop, for scenes on a one-level BVH: per live path
the closest hit (kernels/bvh/single.py's one-ray walk, as the accelerator's closest_hit_bvh traces incoherent
rays), the hit surface (kernels/path/surface.py), the shading (kernels/path/bounce.py's shade_path) and the shadow ray's
any-hit, then the next ray written over the path's own state. No intermediate arrays, gathers or Python between
the pieces: rendering/path.py calls it once per bounce with the list of live paths.

The numbers are those of the unfused wavefront to the bit: the same functions in the same order per path, and each
path's light is added in the same order (its emission found, then its shadow ray's light, bounce by bounce).
Numba's on-disk cache of trace_bounce is keyed on this file alone, as bounce.py's is on that one, not on the
shading they inline: after a change there, delete __pycache__ or touch this file (last: area lights' textured
radiance; the normal and bump maps' MAP_* columns and shading_frame's side normal; kernels/bvh/single.py's walks:
the unsigned ordered stack and the child codes by selects; the environment map's guided cdf search)."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..bvh.single import blas_any, blas_closest, planes_closest
from ..common import JIT, MISS, PLANE
from .bounce import shade_path
from .bsdf import anisotropic
from .columns import COLUMNS, TEXTURED
from .qmc import SAMPLE_MIX as _SAMPLE_MIX
from .qmc import mix64
from .surface import surface_at, uv_at

# The accelerator's one-ray walks, compiled from the same Python functions (no second copy of the traversal) for
# this kernel: a call passes a dozen arrays, each seven words by value, and the callee updates their reference
# counts. Bounce-1 wavefront, one thread, ns per path (Cornell box / caustic): both walks called 305 / 132 (with
# reference counting 310 on the Cornell box), both inlined 260 / 99 but the first render's compile 46-50 s of CPU
# instead of 27-34 (main), closest hit inlined and any hit called without reference counting 273 / 106 and 35 s.
_closest = nb.njit(**JIT, inline="always")(blas_closest.py_func)
_any = nb.njit(**JIT, _nrt=False)(blas_any.py_func)
_planes = nb.njit(**JIT, inline="always")(planes_closest.py_func)

PIECES = 32  # work items of a bounce: a few per thread, so a thread that was descheduled does not stall the other


def scratch(stack_size: int) -> tuple:
    """Each piece's traversal stack (nodes, entry distances) and three rows for a textured slot's resolved BSDF
    (kernels/path/textures.resolve_row): trace_bounce allocates nothing."""
    return (np.empty((PIECES, stack_size), np.int32), np.empty((PIECES, stack_size)), np.empty((3 * PIECES, COLUMNS)))


# _nrt=False: no reference counting in this kernel. With it, every array taken out of a tuple argument inside the
# per-path loop (the inlined shading reads a dozen) was an atomic increment and decrement (perf: Numba's NRT_incref
# and NRT_decref were the render's two hottest instructions), a third of the kernel's time on the Cornell box
# (408 -> 260 ns per path and bounce, one thread), and an atomic on a shared array's count is a cache line the two
# threads pass back and forth. Without the runtime the kernel cannot allocate (np.empty here fails to compile),
# so no array can leak; the scratch comes from the caller.
@nb.njit(**JIT, _nrt=False)
def trace_bounce(live, o, d, thr, eta, prev, path, accel, surfaces, miss, bsdf, lights, env, scalars, t_min, L,
                 aux, first, alive, given, scratch, p0, p1):
    """Bounce `scalars[0]` of the paths `live`, pieces p0..p1 of PIECES: each path traced, shaded and advanced
    in place.

    live: the row of each live path in the wavefront's arrays; o, d (n, 3) its ray, thr (n, 3) throughput, eta
    (n,), prev (n, 5) as in shade_bounce, all overwritten with the next bounce's; path = (sample, keys, pixel
    keys) (n,); accel = the one-level BVH's arrays (BVHAccelerator._args: bounds, child, leaf slots and
    triangles, spheres, planes, stack size); surfaces = CompiledScene.flat's arrays as hit_surfaces takes them
    (corner UVs last: uv_at);
    miss = (radiance r, g, b, light pdf, is an emitter) of every escaping ray; bsdf, lights, env and scalars as
    shade_bounce's; t_min of the rays. Adds found light to L (n, 3) and features to aux as shade_path; on bounce 0
    writes each path's first hit to first = (t (n,), geometric normal (n, 3)); alive[k] says whether path live[k]
    goes on. given = (t, kind, prim) (n,): the paths' closest hits found already (the camera rays, traced by the
    accelerator's batch kernel: the same hits), or empty arrays: each path walks the tree. scratch = scratch()."""
    m = live.shape[0]
    for piece in range(p0, p1):
        stack_node, stack_t = scratch[0][piece], scratch[1][piece]
        for k in range(m * piece // PIECES, m * (piece + 1) // PIECES):
            _one_path(live[k], k, o, d, thr, eta, prev, path, accel, surfaces, miss, bsdf, lights, env, scalars,
                      t_min, L, aux, first, alive, given, stack_node, stack_t, (scratch[2], 3 * piece))


@nb.njit(**JIT, inline="always")
def _one_path(i, k, o, d, thr, eta, prev, path, accel, surfaces, miss, bsdf, lights, env, scalars, t_min, L, aux,
              first, alive, given, stack_node, stack_t, work):
    """trace_bounce's work on path i (live[k])."""
    sample, keys, pkeys = path
    bounds, child, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o, pl_n, pl_off, _ = accel
    tris, tri_mat, w2o, center, radius, normal_matrix, sph_mat, plane_normal, plane_mat, tri_n, tri_uv = surfaces
    first_t, first_n = first
    ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
    if given[0].shape[0]:
        t, kind, prim = given[0][i], given[1][i], given[2][i]
    else:
        best, pprim = _planes(pl_n, pl_off, ox, oy, oz, dx, dy, dz, t_min, np.inf)
        t, kind, prim, _, _ = _closest(bounds, child, 0, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o,
                                       ox, oy, oz, dx, dy, dz, t_min, best, stack_node, stack_t)
        if kind == MISS and pprim >= 0:
            t, kind, prim = best, PLANE, pprim
    hit = kind != MISS
    h = t if hit else 0.0
    gx, gy, gz, sx, sy, sz, s = surface_at(ox + h * dx, oy + h * dy, oz + h * dz, kind, prim, tris, tri_mat, w2o,
                                           center, radius, normal_matrix, sph_mat, plane_normal, plane_mat, tri_n)
    surf = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    if s >= 0 and (bsdf[0][s, TEXTURED] != 0 or anisotropic(bsdf[0], s)):
        surf = uv_at(ox + h * dx, oy + h * dy, oz + h * dz, kind, prim, tris, tri_uv, w2o, center, radius)
    if scalars[0] == 0:
        first_t[i] = t
        first_n[i, 0], first_n[i, 1], first_n[i, 2] = gx, gy, gz
    ok, so, sd, st, sc, nt, no, nd, npv, ne = shade_path(
        (ox, oy, oz, dx, dy, dz), hit, kind, prim, t, (gx, gy, gz, sx, sy, sz), surf, s, s, miss, i, sample, keys,
        pkeys, (thr[i, 0], thr[i, 1], thr[i, 2]), eta[i], (prev[i, 0], prev[i, 1], prev[i, 2], prev[i, 3],
                                                            prev[i, 4]), bsdf, lights, env, scalars, L, aux, work)
    if ok:
        _, blocker = _planes(pl_n, pl_off, so[0], so[1], so[2], sd[0], sd[1], sd[2], 0.0, st)
        if blocker < 0 and not _any(bounds, child, 0, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o,
                                    so[0], so[1], so[2], sd[0], sd[1], sd[2], 0.0, st, stack_node):
            L[i, 0] += sc[0]
            L[i, 1] += sc[1]
            L[i, 2] += sc[2]
    go = nt[0] > 0 or nt[1] > 0 or nt[2] > 0
    alive[k] = go
    if go:
        thr[i, 0], thr[i, 1], thr[i, 2] = nt
        o[i, 0], o[i, 1], o[i, 2] = no
        d[i, 0], d[i, 1], d[i, 2] = nd
        prev[i, 0], prev[i, 1], prev[i, 2], prev[i, 3], prev[i, 4] = npv
        eta[i] = ne


@nb.njit(**JIT)
def start_paths(seed_key, pixel, sample, pixel_sample, origins, directions, state, streams, out, aux):
    """The wavefront's state for camera rays (origins, directions (n, 3)) of (pixel, sample) in one pass, as the
    NumPy of the unfused wavefront makes it (the same bits): state = (o, unit d, throughput 1, eta 1, prev = (1, 1,
    origin)); streams = (keys, pixel keys): rendering/sampling.key of (seed, pixel, sample) and of (seed, pixel,
    pixel_sample), seed_key = the seed's mix; out = (L = 0, first t = inf, first normal = 0); aux = the features'
    (tint = 1, albedo = 0, normal = 0, seen emission (n, 6) = 0), or empty arrays when no features are wanted."""
    o, d, thr, eta, prev = state
    keys, pkeys = streams
    L, first_t, first_n = out
    tint, albedo, normal, seen = aux
    if tint.shape[0]:
        for i in range(pixel.shape[0]):
            for c in range(3):
                tint[i, c] = 1.0
                albedo[i, c] = normal[i, c] = seen[i, c] = seen[i, c + 3] = 0.0
    pk = np.uint64(pixel_sample) * _SAMPLE_MIX
    for i in range(pixel.shape[0]):
        k = mix64(np.uint64(pixel[i]) + seed_key)
        keys[i] = mix64(k ^ (np.uint64(sample[i]) * _SAMPLE_MIX))
        pkeys[i] = mix64(k ^ pk)
        x, y, z = directions[i, 0], directions[i, 1], directions[i, 2]
        ln = np.sqrt(x * x + y * y + z * z)
        d[i, 0], d[i, 1], d[i, 2] = x / ln, y / ln, z / ln
        for c in range(3):
            o[i, c] = origins[i, c]
            prev[i, 2 + c] = origins[i, c]
            thr[i, c] = 1.0
            L[i, c] = 0.0
            first_n[i, c] = 0.0
        prev[i, 0] = prev[i, 1] = eta[i] = 1.0
        first_t[i] = np.inf
