"""Point-query benchmark: durer's closest points, distance, signed distance and occupancy against Open3D's
RaycastingScene and trimesh.proximity, same points, same run, with agreement figures.

    python benchmarks/distance.py                  # 1M points around the bunny, 20k around the 1.1M bunny
    python benchmarks/distance.py --quick          # 100k points, bunny only
    python benchmarks/distance.py --occupancy 5    # occupancy only, best of 5, durer and Open3D interleaved
    python benchmarks/distance.py --occupancy 5 --subdivided   # the same on the 1.1M-triangle bunny
    python benchmarks/distance.py --occupancy 5 --torus        # the same on a closed torus (ray crossings)

Meshes: the Stanford bunny and its subdivided version (Stanford Computer Graphics Laboratory), from
../shared/meshes or --meshes. Points are uniform in the mesh's bounding box grown by 10% on each side. Every
engine uses all cores (2 here); durer computes in float64, Open3D in float32. trimesh.proximity.closest_point is
pure Python and NumPy: it gets 20,000 of the bunny's points (its time includes building its r-tree) and is not run
on the 1.1M bunny.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numba
import numpy as np
import trimesh

from durer.accel.distance import SIGN_BETA
from durer.query import RaycastingScene

ROOT = Path(__file__).resolve().parents[1]


def timed(fn, repeat: int = 1):
    """(fastest seconds of `repeat` calls, last result)."""
    best, out = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def bench_occupancy(mesh: trimesh.Trimesh, n: int, repeat: int) -> None:
    """Only the fast queries (occupancy), best of `repeat`, durer and Open3D interleaved: a steadier ratio on a
    busy machine than one call each."""
    import open3d as o3d

    pts = points_around(mesh, n)
    scene = RaycastingScene()
    scene.add_triangles(mesh.vertices, mesh.faces)
    scene.compute_occupancy(pts[:1000])
    scene.compute_occupancy(pts[:1000], method="parity")
    osc = o3d.t.geometry.RaycastingScene()
    osc.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)), o3d.core.Tensor(mesh.faces.astype(np.uint32)))
    q = o3d.core.Tensor(pts.astype(np.float32))
    osc.compute_occupancy(q[:1000])
    index = scene._distance_index()
    rule = lambda: np.abs(index.winding_numbers(pts, SIGN_BETA, want_err=False)[0]) > 0.5  # noqa: E731
    differ = int(np.count_nonzero((scene.compute_occupancy(pts) > 0.5) != rule()))
    t = {"winding": np.inf, "rule": np.inf, "parity": np.inf, "open3d": np.inf}
    for _ in range(repeat):
        t["winding"] = min(t["winding"], timed(lambda: scene.compute_occupancy(pts))[0])
        t["rule"] = min(t["rule"], timed(rule)[0])
        t["parity"] = min(t["parity"], timed(lambda: scene.compute_occupancy(pts, method="parity"))[0])
        t["open3d"] = min(t["open3d"], timed(lambda: osc.compute_occupancy(q).numpy())[0])
    print(f"occupancy of {n:,} points ({len(mesh.faces):,} triangles, closed: {index.closed}), best of {repeat} "
          f"(interleaved): durer winding {t['winding']:.3f} s (the far-field winding rule everywhere, as before "
          f"the rays: {t['rule']:.3f} s; answers differing from it: {differ}), durer parity {t['parity']:.3f} s, "
          f"Open3D parity {t['open3d']:.3f} s; winding / Open3D {t['winding'] / t['open3d']:.2f}, parity / Open3D "
          f"{t['parity'] / t['open3d']:.2f}")


def points_around(mesh: trimesh.Trimesh, n: int, seed: int = 0) -> np.ndarray:
    lo, hi = mesh.bounds
    pad = 0.1 * (hi - lo)
    return np.random.default_rng(seed).uniform(lo - pad, hi + pad, (n, 3))


def bench_mesh(name: str, mesh: trimesh.Trimesh, n: int, trimesh_n: int) -> list[str]:
    pts = points_around(mesh, n)
    rows = []
    print(f"\n### {name}: {len(mesh.faces):,} triangles, {n:,} points\n")

    # ---- durer
    scene = RaycastingScene()
    t_build, _ = timed(lambda: (scene.add_triangles(mesh.vertices, mesh.faces), scene.build()))
    t_first, _ = timed(lambda: (scene.compute_closest_points(pts[:1000]), scene.compute_distance(pts[:1000]),
                                scene.compute_occupancy(pts[:1000], method="parity")))
    t_index, _ = timed(lambda: scene.compute_winding_number(pts[:1]))  # the per-lane moments, on first use
    d = {}
    d["closest"], cp = timed(lambda: scene.compute_closest_points(pts))
    d["distance"], dist = timed(lambda: scene.compute_distance(pts))
    d["signed winding"], sd_w = timed(lambda: scene.compute_signed_distance(pts))
    d["signed parity"], sd_p = timed(lambda: scene.compute_signed_distance(pts, method="parity"))
    d["occupancy winding"], occ_w = timed(lambda: scene.compute_occupancy(pts))
    d["occupancy parity"], occ_p = timed(lambda: scene.compute_occupancy(pts, method="parity"))
    print(f"durer: build {t_build:.3f} s, first calls (compile or cache load) {t_first:.2f} s, winding moments "
          f"{t_index:.3f} s, {scene!r}")

    # ---- Open3D
    o = {}
    try:
        import open3d as o3d
    except ImportError:
        o3d = None
        print("Open3D not installed: pip install durer[bench]")
    if o3d is not None:
        osc = o3d.t.geometry.RaycastingScene()
        t_obuild, _ = timed(lambda: osc.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                                                      o3d.core.Tensor(mesh.faces.astype(np.uint32))))
        q = o3d.core.Tensor(pts.astype(np.float32))
        osc.compute_distance(o3d.core.Tensor(pts[:1000].astype(np.float32)))  # builds Open3D's tree
        o["closest"], ocp = timed(lambda: osc.compute_closest_points(q))
        o["distance"], odist = timed(lambda: osc.compute_distance(q).numpy())
        o["signed parity"], osd = timed(lambda: osc.compute_signed_distance(q).numpy())
        o["occupancy parity"], oocc = timed(lambda: osc.compute_occupancy(q).numpy())
        ocp_pts = ocp["points"].numpy()
        print(f"Open3D {o3d.__version__}: add_triangles {t_obuild:.3f} s")

    # ---- trimesh on a subset
    t_tm = None
    try:
        if not trimesh_n:
            raise ImportError("skipped")
        import rtree  # noqa: F401
        import scipy  # noqa: F401
        sub = pts[:trimesh_n]
        t_tm, (tm_q, tm_d, _) = timed(lambda: trimesh.proximity.closest_point(mesh, sub))
        tm_agree = np.abs(tm_d - dist[:trimesh_n]).max()
    except ImportError as e:
        print("trimesh.proximity: " + ("skipped" if str(e) == "skipped" else "needs rtree and scipy: skipped"))

    # ---- agreement
    exact_n = min(20_000, n, int(2e9 // len(mesh.faces)))  # the exact sum costs points x triangles
    w_exact = scene.compute_winding_number(pts[:exact_n], beta=np.inf)
    w_fast = scene.compute_winding_number(pts[:exact_n])
    inside_exact = np.abs(w_exact) > 0.5
    same = np.mean((sd_w[:exact_n] < 0) == inside_exact)
    print(f"winding: fast (beta 2, order 2; signs use beta 1.5) vs exact on {exact_n:,} points: max |error| "
          f"{np.abs(w_fast - w_exact).max():.2e}; signed distance's inside decisions equal the exact ones {same:.4%}")
    if o:
        dd = np.abs(odist - dist)
        rel = dd / np.maximum(dist, 1e-12)
        print(f"distance vs Open3D: max |diff| {dd.max():.2e} (rel. median {np.median(rel):.1e}, max {rel.max():.1e}; "
              f"float32 spacing at the bunny's size ~{np.spacing(np.float32(0.1)):.1e})")
        print(f"closest points vs Open3D: max |diff| {np.abs(ocp_pts - cp['points']).max():.2e}")
        print(f"inside: durer winding vs Open3D parity {np.mean((sd_w < 0) == (osd < 0)):.4%}, durer parity vs "
              f"Open3D parity {np.mean((sd_p < 0) == (osd < 0)):.4%}; against the exact winding number on "
              f"{exact_n:,} points: durer winding {np.mean((sd_w[:exact_n] < 0) == inside_exact):.4%}, durer parity "
              f"{np.mean((sd_p[:exact_n] < 0) == inside_exact):.4%}, Open3D parity "
              f"{np.mean((osd[:exact_n] < 0) == inside_exact):.4%}")
        assert np.array_equal(occ_w, sd_w < 0) and np.array_equal(oocc > 0.5, osd < 0)
    if t_tm is not None:
        print(f"trimesh.proximity.closest_point: {trimesh_n:,} points in {t_tm:.2f} s = {trimesh_n / t_tm / 1e3:.1f} "
              f"k points/s (durer {n / d['closest'] / 1e3:.0f} k/s); max |distance diff| {tm_agree:.1e}")
    print()
    print("| query | durer s | durer Mpts/s | Open3D s | Open3D Mpts/s | durer / Open3D time |")
    print("|---|---|---|---|---|---|")
    pairs = [("closest", "closest"), ("distance", "distance"), ("signed winding", "signed parity"),
             ("signed parity", "signed parity"), ("occupancy winding", "occupancy parity"),
             ("occupancy parity", "occupancy parity")]
    for mine, theirs in pairs:
        ot = o.get(theirs)
        label = f"{mine} (Open3D: {theirs})" if mine != theirs else mine
        ratio = f"{d[mine] / ot:.2f}" if ot else "-"
        orate = f"{n / ot / 1e6:.2f}" if ot else "-"
        ots = f"{ot:.3f}" if ot else "-"
        row = f"| {label} | {d[mine]:.3f} | {n / d[mine] / 1e6:.2f} | {ots} | {orate} | {ratio} |"
        print(row)
        rows.append(row)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", type=Path, default=ROOT.parent / "shared" / "meshes")
    ap.add_argument("--points", type=int, default=1_000_000, help="points around the bunny")
    ap.add_argument("--sub-points", type=int, default=1_000_000, help="points around the 1.1M-triangle bunny")
    ap.add_argument("--quick", action="store_true", help="100k points, bunny only")
    ap.add_argument("--no-bunny", action="store_true", help="only the 1.1M-triangle bunny")
    ap.add_argument("--occupancy", type=int, metavar="REPEAT", default=0,
                    help="only occupancy on the bunny's points, best of REPEAT, durer and Open3D interleaved")
    ap.add_argument("--subdivided", action="store_true",
                    help="with --occupancy: the 1.1M-triangle bunny (--sub-points points) instead of the bunny")
    ap.add_argument("--torus", action="store_true",
                    help="with --occupancy: a closed torus (16,384 triangles) instead of the bunny")
    args = ap.parse_args()
    print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {platform.processor() or platform.machine()}, "
          f"{numba.get_num_threads()} threads, Python {platform.python_version()}, numba {numba.__version__}")
    bunny = trimesh.load(args.meshes / "bun_zipper.ply", process=False)
    if args.occupancy:
        if args.torus:
            bench_occupancy(trimesh.creation.torus(1.0, 0.35, major_sections=128, minor_sections=64), args.points,
                            args.occupancy)
        elif args.subdivided:
            sub = trimesh.load(args.meshes / "bun_zipper_subdiv2.ply", process=False)
            bench_occupancy(sub, args.sub_points, args.occupancy)
        else:
            bench_occupancy(bunny, args.points, args.occupancy)
        return
    if not args.no_bunny:
        bench_mesh("Bunny", bunny, 100_000 if args.quick else args.points, 20_000)
    if not args.quick:
        sub = trimesh.load(args.meshes / "bun_zipper_subdiv2.ply", process=False)
        # trimesh on 1.1M triangles: not measured this round (the runs that tried it ran out of time)
        bench_mesh("Subdivided bunny", sub, args.sub_points, 0)


if __name__ == "__main__":
    main()
