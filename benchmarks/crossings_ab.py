"""A/B of list_intersections in one process, interleaved (issue 21 item 4): the old path (a counting pass and a
filling pass of kernels/bvh/queries.crossings_two_level, then a global lexsort by (ray, t)) against the one-pass
`RaycastingScene.list_intersections` (queries.hit_lists_two_level), on the bunny's 1024² camera rays and 1M
incoherent rays; the answers are checked equal first. Also Shape.mesh's NumPy normals and bounds against
build.mesh_normals_bounds on the 1.1M bunny.

    PYTHONPATH=src python benchmarks/crossings_ab.py [--repeat 5] [--meshes ../shared/meshes]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from raycases import SHARED, camera_rays, load_mesh, random_rays

from durer import RaycastingScene
from durer.kernels.bvh.items import mesh_normals_bounds
from durer.kernels.bvh.queries import crossings_two_level
from durer.query import _durer_form, t_range


def old_list(scene: RaycastingScene, batch) -> tuple:
    """The list as it was made before: count, fill, lexsort (t, ray ids, uvs)."""
    tree, n = scene._tree(), len(batch)
    counts = np.zeros(n, np.int64)
    f, i32, i8 = np.zeros(0), np.zeros(0, np.int32), np.zeros(0, np.int8)
    args = (tree.packed.args, batch.band())
    batch.run(crossings_two_level, *args, np.zeros(n, np.int64), f, i32, i8, i32, f, f, counts)
    offsets = np.zeros(n, np.int64)
    np.cumsum(counts[:-1], out=offsets[1:])
    total = int(counts.sum())
    out = dict(t=np.empty(total), inst=np.empty(total, np.int32), kind=np.empty(total, np.int8),
               prim=np.empty(total, np.int32), u=np.empty(total), v=np.empty(total))
    batch.run(crossings_two_level, *args, offsets, out["t"], out["inst"], out["kind"], out["prim"], out["u"],
              out["v"], counts)
    ray_ids = np.repeat(np.arange(n, dtype=np.uint32), counts)
    order = np.lexsort((out["t"], ray_ids))
    uv = np.stack([out["u"], out["v"]], axis=-1)[order].astype(np.float32)
    return out["t"][order].astype(np.float32), ray_ids[order], uv


def interleaved(a, b, repeat: int) -> tuple[float, float]:
    ta, tb = [], []
    for k in range(repeat):
        for fn, times in ((a, ta), (b, tb)) if k % 2 == 0 else ((b, tb), (a, ta)):
            time.sleep(0.2)
            start = time.perf_counter()
            fn()
            times.append(time.perf_counter() - start)
    return float(np.median(ta)), float(np.median(tb))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--meshes", type=Path, default=SHARED / "meshes", help="folder with the bunny PLY files")
    args = ap.parse_args()
    repeat = args.repeat
    mesh = load_mesh(args.meshes, "bun_zipper.ply")
    scene = RaycastingScene()
    scene.add_triangles(np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32))
    for label, (o, d) in (("camera 1024^2", camera_rays(mesh, 1024)), ("incoherent 1M", random_rays(mesh, 1 << 20))):
        r = np.hstack([o, d]).astype(np.float32)
        rr, dd, _ = _durer_form(r, None, 0)
        batch = scene._rays(rr, dd, *t_range(None, None, None, None))
        a, b = old_list(scene, batch), scene.list_intersections(r)
        same = all(np.array_equal(x, b[k]) for x, k in zip(a, ("t_hit", "ray_ids", "primitive_uvs"), strict=True))
        old, new = interleaved(lambda batch=batch: old_list(scene, batch), lambda r=r: scene.list_intersections(r),
                               repeat)
        print(f"list {label}: old {old:.3f} s, one pass {new:.3f} s, new/old {new / old:.2f}, same answers {same}")
    big = load_mesh(args.meshes, "bun_zipper_subdiv2.ply")
    tris = np.asarray(big.vertices, np.float64)[np.asarray(big.faces)]

    def numpy_prep():
        normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        np.divide(normals, length, out=normals, where=length > 0)
        return normals, tris.min(axis=(0, 1)), tris.max(axis=(0, 1))

    mesh_normals_bounds(tris[:1])
    old, new = interleaved(numpy_prep, lambda: mesh_normals_bounds(tris), repeat)
    print(f"Shape.mesh normals + bounds, 1.1M: NumPy {old:.3f} s, one kernel pass {new:.3f} s, new/old {new / old:.2f}")


if __name__ == "__main__":
    main()
