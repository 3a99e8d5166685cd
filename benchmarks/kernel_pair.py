"""Kernel speed of two checkouts, paired and interleaved (issue 19's "within noise in a paired run before and after").

    git worktree add ../kernels-base 933254b
    python benchmarks/kernel_pair.py --a ../kernels-base/src --b src [--rounds 5] [--repeat 3] [--only WORD]

Each round starts one process per side, A then B on even rounds and B then A on odd ones, so that neither side
always runs first; each process imports durer from its own `src` (its own Numba cache), times every row (after a
warm-up call, the best of --repeat wall times) and prints them as JSON. A warm-up process per side fills the
caches first. Printed per row: the median over rounds of each side's time and of the round's B / A ratio (below 1:
B is faster), with the ratios' range. Rows: `cast_rays` on 1024 x 1024 pinhole rays at the Stanford bunny on one
and two threads, 2^20 incoherent rays on two threads, `compute_closest_points` of 2^18 points around it, and
`durer.render` of examples/cornell_box.xml at 64 x 64, 16 samples (the path tracer). Mesh: the Stanford bunny
(Stanford Computer Graphics Laboratory) from ../shared/meshes or DURER_SHARED. --only WORD: the rows naming WORD.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("DURER_SHARED", REPO.parent / "shared"))
ROWS = ("cast_rays, bunny 1024² pinhole, 1 thread", "cast_rays, bunny 1024² pinhole, 2 threads",
        "cast_rays, 2^20 incoherent rays, 2 threads", "compute_closest_points, 2^18 points, 2 threads",
        "render cornell_box.xml 64² 16 spp (path), 2 threads")


def _best(f, repeat: int) -> float:
    f()  # warm-up: compiles on an empty cache, loads it otherwise
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def child(repeat: int, only: str) -> None:
    """Time every row with the durer on sys.path; print {row: seconds} as JSON."""
    import numpy as np
    import trimesh

    import durer

    mesh = trimesh.load(SHARED / "meshes" / "bun_zipper.ply", force="mesh", process=False)
    rs = durer.RaycastingScene()
    rs.add_triangles(np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32))
    rays = durer.RaycastingScene.create_rays_pinhole(40, (-0.02, 0.1, 0), (-0.02, 0.1, 0.4), (0, 1, 0), 1024, 1024)
    rng = np.random.default_rng(0)
    n = 1 << 20
    incoherent = np.concatenate([rng.uniform(-0.1, 0.1, (n, 3)) + [-0.02, 0.1, 0], rng.normal(size=(n, 3))],
                                axis=1).astype(np.float32)
    points = (rng.uniform(-0.1, 0.1, (1 << 18, 3)) + [-0.02, 0.1, 0]).astype(np.float32)
    scene = durer.load(REPO / "examples" / "cornell_box.xml")
    work = (lambda: rs.cast_rays(rays, nthreads=1), lambda: rs.cast_rays(rays, nthreads=2),
            lambda: rs.cast_rays(incoherent, nthreads=2), lambda: rs.compute_closest_points(points, nthreads=2),
            lambda: durer.render(scene, 64, 64, samples=16, nthreads=2))
    print(json.dumps({row: _best(f, repeat) for row, f in zip(ROWS, work, strict=True) if only in row}))


def run_side(src: str, repeat: int, only: str = "") -> dict:
    env = dict(os.environ, PYTHONPATH=str(Path(src).resolve()), DURER_SHARED=str(SHARED))
    command = [sys.executable, __file__, "--child", "--repeat", str(repeat), "--only", only]
    out = subprocess.run(command, env=env, check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--a", help="the first checkout's src folder (before)")
    ap.add_argument("--b", help="the second checkout's src folder (after)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", default="", help="time only the rows whose name contains this")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.child:
        child(a.repeat, a.only)
        return
    for src in (a.a, a.b):  # fill each side's Numba cache
        run_side(src, 1, a.only)
    times = {"a": [], "b": []}
    for r in range(a.rounds):
        for side in ("ab" if r % 2 == 0 else "ba"):
            times[side].append(run_side(a.a if side == "a" else a.b, a.repeat, a.only))
        rows = [row for row in ROWS if a.only in row]
        print(f"round {r + 1}: " + "  ".join(f"{times['b'][-1][row] / times['a'][-1][row]:.3f}" for row in rows),
              file=sys.stderr, flush=True)
    print("| row | A (s, median) | B (s, median) | B / A, median of rounds (range) |")
    print("|---|---|---|---|")
    for row in [row for row in ROWS if a.only in row]:
        ta = [t[row] for t in times["a"]]
        tb = [t[row] for t in times["b"]]
        ratios = [y / x for x, y in zip(ta, tb, strict=True)]
        print(f"| {row} | {statistics.median(ta):.4f} | {statistics.median(tb):.4f} | "
              f"{statistics.median(ratios):.3f} ({min(ratios):.3f}–{max(ratios):.3f}) |")


if __name__ == "__main__":
    main()
