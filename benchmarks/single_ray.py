"""CPU time of the one-ray traversal (kernels/bvh/single.py) on incoherent rays, for alternating A/B runs:

    for i in 1 2 3 4 5; do
        NUMBA_NUM_THREADS=1 PYTHONPATH=old/src python benchmarks/single_ray.py
        NUMBA_NUM_THREADS=1 PYTHONPATH=new/src python benchmarks/single_ray.py
    done

262,144 rays from random points around the Stanford bunny to random points on its surface (benchmarks/raycases.py:
no 16-ray chunk is coherent, so every ray takes the one-ray path), traced by BVHAccelerator.closest_hit and
any_hit (t_max = inf, and t_max = 0.999 of the closest hit: an unoccluded shadow ray, which walks the whole way)
on one thread (NUMBA_NUM_THREADS=1 runs the kernel on the calling thread). Prints the median (and least) ns per ray
of the thread's CPU time (time.thread_time) over --repeat calls after a warm-up, and a checksum of the results so two
versions can be seen to agree. --mesh picks another mesh from ../shared/meshes (bun_zipper_subdiv2.ply: 1.1M).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from raycases import SHARED, load_mesh, random_rays

from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.scene.cameras import PerspectiveCamera
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh


def cpu_ns_per_ray(fn, n: int, repeat: int) -> tuple[float, float]:
    """Median and least CPU time of the calling thread per ray, in ns, over `repeat` calls after a warm-up call
    (the least is the steadier figure when other jobs share the machine's caches)."""
    fn()
    times = []
    for _ in range(repeat):
        start = time.thread_time()
        fn()
        times.append(time.thread_time() - start)
    return float(np.median(times)) / n * 1e9, min(times) / n * 1e9


def incoherent_case(description: str):
    """(arguments, mesh, origins, directions) from the command line: --rays incoherent rays at --mesh, --repeat."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--rays", type=int, default=262_144)
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--mesh", default="bun_zipper.ply")
    args = parser.parse_args()
    mesh = load_mesh(SHARED / "meshes", args.mesh)
    return (args, mesh, *random_rays(mesh, args.rays))


def main() -> None:
    args, mesh, o, d = incoherent_case(__doc__.split("\n")[0])
    camera = PerspectiveCamera(center=(0, 0, 1), direction=(0, 0, -1), up=(0, 1, 0), angle=40)
    group = Group([TriangleMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))])
    acc = BVHAccelerator(compile_scene(Scene(camera=camera, group=group)))
    n = len(o)
    hits = acc.closest_hit(o, d)
    shadow = np.where(np.isfinite(hits.t), hits.t * 0.999, np.inf)
    figures = {
        "closest": cpu_ns_per_ray(lambda: acc.closest_hit(o, d), n, args.repeat),
        "any": cpu_ns_per_ray(lambda: acc.any_hit(o, d), n, args.repeat),
        "any_shadow": cpu_ns_per_ray(lambda: acc.any_hit(o, d, t_max=shadow), n, args.repeat),
    }
    finite = np.isfinite(hits.t)
    check = (f"hits={int(finite.sum())} sum_t={hits.t[finite].sum():.9f} prim_sum={int(hits.prim[finite].sum())} "
             f"occluded={int(acc.any_hit(o, d).sum())} shadow_occluded={int(acc.any_hit(o, d, t_max=shadow).sum())}")
    print(" ".join(f"{k}={v[0]:.0f}ns(min {v[1]:.0f})" for k, v in figures.items()), check)


if __name__ == "__main__":
    main()
