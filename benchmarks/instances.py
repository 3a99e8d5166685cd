"""Instanced meshes against the same triangles merged (issue 9, item 4): RaycastingScene.cast_rays on the bunny
placed 2 and 4 times with add_instance (the two-level kernels), on the same placements added as separate meshes
(one world-space tree: the one-level packet kernels) and embreex on the merged triangles (rtcIntersect1 per ray).

    NUMBA_NUM_THREADS=1 python benchmarks/instances.py [--res 1024] [--repeat 5] [--copies 2 4]

Rays: res x res pinhole rays framing all copies (raycases.camera_rays on the merged mesh), given flat ((N, 3)
float32 origins + directions) and as one (H, W, 6) float32 image. Figures are Mrays per CPU second
(time.process_time, so other jobs on the machine count little): run with NUMBA_NUM_THREADS=1 and embreex on one
thread. Rounds alternate the engines; each figure is the median over --repeat rounds. Run it with another
checkout's src on PYTHONPATH to compare versions of durer on the same rays.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import trimesh
from raycases import SHARED, camera_rays, load_mesh

from durer import RaycastingScene


def placements(mesh: trimesh.Trimesh, copies: int) -> list[np.ndarray]:
    """copies object-to-world matrices: the bunny on a grid two wide (x, y), each turned about y by its own
    angle."""
    size = float(np.ptp(mesh.vertices, axis=0).max())
    out = []
    for k in range(copies):
        m = np.eye(4)
        a = 0.6 * k
        m[:3, :3] = [[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]]
        m[:3, 3] = [1.1 * size * (k % 2), 1.1 * size * (k // 2), 0.0]
        out.append(m)
    return out


def cpu_time(fn, repeat: int) -> list[float]:
    times = []
    for _ in range(repeat):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return times


def case(v: np.ndarray, f: np.ndarray, mats: list[np.ndarray], res: int, repeat: int) -> None:
    """Time and print every engine on the bunny placed by `mats`."""
    moved = [v @ m[:3, :3].T + m[:3, 3] for m in mats]
    merged = trimesh.Trimesh(np.concatenate(moved), np.concatenate([f + k * len(v) for k in range(len(mats))]),
                             process=False)
    o, d = camera_rays(merged, res)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    image = np.concatenate([o32, d32], axis=1).reshape(res, res, 6)
    inst, sep = RaycastingScene(), RaycastingScene()
    first = inst.add_triangles(v, f, transform=mats[0])
    for m in mats[1:]:
        inst.add_instance(first, m)
    for mv in moved:
        sep.add_triangles(mv, f)
    engines = {
        "instances flat": lambda: inst.cast_rays(o32, d32),
        "instances image": lambda: inst.cast_rays(image),
        "merged flat": lambda: sep.cast_rays(o32, d32),
        "merged image": lambda: sep.cast_rays(image),
    }
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh as EmbreeMesh

        es = rtcore_scene.EmbreeScene()
        EmbreeMesh(es, merged.vertices[merged.faces].astype(np.float32))
        engines["embreex merged"] = lambda: es.run(o32, d32, output=1)
    except ImportError:
        pass
    for fn in engines.values():
        fn()  # warm: compiles or loads the kernels
    ref = inst.cast_rays(image)["t_hit"].reshape(-1)
    assert np.array_equal(inst.cast_rays(o32, d32)["t_hit"], ref)
    merged_t = sep.cast_rays(image)["t_hit"].reshape(-1)
    both = np.isfinite(ref) & np.isfinite(merged_t)
    times: dict[str, list[float]] = {name: [] for name in engines}
    names = list(engines)
    for r in range(repeat):
        for name in names[r % len(names):] + names[:r % len(names)]:
            times[name] += cpu_time(engines[name], 1)
    print(f"bunny x{len(mats)} ({len(f) * len(mats)} triangles placed, {res}x{res} rays, hit "
          f"{np.isfinite(ref).mean():.3f}, instanced vs merged t: max rel "
          f"{np.max(np.abs(ref[both] - merged_t[both]) / merged_t[both]):.1e})")
    for name in names:
        med = float(np.median(times[name]))
        print(f"  {name:18s} {len(o) / med / 1e6:7.2f} Mrays/CPU-s  (median {med:.3f} s of {repeat})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--res", type=int, default=1024)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--copies", type=int, nargs="+", default=[2, 4])
    ap.add_argument("--meshes", default=str(SHARED / "meshes"))
    a = ap.parse_args()
    bunny = load_mesh(a.meshes, "bun_zipper.ply")
    v, f = np.asarray(bunny.vertices), np.asarray(bunny.faces)
    for copies in a.copies:
        case(v, f, placements(bunny, copies), a.res, a.repeat)


if __name__ == "__main__":
    main()
