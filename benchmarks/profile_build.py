"""Where `add_triangles` plus the first query spends its time (issue 21 item 4): each stage of the build run alone,
medians of --repeat rounds, bunny and 1.1M bunny, beside the whole call and Open3D's.

    PYTHONPATH=src python benchmarks/profile_build.py [--repeat 5] [--meshes ../shared/meshes]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numba as nb
import numpy as np
from raycases import SHARED, load_mesh

from durer.accel.bvh import Shape, TwoLevelBVH
from durer.kernels.bvh import build
from durer.kernels.bvh.items import indexed_items, indexed_leaves
from durer.query import RaycastingScene


def _median(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def stages(v32: np.ndarray, f32: np.ndarray, repeat: int) -> dict[str, float]:
    """Seconds of each stage of add_triangles + the first query, run one by one on the same input."""
    v, f = np.ascontiguousarray(v32, np.float64), np.ascontiguousarray(f32, np.int64)
    n = len(f)
    out: dict[str, float] = {}
    out["validate + convert (add_triangles' checks, float64/int64 copies)"] = _median(
        lambda: (np.isfinite(v32).all(), f32.astype(np.int64).min(), f.max(), np.ascontiguousarray(v32, np.float64)),
        repeat)
    out["indexed_items (normals, bounds, the build's item rows)"] = _median(lambda: indexed_items(v, f), repeat)
    _, lo, hi, ib, root_box, root_cb = indexed_items(v, f)
    threads = nb.get_num_threads()

    def top():  # the serial top of the threaded build, to its deferred subtrees
        rows = ib.copy()
        arrays = build.node_arrays(n, root_box)
        build.build_nodes(rows, *arrays, 0, 0, n, root_cb, 1, build.MAX_LEAF, n // (4 * threads),
                          np.empty((n, 3), np.int64), np.empty((n, 6)))

    if n >= build.PARALLEL_BUILD and threads >= 2:
        out["SAH top (serial, to the deferred subtrees; with a copy of the item rows)"] = _median(top, repeat)
    box_lo, box_hi = ib[:, :3].copy(), ib[:, 3:6].copy()
    out["SAH whole tree, serial (build_bvh2, with item_rows)"] = _median(
        lambda: build.build_bvh2(box_lo, box_hi, build.MAX_LEAF), repeat)
    box, left, right, start, count, order = build.build_bvh2(box_lo, box_hi, build.MAX_LEAF)
    out["collapse_bvh4"] = _median(lambda: build.collapse_bvh4(box, left, right, start, count), repeat)
    out["build_wide_bvh (as called: threaded when large)"] = _median(lambda: build.build_wide_bvh(box_lo, box_hi),
                                                                      repeat)
    out["indexed_leaves (float32 leaf gather)"] = _median(lambda: indexed_leaves(v, f, order, True), repeat)
    shape = Shape.indexed(v, f)
    out["TwoLevelBVH (pack + the tree over instances)"] = _median(lambda: TwoLevelBVH([shape], [(0, np.eye(4))]),
                                                                   repeat)

    def whole():
        s = RaycastingScene()
        s.add_triangles(v32, f32)
        s.count_intersections(np.zeros((1, 6), np.float32))

    out["whole: add_triangles + first query"] = _median(whole, repeat)
    try:
        import open3d as o3d

        def o3d_build():
            s = o3d.t.geometry.RaycastingScene()
            s.add_triangles(o3d.core.Tensor(v32), o3d.core.Tensor(f32))
            s.count_intersections(o3d.core.Tensor(np.zeros((1, 6), np.float32)))

        o3d_build()
        out["Open3D 0.20: add_triangles + first query"] = _median(o3d_build, repeat)
    except ImportError:
        pass
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--meshes", default=str(SHARED / "meshes"))
    ap.add_argument("--quick", action="store_true", help="the bunny only")
    args = ap.parse_args()
    files = ["bun_zipper.ply"] + ([] if args.quick else ["bun_zipper_subdiv2.ply"])
    stages(np.zeros((3, 3), np.float32) + np.eye(3, dtype=np.float32), np.array([[0, 1, 2]], np.uint32), 1)  # compile
    for file in files:
        mesh = load_mesh(args.meshes, file)
        v32, f32 = np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)
        print(f"\n## {file}: {len(f32):,} triangles, {nb.get_num_threads()} threads, median of {args.repeat}")
        for name, sec in stages(v32, f32, args.repeat).items():
            print(f"| {name} | {1000 * sec:.1f} ms |")


if __name__ == "__main__":
    main()
