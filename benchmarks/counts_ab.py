"""count_intersections and list_intersections, three engines interleaved in one process (issue 21 item 4): this
durer, Open3D 0.20 and, with --old, another durer (a copy of an older src/durer under another package name, e.g.
`cp -r ../main/src/durer /tmp/old/durer_old`), on the bunny's 1024² camera rays and 1M incoherent rays, float32,
2 threads; medians of --repeat rounds, each round starting with the next engine. Ratios are printed against
Open3D and against the old durer; answers are checked equal to the old durer's.

    PYTHONPATH=src python benchmarks/counts_ab.py [--repeat 5] [--old /tmp/old:durer_old] [--only count]
        [--meshes ../shared/meshes]
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

import numpy as np
from raycases import SHARED, camera_rays, load_mesh, random_rays

from durer import RaycastingScene


def interleaved(calls: dict, repeat: int) -> dict:
    times: dict[str, list[float]] = {e: [] for e in calls}
    names = list(calls)
    for r in range(repeat):
        for e in names[r % len(names):] + names[:r % len(names)]:
            time.sleep(0.2)
            start = time.perf_counter()
            calls[e]()
            times[e].append(time.perf_counter() - start)
    return {e: float(np.median(t)) for e, t in times.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--old", default="", help="FOLDER:PACKAGE of an older durer to compare with")
    ap.add_argument("--only", choices=("count", "list", ""), default="")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--meshes", type=Path, default=SHARED / "meshes", help="folder with bun_zipper.ply")
    args = ap.parse_args()
    mesh = load_mesh(args.meshes, "bun_zipper.ply")
    v, f = np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)
    engines = {"durer": RaycastingScene}
    if args.old:
        folder, name = args.old.split(":")
        sys.path.insert(0, folder)
        engines["old"] = importlib.import_module(name).RaycastingScene
    scenes = {}
    for e, cls in engines.items():
        scenes[e] = cls()
        scenes[e].add_triangles(v, f)
    try:
        import open3d as o3d
        o3s = o3d.t.geometry.RaycastingScene()
        o3s.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))
    except ImportError:
        o3d = None
    batches = {"camera 1024^2": camera_rays(mesh, 1024), "incoherent 1M": random_rays(mesh, 1 << 20)}
    nt = args.threads
    for label, (o, d) in batches.items():
        r = np.hstack([o, d]).astype(np.float32)
        for q in ("count", "list"):
            if args.only and q != args.only:
                continue
            calls = {}
            for e, s in scenes.items():
                fn = getattr(s, f"{q}_intersections")
                calls[e] = lambda fn=fn, r=r: fn(r, nthreads=nt)
            if o3d is not None:
                rt = o3d.core.Tensor(r)
                fn = getattr(o3s, f"{q}_intersections")
                calls["open3d"] = lambda fn=fn, rt=rt: fn(rt, nthreads=nt)
            outs = {e: c() for e, c in calls.items() if e != "open3d"}  # warm (compile) and check
            same = ""
            if "old" in outs:
                a, b = outs["durer"], outs["old"]
                eq = all(np.array_equal(a[k], b[k]) for k in a) if isinstance(a, dict) else np.array_equal(a, b)
                same = f", same as old: {eq}"
            t = interleaved(calls, args.repeat)
            line = f"{q} {label}: " + ", ".join(f"{e} {s:.3f} s" for e, s in t.items())
            if "open3d" in t:
                line += f"; durer/open3d {t['durer'] / t['open3d']:.2f}"
            if "old" in t:
                line += f"; durer/old {t['durer'] / t['old']:.2f}"
            print(line + same, flush=True)


if __name__ == "__main__":
    main()
