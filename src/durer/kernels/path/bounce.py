"""One bounce of the path tracer's wavefront for every live path, fused into one Numba loop: the emission the ray
found (weighted by multiple importance sampling against light sampling), next-event estimation (a shadow ray per
path, traced afterwards by the accelerator), BSDF sampling, Russian roulette and the next ray. rendering/path.py
drives it between the accelerator's closest-hit and any-hit queries and documents the estimator. shade_path, the
work on one path, is also the shading of the fused bounce (kernels/path/wavefront.py).

Random numbers come from the counter-based stream (kernels/path/qmc.py) keyed by (seed, pixel, sample, dimension), so
every path's numbers depend only on the path: the result is the same whatever the thread count or work split.

Numba's on-disk cache of shade_bounce is keyed on this file alone, not on the BSDF and emitter kernels it inlines:
after a change there (the BSDF table gained its BECKMANN column; the emitters their SPOT and AREA_SHAPE kinds, the
spot's texture and area lights' textured radiance; the environment map's guided cdf search), delete __pycache__ or
touch this file and wavefront.py."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..common import JIT, MISS, SPHERE, TRIANGLE
from .columns import COLUMNS, EMISSION, FLIP, SMOOTH, TEXTURED
from .compose import bsdf_albedo, bsdf_eval, bsdf_sample
from .emitters import emitter_pdf, pick_sample
from .envmap import envmap_eval_pdf, has_map
from .qmc import sobol2, uniform1
from .textures import map_factor, resolve_row, shading_frame
from .warps import power_heuristic1, to_local3, to_world3

DIMS = 8  # 1-D random dimensions per bounce: 0 light pick, 1 lobe pick, 2 Russian roulette, 3 texture pick


@nb.njit(**JIT, inline="always")
def dim1(depth, k):
    """1-D dimension k of bounce `depth`."""
    return 1 + depth * DIMS + k


@nb.njit(**JIT, inline="always")
def dim2(depth, k):
    """2-D Sobol pair k of bounce `depth` (pair 0 is the pixel position): 0 light position, 1 BSDF direction."""
    return 1 + 2 * depth + k


@nb.njit(**JIT, inline="always")
def shade_path(ray, hit, kind, prim, t, normals, surf, se, s, miss, j, sample, keys, pkeys, thr, eta, prev, bsdf,
               lights, env, scalars, L, aux, work):
    """Shade one path after its closest hit: the body of shade_bounce, shared with the fused bounce of
    kernels/path/wavefront.py (inlined into both).

    ray = (ox, oy, oz, dx, dy, dz); the hit's kind, primitive, t, normals = (geometric gx, gy, gz, shading sx, sy,
    sz: the BSDF frame, side tests and emission use the shading normal, as Mitsuba's shading frame; the
    solid-angle pdf of an emitter and the offsets of new rays the geometric one), surf = (u, v, dp/du, dp/dv) at the
    hit (surface.uv_at; read only by textured slots) and material slots (se as hit, s with solid textures
    resolved; a slot with Mitsuba textures is looked up at (u, v) into work = (scratch table Q, first of its three
    rows) first, kernels/path/textures.resolve_row); miss = (radiance r, g, b, light pdf, is an emitter) for a ray
    that escaped (with an environment map, an emitter's radiance and pdf are the map's, looked up here); j the path's
    row in L, sample, keys, pkeys; thr = (t0, t1, t2), eta and prev = (pdf, delta, x, y, z) its state. Adds found
    light to L[j]; with scalars[4] (features wanted) records the first non-specular hit's albedo and normal in aux =
    (tint, albedo, normal, seen) rows j (_features_at), and in seen (n, 6) the emission the camera ray sees directly
    or through mirrors and glass (the light this function adds to L[j] while the features are sought): columns
    0-2 from surface emitters, 3-5 from the environment (the denoiser's split, rendering/denoise.py). Returns
    (shadow ray: valid, origin, direction, t_max, contribution, and next ray: throughput (0: the path ended), origin,
    direction, prev, eta), each as scalars."""
    P, T, tex = bsdf
    TI, TD = tex
    gx, gy, gz, hx, hy, hz = normals
    if hit and s >= 0 and P[s, TEXTURED] != 0:
        Q, r = work
        resolve_row(P, s, Q, r, TI, TD, surf[0], surf[1])
        if se == s:
            se = r
        P, s = Q, r
    K, _, F, _, _, _, tri_em, sph_em = lights
    depth, emit, last, rr_depth, want = scalars
    tint = aux[0]
    seek = want and (tint[j, 0] > 0 or tint[j, 1] > 0 or tint[j, 2] > 0)
    count = K.shape[0]
    ox, oy, oz, dx, dy, dz = ray
    t0, t1, t2 = thr
    shadow_ok = False
    so = (0.0, 0.0, 0.0)
    sd = (0.0, 0.0, 0.0)
    st = 0.0
    sc = (0.0, 0.0, 0.0)
    px = py = pz = 0.0
    # --- emission seen by this ray (BSDF sampling's share of MIS)
    if hit:
        px, py, pz = ox + t * dx, oy + t * dy, oz + t * dz
        if emit and se >= 0:
            sgn = -1.0 if P[se, FLIP] != 0 else 1.0
            nx, ny, nz = gx * sgn, gy * sgn, gz * sgn
            if hx * dx * sgn + hy * dy * sgn + hz * dz * sgn < 0:
                le0, le1, le2 = P[se, EMISSION], P[se, EMISSION + 1], P[se, EMISSION + 2]
                e = -1
                if kind == TRIANGLE:
                    e = tri_em[prim]
                elif kind == SPHERE:
                    e = sph_em[prim]
                w = 1.0
                if prev[1] == 0 and e >= 0:
                    pdf_l = emitter_pdf(K, F, e, prev[2], prev[3], prev[4], px, py, pz, nx, ny, nz)
                    w = power_heuristic1(prev[0], pdf_l / count)
                L[j, 0] += t0 * le0 * w
                L[j, 1] += t1 * le1 * w
                L[j, 2] += t2 * le2 * w
                if seek:
                    _seen(aux[3], j, 0, t0 * le0 * w, t1 * le1 * w, t2 * le2 * w)
    elif emit:
        le0, le1, le2, pdf_l = miss[0], miss[1], miss[2], miss[3]
        if miss[4] and has_map(env):
            le, pdf_l = envmap_eval_pdf(env, dx, dy, dz)
            le0, le1, le2 = le
            pdf_l /= count
        w = 1.0
        if prev[1] == 0 and miss[4]:
            w = power_heuristic1(prev[0], pdf_l)
        L[j, 0] += t0 * le0 * w
        L[j, 1] += t1 * le1 * w
        L[j, 2] += t2 * le2 * w
        if seek:
            _seen(aux[3], j, 3, t0 * le0 * w, t1 * le1 * w, t2 * le2 * w)
    found = False  # the features were taken at this hit: a map's normal replaces theirs below
    if seek:
        cont = _features_at(P, hit, s, hx, hy, hz, dx, dy, dz, j, aux)
        found = not cont and hit and s >= 0
        seek = cont and not last
    if not hit or last or s < 0:
        return shadow_ok, so, sd, st, sc, (0.0, 0.0, 0.0), so, sd, prev, 0.0
    sgn = -1.0 if P[s, FLIP] != 0 else 1.0
    n0x, n0y, n0z = hx * sgn, hy * sgn, hz * sgn
    (nx, ny, nz), ts, tt, bent, side_n = shading_frame(P, s, TI, TD, (n0x, n0y, n0z), (gx * sgn, gy * sgn, gz * sgn),
                                                       surf, (-dx, -dy, -dz))
    if found and bent:
        fn = aux[2]
        fn[j, 0], fn[j, 1], fn[j, 2] = nx * sgn, ny * sgn, nz * sgn
    wi = to_local3(-dx, -dy, -dz, ts, tt, nx, ny, nz)
    scale = 1e-7 * (1.0 + max(abs(px), abs(py), abs(pz)))
    # --- next-event estimation (light sampling's share of MIS)
    if count and P[s, SMOOTH] != 0:
        u0, u1 = sobol2(pkeys[j], sample[j], dim2(depth, 0))
        ld, ldist, lw, lpdf = pick_sample(lights, env, tex, uniform1(keys[j], dim1(depth, 0)), u0, u1, px, py, pz)
        wo = to_local3(ld[0], ld[1], ld[2], ts, tt, nx, ny, nz)
        f0, f1, f2, bpdf = bsdf_eval(P, T, s, wi, wo)
        if bent:  # a normal or bump map's side test and shadowing (the pdf is the BSDF's, or 0 off its side)
            k = map_factor(P, s, side_n, (nx, ny, nz), ld)
            f0, f1, f2, bpdf = f0 * k, f1 * k, f2 * k, bpdf if k > 0 else 0.0
        mis = power_heuristic1(lpdf, bpdf)
        c0, c1, c2 = t0 * f0 * lw[0] * mis, t1 * f1 * lw[1] * mis, t2 * f2 * lw[2] * mis
        if max(c0, c1, c2) > 0 and lpdf > 0:
            side = ld[0] * gx + ld[1] * gy + ld[2] * gz
            off = scale * (1.0 if side > 0 else (-1.0 if side < 0 else 0.0))
            so = (px + off * gx, py + off * gy, pz + off * gz)
            sd = (ld[0], ld[1], ld[2])
            st = math.inf if math.isinf(ldist) else ldist * (1.0 - 1e-6) - scale
            sc = (c0, c1, c2)
            shadow_ok = True
    # --- BSDF sampling, Russian roulette, the next ray
    u = uniform1(keys[j], dim1(depth, 1))
    u0, u1 = sobol2(pkeys[j], sample[j], dim2(depth, 1))
    wl, bw, bpdf, delta, beta = bsdf_sample(P, T, s, wi, u, u0, u1)
    wx, wy, wz = to_world3(wl[0], wl[1], wl[2], ts, tt, nx, ny, nz)
    if bent:
        k = map_factor(P, s, side_n, (nx, ny, nz), (wx, wy, wz))
        bw = (bw[0] * k, bw[1] * k, bw[2] * k)
    t0, t1, t2 = t0 * bw[0], t1 * bw[1], t2 * bw[2]
    if seek:  # through a mirror or glass: the tint of the lobe taken, without the radiance scaling of refraction
        b2 = beta * beta
        tint[j, 0], tint[j, 1], tint[j, 2] = tint[j, 0] * bw[0] * b2, tint[j, 1] * bw[1] * b2, tint[j, 2] * bw[2] * b2
    e2 = eta * beta
    if rr_depth <= depth + 1:
        q = min(max(t0, t1, t2) * e2 * e2, 0.95)
        if uniform1(keys[j], dim1(depth, 2)) < q:
            inv = 1.0 / max(q, 1e-300)
            t0, t1, t2 = t0 * inv, t1 * inv, t2 * inv
        else:
            t0 = t1 = t2 = 0.0
    if not max(t0, t1, t2) > 0:
        return shadow_ok, so, sd, st, sc, (0.0, 0.0, 0.0), so, sd, prev, 0.0
    side = wx * gx + wy * gy + wz * gz
    off = scale * (1.0 if side > 0 else (-1.0 if side < 0 else 0.0))
    ln = math.sqrt(wx * wx + wy * wy + wz * wz)
    return (shadow_ok, so, sd, st, sc, (t0, t1, t2), (px + off * gx, py + off * gy, pz + off * gz),
            (wx / ln, wy / ln, wz / ln), (bpdf, 1.0 if delta else 0.0, px, py, pz), e2)


@nb.njit(**JIT, inline="always")
def _seen(seen, j, c, r, g, b):
    """Add (r, g, b) to the directly seen emission of path j, columns c..c+2 (shade_path)."""
    seen[j, c] += r
    seen[j, c + 1] += g
    seen[j, c + 2] += b


@nb.njit(**JIT, inline="always")
def _features_at(P, hit, s, gx, gy, gz, dx, dy, dz, j, aux):
    """The denoiser's features of path j at this hit: on an emitter seen from its emitting side, its radiance's
    colour (scaled to a maximum of 1: the denoiser then sees the light's edge, which a light with the ceiling's BSDF
    would not show); on a surface with a non-delta lobe, bsdf_albedo; either times the tint so far, with the
    shading normal (shade_bounce then puts a normal or bump map's perturbed normal in its place: OIDN keeps the
    map's detail only if it sees it), written to aux[1][j], aux[2][j], and the search ends (tint 0), as it does
    where the path escapes or meets no BSDF. Returns whether it goes on: a delta-only surface (mirror, glass),
    whose sampled lobe multiplies the tint in shade_path."""
    tint, albedo, normal, _ = aux
    if hit and s >= 0:
        sgn = -1.0 if P[s, FLIP] != 0 else 1.0
        wiz = -(dx * gx + dy * gy + dz * gz) * sgn
        glow = max(P[s, EMISSION], P[s, EMISSION + 1], P[s, EMISSION + 2])
        if glow > 0 and wiz > 0:
            a0, a1, a2 = P[s, EMISSION] / glow, P[s, EMISSION + 1] / glow, P[s, EMISSION + 2] / glow
        elif P[s, SMOOTH] == 0:
            return True
        else:
            a0, a1, a2 = bsdf_albedo(P, s, wiz)
        albedo[j, 0], albedo[j, 1], albedo[j, 2] = tint[j, 0] * a0, tint[j, 1] * a1, tint[j, 2] * a2
        normal[j, 0], normal[j, 1], normal[j, 2] = gx, gy, gz
    tint[j, 0] = tint[j, 1] = tint[j, 2] = 0.0
    return False


@nb.njit(**JIT)
def shade_bounce(o, d, hit_t, hit_kind, hit_prim, ng, ns, uvd, slot_em, slot, path, misses, bsdf, lights, env, scalars,
                 L, aux, shadow, nxt, i0, i1):
    """Shade paths i0..i1 of a wavefront after its closest-hit query (shade_path on each).

    o, d (n, 3) the rays; hit_* the Hits; ng, ns (n, 3) geometric and shading normals; uvd (n, 8) surface.uv_at's
    texture coordinates and derivatives; slot_em the hit's material slot,
    slot the same with solid textures resolved; path = (idx, sample, keys, pixel keys, thr (n,3), eta,
    prev (n, 5): pdf of the last BSDF sample, its delta flag, the point it left from); misses = (radiance (n,3),
    light pdf (n,), is an emitter (n,)) of rays that escaped; bsdf = (P, T) packed table; lights = (kinds,
    radiance, params, triangles, normals, cdf, triangle -> emitter, sphere -> emitter); env = the environment
    map's tables (kernels/path/envmap.py; empty without one); scalars = (depth, emit, last, rr_depth, features
    wanted). Adds found light to L[idx] (and features to aux's rows idx, as shade_path); writes each path's shadow
    ray: shadow = (origin, direction, t_max, contribution, valid), and its next ray: nxt = (origin, direction, prev
    as above, throughput (0: the path ended), eta)."""
    idx, sample, keys, pkeys, thr, eta, prev = path
    miss_le, miss_pdf, miss_em = misses
    shadow_o, shadow_d, shadow_t, shadow_c, shadow_ok = shadow
    nxt_o, nxt_d, nxt_prev, nxt_thr, nxt_eta = nxt
    Q = np.empty((3, COLUMNS))  # a textured slot's resolved rows
    for i in range(i0, i1):
        k = hit_kind[i]
        ok, so, sd, st, sc, nt, no, nd, npv, ne = shade_path(
            (o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]), k != MISS, k, hit_prim[i], hit_t[i],
            (ng[i, 0], ng[i, 1], ng[i, 2], ns[i, 0], ns[i, 1], ns[i, 2]),
            (uvd[i, 0], uvd[i, 1], uvd[i, 2], uvd[i, 3], uvd[i, 4], uvd[i, 5], uvd[i, 6], uvd[i, 7]), slot_em[i],
            slot[i],
            (miss_le[i, 0], miss_le[i, 1], miss_le[i, 2], miss_pdf[i], miss_em[i]), idx[i], sample, keys, pkeys,
            (thr[i, 0], thr[i, 1], thr[i, 2]), eta[i], (prev[i, 0], prev[i, 1], prev[i, 2], prev[i, 3], prev[i, 4]),
            bsdf, lights, env, scalars, L, aux, (Q, 0))
        shadow_ok[i] = ok
        if ok:
            shadow_o[i, 0], shadow_o[i, 1], shadow_o[i, 2] = so
            shadow_d[i, 0], shadow_d[i, 1], shadow_d[i, 2] = sd
            shadow_t[i] = st
            shadow_c[i, 0], shadow_c[i, 1], shadow_c[i, 2] = sc
        nxt_thr[i, 0], nxt_thr[i, 1], nxt_thr[i, 2] = nt
        if nt[0] > 0 or nt[1] > 0 or nt[2] > 0:
            nxt_o[i, 0], nxt_o[i, 1], nxt_o[i, 2] = no
            nxt_d[i, 0], nxt_d[i, 1], nxt_d[i, 2] = nd
            nxt_prev[i, 0], nxt_prev[i, 1], nxt_prev[i, 2], nxt_prev[i, 3], nxt_prev[i, 4] = npv
            nxt_eta[i] = ne


@nb.njit(**JIT)
def add_unblocked(L, idx, q, blocked, contribution):
    """L[idx[q[k]]] += contribution[q[k]] for the shadow rays k that reached their light."""
    for k in range(q.shape[0]):
        if not blocked[k]:
            i = q[k]
            j = idx[i]
            L[j, 0] += contribution[i, 0]
            L[j, 1] += contribution[i, 1]
            L[j, 2] += contribution[i, 2]
