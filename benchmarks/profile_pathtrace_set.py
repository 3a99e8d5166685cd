"""Where a path-traced render of the real Mitsuba scenes spends its time, stage by stage (issue 21 item 3).

    DURER_SHARED=../shared PYTHONPATH=src python benchmarks/profile_pathtrace_set.py [--only WORD ...] [--res 128]
        [--spp 16] [--rounds 3] [--threads 1]

Each scene as pathtrace_set.py renders it (the same mirrored file, --res px on the longer side, --spp samples),
warm (one render first, so the build is kept as in the benchmark), then --rounds renders on --threads Numba
threads with the render's stages wrapped by timers (process CPU and wall, summed over the calls): the build check
(make_context: the scene check and fingerprint), the job (PathTracer, tables), the film's sample points and camera
rays, start_paths, the camera rays' batch walk, the fused bounce per depth, the film's gather and nearest sample;
"rest" is the render's total less those (Python glue, the unit threads, allocation). Reported: median ms per
render of each stage and its share. With --threads 1 the CPU figures are one core's work; with 2 the stages
overlap across unit threads and only the total's ratio is meaningful.
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
import durer.rendering.renderer as renderer_mod
from durer.rendering import film

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))
from mitsuba_references import SCENES, mirror  # noqa: E402
from pathtrace_set import resize  # noqa: E402
from test_project_mitsuba_scenes import LOADABLE  # noqa: E402

TIMES: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0])
DEPTH = [0]


def timed(name, fn):
    """fn wrapped so that its CPU and wall time add to TIMES[name] (a name with {depth} gets the bounce depth)."""
    def wrapper(*args, **kwargs):
        w, c = time.perf_counter(), time.thread_time()
        try:
            return fn(*args, **kwargs)
        finally:
            key = name.format(depth=DEPTH[0])
            TIMES[key][0] += time.thread_time() - c
            TIMES[key][1] += time.perf_counter() - w
    return wrapper


def instrument() -> None:
    """Wrap the render's stages where the modules call them."""
    renderer_mod.make_context = timed("make_context (check, fingerprint)", renderer_mod.make_context)
    renderer_mod.job_for = timed("job_for (PathTracer, tables)", renderer_mod.job_for)
    for name in ("tile_samples", "camera_rays", "gather", "nearest_samples"):
        setattr(film, name, timed(f"film.{name}", getattr(film, name)))
    path_mod.start_paths = timed("start_paths", path_mod.start_paths)
    orig_run_pieces = path_mod.run_pieces

    def run_pieces(kernel, *args, **kwargs):
        name = "bounce depth {depth}" if kernel is path_mod.trace_bounce else "other kernels"
        DEPTH[0] = min(args[14][0], 3) if kernel is path_mod.trace_bounce else 0
        return timed(name if DEPTH[0] < 3 else "bounce depth 3+", orig_run_pieces)(kernel, *args, **kwargs)
    path_mod.run_pieces = run_pieces
    tracer = path_mod.PathTracer

    class Timed(tracer):
        def __init__(self, ctx):
            super().__init__(ctx)
            accel = ctx.accel
            if not getattr(accel, "_timed", False):
                accel.closest_hit = timed("camera rays' batch walk", accel.closest_hit)
                accel._timed = True
    path_mod.PathTracer = Timed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--only", nargs="*", default=[])
    a = ap.parse_args()
    nb.set_num_threads(a.threads)
    instrument()
    names = [n for n in LOADABLE if not a.only or any(w in n for w in a.only)]
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            root = mirror(Path(tmp) / "scenes", SCENES)
            xml = root / name
            w, h = resize(xml, a.res)
            scene = durer.load(xml)
            durer.render(scene, samples=a.spp, seed=0)
            rounds = []
            for r in range(a.rounds):
                TIMES.clear()
                wall, cpu = time.perf_counter(), time.process_time()
                durer.render(scene, samples=a.spp, seed=1 + r)
                TIMES["total"] = [time.process_time() - cpu, time.perf_counter() - wall]
                rounds.append(dict(TIMES))
        keys = sorted({k for r in rounds for k in r}, key=lambda k: (k == "total", k))
        med = {k: float(np.median([r.get(k, [0, 0])[0] for r in rounds])) * 1e3 for k in keys}
        medw = {k: float(np.median([r.get(k, [0, 0])[1] for r in rounds])) * 1e3 for k in keys}
        staged = sum(v for k, v in med.items() if k not in ("total", "make_context (check, fingerprint)"))
        staged += med.get("make_context (check, fingerprint)", 0.0)
        print(f"\n{name.split('/')[-1]} ({w}x{h}, {a.spp} spp, {a.threads} thread(s)): total {med['total']:.1f} ms "
              f"CPU, {medw['total']:.1f} ms wall")
        for k in keys:
            if k != "total":
                print(f"  {k:40s} {med[k]:8.2f} ms CPU {100 * med[k] / med['total']:5.1f}%   "
                      f"(wall {medw[k]:.2f})")
        print(f"  {'rest (glue, threads, allocation)':40s} {med['total'] - staged:8.2f} ms CPU "
              f"{100 * (med['total'] - staged) / med['total']:5.1f}%")


if __name__ == "__main__":
    main()
