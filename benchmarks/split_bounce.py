"""The path tracer's fused bounce split into its walks and its shading, on real Mitsuba scenes (issue 21 item 3).

    DURER_SHARED=../shared PYTHONPATH=src python benchmarks/split_bounce.py [--only WORD ...] [--res 128]
        [--spp 16] [--rounds 3]

Each scene is rendered once as pathtrace_set.py renders it (the same mirrored file, --res px, --spp samples, one
Numba thread) with every call of the fused bounce (kernels/path/wavefront.trace_bounce) captured: its inputs
copied before it runs. Each captured call is then replayed --rounds times from those inputs, one thread, the
variants interleaved call by call (thread CPU time, summed per depth):

- whole: the shipped trace_bounce;
- record: a private copy of its per-path body that also writes each path's closest hit and shadow ray (and
  whether it was blocked): the same work plus a few stores, a check that the copy costs what the original does;
- shade: the same copy reading the recorded hit and blocked flag instead of walking: the surface, textures,
  BSDF, emitters, envmap, random numbers and the state written, no traversal;
- closest / shadow: the one-ray walks alone on the recorded rays (the closest hit of each live path, depth 0's
  camera rays excepted as in the render, whose hits the batch walk found before; the any-hit of each shadow ray).

Reported per scene: ms per render of each, the share of the whole, and ns per ray of the two walks.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import numba as nb
import numpy as np

import durer
import durer.rendering.path as path_mod
from durer.kernels.common import JIT, MISS, PLANE
from durer.kernels.path.bounce import dim1, dim2, shade_path
from durer.kernels.path.bsdf import anisotropic
from durer.kernels.path.columns import FLIP, SMOOTH, TEXTURED
from durer.kernels.path.compose import bsdf_eval, bsdf_sample
from durer.kernels.path.emitters import pick_sample
from durer.kernels.path.envmap import envmap_eval_pdf, has_map
from durer.kernels.path.qmc import sobol2, uniform1
from durer.kernels.path.surface import surface_at, uv_at
from durer.kernels.path.textures import resolve_row, shading_frame
from durer.kernels.path.warps import power_heuristic1, to_local3, to_world3
from durer.kernels.path.wavefront import PIECES, _any, _closest, _planes, trace_bounce

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))
from mitsuba_references import SCENES, mirror  # noqa: E402
from pathtrace_set import resize  # noqa: E402
from test_project_mitsuba_scenes import LOADABLE  # noqa: E402

STAGES = ("s:surface", "s:+miss env", "s:+light smp", "s:+nee eval", "s:+bsdf smp")
# trace_bounce's arguments it writes: o, d, thr, eta, prev, L, aux, first, alive
MUTABLE = (1, 2, 3, 4, 5, 15, 16, 17, 18)


@nb.njit(**JIT, _nrt=False)
def bounce_copy(live, o, d, thr, eta, prev, path, accel, surfaces, miss, bsdf, lights, env, scalars, t_min, L, aux,
                first, alive, given, scratch, rec, replay):
    """trace_bounce's loop and per-path body (wavefront._one_path) copied; rec = (t, kind, prim, shadow ok,
    origin (n, 3), direction (n, 3), t_max, blocked) by live index k: written (replay False) or read instead of
    both walks (replay True)."""
    sample, keys, pkeys = path
    bounds, child, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o, pl_n, pl_off, _ = accel
    tris, tri_mat, w2o, center, radius, normal_matrix, sph_mat, plane_normal, plane_mat, tri_n, tri_uv = surfaces
    first_t, first_n = first
    r_t, r_kind, r_prim, r_ok, r_o, r_d, r_st, r_blocked = rec
    stack_node, stack_t = scratch[0][0], scratch[1][0]
    work = (scratch[2], 0)
    for k in range(live.shape[0]):
        i = live[k]
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        if replay:
            t, kind, prim = r_t[k], r_kind[k], r_prim[k]
        elif given[0].shape[0]:
            t, kind, prim = given[0][i], given[1][i], given[2][i]
        else:
            best, pprim = _planes(pl_n, pl_off, ox, oy, oz, dx, dy, dz, t_min, np.inf)
            t, kind, prim, _, _ = _closest(bounds, child, 0, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o,
                                           ox, oy, oz, dx, dy, dz, t_min, best, stack_node, stack_t)
            if kind == MISS and pprim >= 0:
                t, kind, prim = best, PLANE, pprim
        if not replay:
            r_t[k], r_kind[k], r_prim[k] = t, kind, prim
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
            if replay:
                blocked = r_blocked[k]
            else:
                _, blocker = _planes(pl_n, pl_off, so[0], so[1], so[2], sd[0], sd[1], sd[2], 0.0, st)
                blocked = blocker >= 0 or _any(bounds, child, 0, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o,
                                               so[0], so[1], so[2], sd[0], sd[1], sd[2], 0.0, st, stack_node)
                r_ok[k] = True
                r_o[k, 0], r_o[k, 1], r_o[k, 2] = so
                r_d[k, 0], r_d[k, 1], r_d[k, 2] = sd
                r_st[k] = st
                r_blocked[k] = blocked
            if not blocked:
                L[i, 0] += sc[0]
                L[i, 1] += sc[1]
                L[i, 2] += sc[2]
        elif not replay:
            r_ok[k] = False
        go = nt[0] > 0 or nt[1] > 0 or nt[2] > 0
        alive[k] = go
        if go:
            thr[i, 0], thr[i, 1], thr[i, 2] = nt
            o[i, 0], o[i, 1], o[i, 2] = no
            d[i, 0], d[i, 1], d[i, 2] = nd
            prev[i, 0], prev[i, 1], prev[i, 2], prev[i, 3], prev[i, 4] = npv
            eta[i] = ne


@nb.njit(**JIT, _nrt=False)
def walks(live, o, d, accel, t_min, given, rec, scratch, closest, shadow):
    """The bounce's walks alone on recorded rays: the closest hit of each live path (unless given), the any-hit
    of each recorded shadow ray (behind the planes' test, as in the bounce). Returns a count of hits, so nothing
    is dropped as unused."""
    bounds, child, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o, pl_n, pl_off, _ = accel
    r_ok, r_o, r_d, r_st = rec[3], rec[4], rec[5], rec[6]
    stack_node, stack_t = scratch[0][0], scratch[1][0]
    found = 0
    for k in range(live.shape[0]):
        i = live[k]
        if closest and not given[0].shape[0]:
            ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
            best, pprim = _planes(pl_n, pl_off, ox, oy, oz, dx, dy, dz, t_min, np.inf)
            t, kind, prim, _, _ = _closest(bounds, child, 0, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o,
                                           ox, oy, oz, dx, dy, dz, t_min, best, stack_node, stack_t)
            found += kind != MISS or pprim >= 0
        if shadow and r_ok[k]:
            _, blocker = _planes(pl_n, pl_off, r_o[k, 0], r_o[k, 1], r_o[k, 2], r_d[k, 0], r_d[k, 1], r_d[k, 2],
                                 0.0, r_st[k])
            if blocker >= 0 or _any(bounds, child, 0, leaf_prim, leaf_tri, sph_c, sph_r, sph_w2o, r_o[k, 0],
                                    r_o[k, 1], r_o[k, 2], r_d[k, 0], r_d[k, 1], r_d[k, 2], 0.0, r_st[k], stack_node):
                found += 1
    return found


@nb.njit(**JIT, _nrt=False)
def shade_stages(live, o, d, path, surfaces, bsdf, lights, env, scalars, rec, scratch, stop):
    """The shading's parts cumulatively, on the recorded hits: stop 1 the hit's surface (surface_at, UVs and
    textures where the slot needs them, the shading frame); 2 also an escaped ray's envmap lookup; 3 also
    next-event estimation's random numbers and light sample; 4 also the BSDF's eval there; 5 also BSDF sampling
    (its random numbers, bsdf_sample, the world direction). Returns a sum of the results, so none is dropped."""
    sample, keys, pkeys = path
    tris, tri_mat, w2o, center, radius, normal_matrix, sph_mat, plane_normal, plane_mat, tri_n, tri_uv = surfaces
    P0, T, tex = bsdf
    TI, TD = tex
    depth = scalars[0]
    r_t, r_kind, r_prim = rec[0], rec[1], rec[2]
    Q = scratch[2]
    acc = 0.0
    for k in range(live.shape[0]):
        i = live[k]
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        t, kind, prim = r_t[k], r_kind[k], r_prim[k]
        if kind == MISS:
            if stop >= 2 and has_map(env):
                le, pdf = envmap_eval_pdf(env, dx, dy, dz)
                acc += le[0] + pdf
            continue
        px, py, pz = ox + t * dx, oy + t * dy, oz + t * dz
        gx, gy, gz, hx, hy, hz, s = surface_at(px, py, pz, kind, prim, tris, tri_mat, w2o, center, radius,
                                               normal_matrix, sph_mat, plane_normal, plane_mat, tri_n)
        if s < 0:
            continue
        P = P0
        surf = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        if P[s, TEXTURED] != 0 or anisotropic(P, s):
            surf = uv_at(px, py, pz, kind, prim, tris, tri_uv, w2o, center, radius)
        if P[s, TEXTURED] != 0:
            resolve_row(P, s, Q, 0, TI, TD, surf[0], surf[1])
            P, s = Q, 0
        sgn = -1.0 if P[s, FLIP] != 0 else 1.0
        (nx, ny, nz), ts, tt, bent, side_n = shading_frame(P, s, TI, TD, (hx * sgn, hy * sgn, hz * sgn),
                                                           (gx * sgn, gy * sgn, gz * sgn), surf, (-dx, -dy, -dz))
        wi = to_local3(-dx, -dy, -dz, ts, tt, nx, ny, nz)
        acc += wi[2]
        if stop >= 3 and lights[0].shape[0] and P[s, SMOOTH] != 0:
            u0, u1 = sobol2(pkeys[i], sample[i], dim2(depth, 0))
            ld, ldist, lw, lpdf = pick_sample(lights, env, tex, uniform1(keys[i], dim1(depth, 0)), u0, u1, px, py, pz)
            acc += lpdf + lw[0]
            if stop >= 4:
                wo = to_local3(ld[0], ld[1], ld[2], ts, tt, nx, ny, nz)
                f0, f1, f2, bpdf = bsdf_eval(P, T, s, wi, wo)
                acc += f0 * power_heuristic1(lpdf, bpdf)
        if stop >= 5:
            u = uniform1(keys[i], dim1(depth, 1))
            u0, u1 = sobol2(pkeys[i], sample[i], dim2(depth, 1))
            wl, bw, bpdf, delta, beta = bsdf_sample(P, T, s, wi, u, u0, u1)
            wx, wy, wz = to_world3(wl[0], wl[1], wl[2], ts, tt, nx, ny, nz)
            acc += wx + bw[0] + bpdf
    return acc


def _copy(x):
    return tuple(_copy(v) for v in x) if isinstance(x, tuple) else x.copy()


def _restore(dst, src):
    if isinstance(dst, tuple):
        for a, b in zip(dst, src, strict=True):
            _restore(a, b)
    else:
        np.copyto(dst, src)


def capture(scene, spp: int) -> list[tuple]:
    """Every trace_bounce call of one render: (its arguments, a copy of the ones it writes)."""
    calls = []
    orig = path_mod.run_pieces

    def run_pieces(kernel, total, *args, **kwargs):
        if kernel is trace_bounce:
            calls.append((args, {j: _copy(args[j]) for j in MUTABLE}))
        return orig(kernel, total, *args, **kwargs)
    path_mod.run_pieces = run_pieces
    try:
        durer.render(scene, samples=spp, seed=1)
    finally:
        path_mod.run_pieces = orig
    return calls


def timed(fn) -> float:
    c = time.thread_time()
    fn()
    return time.thread_time() - c


def _runs(args: tuple, rec: tuple) -> dict:
    """Each variant of one captured call, as a function of nothing."""
    live, o, d, accel, tmin, given, work = args[0], args[1], args[2], args[7], args[14], args[19], args[20]
    runs = {
        "whole": lambda: trace_bounce(*args, 0, PIECES),
        "record": lambda: bounce_copy(*args, rec, False),
        "shade": lambda: bounce_copy(*args, rec, True),
        "closest": lambda: walks(live, o, d, accel, tmin, given, rec, work, True, False),
        "shadow": lambda: walks(live, o, d, accel, tmin, given, rec, work, False, True),
    }
    for stop, n in enumerate(STAGES):
        runs[n] = lambda stop=stop: shade_stages(live, o, d, args[6], args[8], args[10], args[11], args[12], args[13],
                                                 rec, work, stop + 1)
    return runs


def split(calls, rounds: int) -> dict:
    """Each variant's thread CPU seconds per depth (median over rounds) and the rays walked."""
    recs = []
    for args, saved in calls:
        m = len(args[0])
        rec = (np.empty(m), np.empty(m, np.int8), np.empty(m, np.int32), np.zeros(m, np.bool_), np.empty((m, 3)),
               np.empty((m, 3)), np.empty(m), np.empty(m, np.bool_))
        _restore(tuple(args[j] for j in MUTABLE), tuple(saved[j] for j in MUTABLE))
        bounce_copy(*args, rec, False)
        recs.append(rec)
    names = ("whole", "record", "shade", "closest", "shadow") + STAGES
    per = {n: defaultdict(list) for n in names}
    for r in range(rounds + 1):  # round 0 warms (compiles) every variant and is not counted
        acc = {n: defaultdict(float) for n in names}
        for (args, saved), rec in zip(calls, recs, strict=True):
            depth = min(args[13][0], 3)
            runs = _runs(args, rec)
            for n in names:
                _restore(tuple(args[j] for j in MUTABLE), tuple(saved[j] for j in MUTABLE))
                acc[n][depth] += timed(runs[n])
        for n in names:
            for k, v in acc[n].items():
                if r:
                    per[n][k].append(v)
    out = {n: {k: float(np.median(v)) for k, v in per[n].items()} for n in names}
    out["rays"] = (sum(len(a[0]) for a, _ in calls if not a[19][0].shape[0]), sum(int(r[3].sum()) for r in recs),
                   sum(len(a[0]) for a, _ in calls))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--only", nargs="*", default=[])
    a = ap.parse_args()
    nb.set_num_threads(1)
    names = [n for n in LOADABLE if not a.only or any(w in n for w in a.only)]
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            xml = mirror(Path(tmp) / "scenes", SCENES) / name
            w, h = resize(xml, a.res)
            scene = durer.load(xml)
            durer.render(scene, samples=a.spp, seed=0)
            calls = capture(scene, a.spp)
        res = split(calls, a.rounds)
        closest_rays, shadow_rays, paths = res.pop("rays")
        total = sum(res["whole"].values())
        print(f"\n{name.split('/')[-1]} ({w}x{h}, {a.spp} spp, one thread; {paths} path bounces, {closest_rays} "
              f"closest-hit walks, {shadow_rays} shadow rays): ms CPU per render (share of whole)")
        for n, v in res.items():
            ms = sum(v.values())
            depths = " ".join(f"d{k}={1e3 * v[k]:.1f}" for k in sorted(v))
            print(f"  {n:8s} {1e3 * ms:8.1f} ({100 * ms / total:5.1f}%)   {depths}")
        walk = sum(res["closest"].values()) + sum(res["shadow"].values())
        print(f"  walks {1e3 * walk:.1f} ms = {100 * walk / total:.0f}% of whole; shade + walks "
              f"{1e3 * (walk + sum(res['shade'].values())):.1f} ms; closest "
              f"{1e9 * sum(res['closest'].values()) / max(closest_rays, 1):.0f} ns a ray, shadow "
              f"{1e9 * sum(res['shadow'].values()) / max(shadow_rays, 1):.0f} ns a ray, shading "
              f"{1e9 * sum(res['shade'].values()) / max(paths, 1):.0f} ns a path bounce", flush=True)


if __name__ == "__main__":
    main()
