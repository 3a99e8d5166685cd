"""CPU time of durer's BVH kernels in one checkout, to compare two versions run alternately (issue 8's "before and
after in one run"):

    for i in 1 2 3 4; do
        NUMBA_NUM_THREADS=1 PYTHONPATH=old/src python benchmarks/kernel_ab.py
        NUMBA_NUM_THREADS=1 PYTHONPATH=new/src python benchmarks/kernel_ab.py
    done

One thread and the main thread's CPU time (time.thread_time), so other jobs on the machine change the figures far
less than wall time would; best of 5 after a warm-up. Prints Mrays/s of BVHAccelerator.closest_hit / any_hit on
512x512 pinhole rays at the Stanford bunny (as an image, and flat), RaycastingScene.cast_rays on the same rays as
an (H, W, 6) array, and 300,000 random rays (incoherent). Works with durer before the issue 8 layout too.
Mesh: the Stanford bunny (Stanford Computer Graphics Laboratory), from ../shared/meshes.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import trimesh

import durer

try:
    from durer.accel.bvh import BVHAccelerator
    from durer.accel.compile import compile_scene
    from durer.scene.graph import Group, Scene
    from durer.scene.shapes import TriangleMesh
except ImportError:  # durer before the layered layout
    from durer.bvh import BVHAccelerator
    from durer.compile import compile_scene
    from durer.shapes import TriangleMesh

    from durer.scene import Group, Scene

MESH = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "bun_zipper.ply"


def best(f, k: int = 5) -> float:
    f()
    times = []
    for _ in range(k):
        t = time.thread_time()
        f()
        times.append(time.thread_time() - t)
    return min(times)


def main() -> None:
    mesh = trimesh.load(MESH, force="mesh", process=False)
    rays = durer.RaycastingScene.create_rays_pinhole(40, (-0.02, 0.1, 0), (-0.02, 0.1, 0.4), (0, 1, 0), 512, 512)
    rays = np.asarray(rays, dtype=np.float64)  # float64 rays as before Open3D's float32 pinhole (issue 22)
    o = np.ascontiguousarray(rays[..., :3].reshape(-1, 3))
    d = np.ascontiguousarray(rays[..., 3:].reshape(-1, 3))
    camera = durer.PerspectiveCamera(center=(0, 0, 1), direction=(0, 0, -1), up=(0, 1, 0), angle=40)
    group = Group([TriangleMesh(np.asarray(mesh.vertices), np.asarray(mesh.faces))])
    acc = BVHAccelerator(compile_scene(Scene(camera=camera, group=group)))
    rs = durer.RaycastingScene()
    rs.add_mesh(mesh)
    rs.build()
    rng = np.random.default_rng(0)
    ro = rng.uniform(-0.1, 0.1, (300_000, 3)) + [-0.02, 0.1, 0]
    rd = rng.normal(size=(300_000, 3))
    n, m = len(o), len(ro)
    figures = {
        "closest_img": n / best(lambda: acc.closest_hit(o, d, width=512)),
        "closest_flat": n / best(lambda: acc.closest_hit(o, d)),
        "any_flat": n / best(lambda: acc.any_hit(o, d)),
        "cast_rays_img": n / best(lambda: rs.cast_rays(rays)),
        "closest_random": m / best(lambda: acc.closest_hit(ro, rd)),
        "any_random": m / best(lambda: acc.any_hit(ro, rd)),
        "cast_random": m / best(lambda: rs.cast_rays(ro, rd)),
    }
    print(" ".join(f"{k}={v / 1e6:.2f}" for k, v in figures.items()))


if __name__ == "__main__":
    main()
