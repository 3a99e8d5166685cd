"""Open3D's rows of the ray casting benchmark (benchmarks/raycast.py --open3d-rows, issue 21 item 4): durer's
`RaycastingScene` against `o3d.t.geometry.RaycastingScene` in one process on the same float32 rays, engines
interleaved (each round starts with the other engine, SETTLE s of rest before each call), medians.

Rows: `count_intersections` and `list_intersections` on the bunny (res x res camera rays and res^2 incoherent
rays), and building the scene as a user waits for it: `add_triangles` plus the first query (Open3D builds its
tree lazily at the first query; durer's RaycastingScene too), on the bunny and the 1.1M bunny. Agreement: counts
equal (the rest are grazing rays), and on the rays whose counts agree, the sorted t of each ray within float32
rounding.
"""

from __future__ import annotations

import time

import numpy as np

from durer import RaycastingScene

SETTLE = 0.3  # seconds of rest before each timed call


def _interleaved(calls: dict, repeat: int) -> tuple[dict, dict]:
    """Median seconds of each call over `repeat` rounds, each round starting one engine later; the last outputs."""
    times: dict[str, list[float]] = {e: [] for e in calls}
    outs = {}
    names = list(calls)
    for r in range(repeat):
        for e in names[r % len(names):] + names[:r % len(names)]:
            time.sleep(SETTLE)
            start = time.perf_counter()
            outs[e] = calls[e]()
            times[e].append(time.perf_counter() - start)
    return {e: float(np.median(t)) for e, t in times.items()}, outs


def _build_durer(v32, f32):
    s = RaycastingScene()
    s.add_triangles(v32, f32)
    s.count_intersections(np.zeros((1, 6), np.float32))  # the first query: durer builds here too
    return s


def _build_open3d(o3d, v32, f32):
    s = o3d.t.geometry.RaycastingScene()
    s.add_triangles(o3d.core.Tensor(v32), o3d.core.Tensor(f32))
    s.count_intersections(o3d.core.Tensor(np.zeros((1, 6), np.float32)))  # Open3D builds on the first query
    return s


def _sorted_lists(splits, t) -> np.ndarray:
    """t sorted within each ray (Open3D does not promise an order within a ray)."""
    ray = np.repeat(np.arange(len(splits) - 1), np.diff(splits))
    return t[np.lexsort((t, ray))]


def _list_agreement(a: dict, b: dict) -> str:
    sa, sb = a["ray_splits"].astype(np.int64), b["ray_splits"].astype(np.int64)
    ca, cb = np.diff(sa), np.diff(sb)
    same = ca == cb
    ta, tb = _sorted_lists(sa, a["t_hit"]), _sorted_lists(sb, b["t_hit"])
    keep_a, keep_b = np.repeat(same, ca), np.repeat(same, cb)
    x, y = ta[keep_a].astype(np.float64), tb[keep_b].astype(np.float64)
    rel = np.abs(x - y) / np.maximum(np.abs(y), 1e-30)
    eps = np.finfo(np.float32).eps
    med, p999 = (np.median(rel) / eps, np.percentile(rel, 99.9) / eps) if len(rel) else (0.0, 0.0)
    return (f"counts equal on {100 * same.mean():.4f}% of rays ({(~same).sum()} differ); hits {sa[-1]:,} / "
            f"{sb[-1]:,}; t on equal-count rays: |dt|/t median {med:.2f}, p99.9 {p999:.2f} float32 eps")


def query_rows(o3d, v, f, rays: dict, repeat: int, threads: int) -> list[tuple[str, float, float, str]]:
    """count / list rows for each batch in rays ({name: (N, 6) float32}): (row, durer s, Open3D s, agreement)."""
    v32, f32 = v.astype(np.float32), f.astype(np.uint32)
    ds, os_ = _build_durer(v32, f32), _build_open3d(o3d, v32, f32)
    rows = []
    for name, r in rays.items():
        rt = o3d.core.Tensor(r)
        ds.count_intersections(r[:64])  # compile / warm both
        calls = {"durer": lambda r=r: ds.count_intersections(r, nthreads=threads),
                 "open3d": lambda rt=rt: os_.count_intersections(rt, nthreads=threads).numpy()}
        t, out = _interleaved(calls, repeat)
        same = out["durer"].astype(np.int64) == out["open3d"].astype(np.int64)
        rows.append((f"count_intersections, {name}", t["durer"], t["open3d"],
                     f"counts equal on {100 * same.mean():.4f}% ({(~same).sum()} rays differ)"))
        ds.list_intersections(r[:64])
        calls = {"durer": lambda r=r: ds.list_intersections(r, nthreads=threads),
                 "open3d": lambda rt=rt: {k: x.numpy() for k, x in
                                          os_.list_intersections(rt, nthreads=threads).items()}}
        t, out = _interleaved(calls, repeat)
        rows.append((f"list_intersections, {name}", t["durer"], t["open3d"],
                     _list_agreement(out["durer"], out["open3d"])))
    return rows


def build_row(o3d, name: str, v, f, repeat: int) -> tuple[str, float, float, str]:
    """add_triangles + the first query, both engines, interleaved: (row, durer s, Open3D s, '')."""
    v32, f32 = v.astype(np.float32), f.astype(np.uint32)
    _build_durer(v32[:3], np.array([[0, 1, 2]], np.uint32))  # compiled kernels loaded before timing
    calls = {"durer": lambda: _build_durer(v32, f32), "open3d": lambda: _build_open3d(o3d, v32, f32)}
    t, _ = _interleaved(calls, repeat)
    return f"build (add_triangles + first query), {name}, {len(f):,} triangles", t["durer"], t["open3d"], ""


def open3d_rows(bunny, big, res: int, repeat: int, threads: int, camera_rays, random_rays) -> None:
    """Print Open3D's rows as a markdown table (durer / Open3D < 1: durer is faster)."""
    try:
        import open3d as o3d
    except ImportError as err:
        print(f"\n## Open3D rows: Open3D not available ({err})")
        return
    v, f = np.asarray(bunny.vertices, np.float64), np.asarray(bunny.faces, np.int64)
    o, d = camera_rays(bunny, res)
    ro, rd = random_rays(bunny, res * res)
    rays = {f"bunny, {res}x{res} camera rays": np.hstack([o, d]).astype(np.float32),
            f"bunny, {res * res:,} incoherent rays": np.hstack([ro, rd]).astype(np.float32)}
    rows = query_rows(o3d, v, f, rays, repeat, threads)
    rows.append(build_row(o3d, "bunny", v, f, repeat))
    if big is not None:
        rows.append(build_row(o3d, "1.1M bunny", np.asarray(big.vertices), np.asarray(big.faces), repeat))
    print(f"\n## Open3D's rows ({o3d.__version__}), float32 rays, {threads} threads, median of {repeat} "
          "interleaved rounds")
    print("| row | durer s | Open3D s | **durer / Open3D** | agreement |")
    print("|---|---|---|---|---|")
    for row, a, b, agree in rows:
        print(f"| {row} | {a:.4f} | {b:.4f} | **{a / b:.2f}** | {agree} |")
