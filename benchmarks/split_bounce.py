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
from durer.kernels.path.bounce import shade_path
from durer.kernels.path.bsdf import anisotropic
from durer.kernels.path.columns import TEXTURED
from durer.kernels.path.surface import surface_at, uv_at
from durer.kernels.path.wavefront import PIECES, _any, _closest, _planes, trace_bounce

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))
from mitsuba_references import SCENES, mirror  # noqa: E402
from pathtrace_set import resize  # noqa: E402
from test_project_mitsuba_scenes import LOADABLE  # noqa: E402

MUTABLE = (1, 2, 3, 4, 5, 15, 16, 17, 18)  # trace_bounce's arguments it writes: o, d, thr, eta, prev, L, aux, first, alive


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


def _copy(x):
    return tuple(_copy(v) for v in x) if isinstance(x, tuple) else x.copy()


def _restore(dst, src):
    if isinstance(dst, tuple):
        for a, b in zip(dst, src):
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
    names = ("whole", "record", "shade", "closest", "shadow")
    per = {n: defaultdict(list) for n in names}
    for r in range(rounds + 1):  # round 0 warms (compiles) every variant and is not counted
        acc = {n: defaultdict(float) for n in names}
        for (args, saved), rec in zip(calls, recs):
            depth = min(args[13][0], 3)
            live, o, d, accel, tmin, given, work = args[0], args[1], args[2], args[7], args[14], args[19], args[20]
            runs = {
                "whole": lambda: trace_bounce(*args, 0, PIECES),
                "record": lambda: bounce_copy(*args, rec, False),
                "shade": lambda: bounce_copy(*args, rec, True),
                "closest": lambda: walks(live, o, d, accel, tmin, given, rec, work, True, False),
                "shadow": lambda: walks(live, o, d, accel, tmin, given, rec, work, False, True),
            }
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
