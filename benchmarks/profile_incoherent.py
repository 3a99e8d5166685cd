"""Where `cast_rays` on incoherent rays spends its time, and how it scales from 1 to 2 threads (issue 21, item 2).

    python benchmarks/profile_incoherent.py [--rays 1048576] [--repeat 5] [--mesh bun_zipper.ply]

On --rays incoherent float32 rays at the mesh (raycases.random_rays), one process, every stage interleaved with the
others round by round, on 1 and 2 threads: wall time and the process's CPU time (so a second thread that only
waits for a core, on a loaded machine, shows as wall time without CPU time), median of --repeat rounds:

* `cast_rays`: the whole query (float32 in, float32 t / ids / uvs / normals out);
* load: the bands' float32 -> float64 copy and checks alone (`bands.check_bands`, the same loop `cast_rays` runs);
* kernel: `TwoLevelBVH.closest_hit` on the float64 rays made untimed (the traversal alone, run_blocks' split);
* kernel, bands: the same traversal split as `cast_rays` splits it (bands of 4096 rays, 8 pieces a thread);
* embreex: `rtcIntersect1` per ray from 1 or 2 Python threads (run() frees the GIL), when installed.

The share of `cast_rays` beyond the kernel is load + ids + uvs + normals + outputs.
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from raycases import SHARED, load_mesh, random_rays

from durer import RaycastingScene
from durer.kernels.bvh.bands import BAND, check_bands, n_bands
from durer.kernels.threads import run_pieces
from durer.query_args import threads


def timed(fn) -> tuple[float, float]:
    """(wall s, process CPU s) of one call."""
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def engines(scene: RaycastingScene, tri: np.ndarray, o32: np.ndarray, d32: np.ndarray) -> dict:
    """name -> fn(threads) for every stage (tri: the mesh's triangles (F, 3, 3), for embreex)."""
    tree = scene._tree()
    o, d = o32.astype(np.float64), d32.astype(np.float64)
    n = len(o)
    lo, hi = np.zeros(n), np.full(n, np.inf)
    w2o = np.ascontiguousarray(np.eye(4)[:3])
    first = np.empty((n_bands(n, BAND), 3), np.int64)

    def api(k):
        scene.cast_rays(o32, directions=d32, nthreads=k)

    def load(k):
        with threads(k):
            run_pieces(check_bands, len(first), o32, d32, lo, hi, w2o, BAND, first)

    def kernel(k):
        with threads(k):
            tree.closest_hit(o, d, lo, hi)

    out = {"cast_rays": api, "load": load, "kernel": kernel}
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh as EmbreeMesh
    except ImportError:
        return out
    es = rtcore_scene.EmbreeScene()
    EmbreeMesh(es, tri.astype(np.float32))
    es.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), output=1)
    pools = {k: ThreadPoolExecutor(k) for k in (1, 2)}

    def embree(k):
        parts = [(np.ascontiguousarray(a), np.ascontiguousarray(b))
                 for a, b in zip(np.array_split(o32, k), np.array_split(d32, k), strict=True)]
        list(pools[k].map(lambda p: es.run(*p, output=1), parts))

    out["embreex"] = embree
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rays", type=int, default=1_048_576)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--mesh", default="bun_zipper.ply")
    args = parser.parse_args()
    mesh = load_mesh(SHARED / "meshes", args.mesh)
    o, d = random_rays(mesh, args.rays)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    scene = RaycastingScene()
    scene.add_triangles(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    scene.build()
    stages = engines(scene, np.asarray(mesh.triangles), o32, d32)
    for fn in stages.values():  # compile and warm
        fn(1)
        fn(2)
    runs: dict = {(name, k): [] for name in stages for k in (1, 2)}
    for _ in range(args.repeat):
        for name, fn in stages.items():
            for k in (1, 2):
                runs[name, k].append(timed(lambda fn=fn, k=k: fn(k)))
    n = args.rays
    print(f"{n} incoherent float32 rays at {args.mesh}; medians of {args.repeat} interleaved rounds")
    print("| stage | 1 thread wall ms | CPU ms | 2 threads wall ms | CPU ms | speed-up 1 -> 2 | Mrays/s, 2 threads |")
    print("|---|---|---|---|---|---|---|")
    for name in stages:
        w1, c1 = np.median(np.array(runs[name, 1]), axis=0)
        w2, c2 = np.median(np.array(runs[name, 2]), axis=0)
        print(f"| {name} | {w1 * 1e3:.0f} | {c1 * 1e3:.0f} | {w2 * 1e3:.0f} | {c2 * 1e3:.0f} | {w1 / w2:.2f} | "
              f"{n / w2 / 1e6:.2f} |")


if __name__ == "__main__":
    main()
