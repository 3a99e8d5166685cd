"""Ray casting benchmark: durer's public query API against embreex, Open3D and Mitsuba 3 (each when installed),
same rays, same run, engines interleaved, so the ratios are fair on a shared machine.

    python benchmarks/raycast.py                 # 1024x1024 rays; bunny (flat, image, incoherent) + 1.1M bunny
    python benchmarks/raycast.py --quick         # 256x256 rays, bunny only, no scaling table, no start-up

Headline: `RaycastingScene.cast_rays` and `test_occlusions` on float32 input (what a user passes; `cast_rays` then
returns float32 t, uvs and normals, as Open3D and Embree do), on 2 threads,
for four batches: pinhole rays given flat ((N, 3) origins + directions), the same rays as one (H, W, 6) image,
incoherent rays (random points to random surface points), and pinhole rays at the 1.1M-triangle bunny. Beside
them durer's kernel (`BVHAccelerator.closest_hit`, float64 arrays, no checks or normals) and every installed peer
on its native input: embreex (`rtcIntersect1` per ray, two Python threads), Open3D `cast_rays` (Embree inside),
Mitsuba 3 `llvm_ad_rgb` (Embree packets; needs libLLVM, e.g. `apt-get install libllvm19` and
DRJIT_LIBLLVM_PATH) and `scalar_rgb` (one Python call per ray, on a subset). Each figure is the median of
--repeat timed calls; every round times every engine once, in turn, each round starting one engine later, with
SETTLE seconds of rest before each call; Mitsuba's memory cache is flushed after each of its calls (while Dr.Jit
held it, the next engine ran up to 3x slow). Agreement: hit/miss and relative t against
durer's `cast_rays`. Meshes: the Stanford bunny and its subdivision (Stanford Computer Graphics Laboratory), read
from ../shared/meshes or --meshes, never shipped.
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numba
import numpy as np
import trimesh
from open3d_rows import open3d_rows
from raycases import SHARED, camera_rays, load_mesh, median_time, random_rays

from durer import RaycastingScene
from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
SETTLE = 0.5  # seconds of rest before each timed call
SCALAR_RAYS = 1 << 15  # Mitsuba scalar_rgb is a Python loop: timed on this many of the rays
AFTER_CALL: list = []  # called after every timed call, untimed


def agreement(t_ref: np.ndarray, t: np.ndarray) -> str:
    """Hit/miss agreement and the median / 99.9th percentile relative t difference where both hit."""
    h0, h1 = np.isfinite(t_ref), np.isfinite(t)
    both = h0 & h1
    rel = np.abs(t[both] - t_ref[both]) / np.maximum(np.abs(t_ref[both]), 1e-30)
    med, p999 = (np.median(rel), np.percentile(rel, 99.9)) if both.any() else (0.0, 0.0)
    return f"hit/miss {100 * (h0 == h1).mean():.4f}%, dt/t median {med:.0e}, p99.9 {p999:.0e}"


def timed_build(fn):
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


# ------------------------------------------------------------------------------------------------------ engines
# Each engine: prepare(v, f, threads) -> (build seconds, make(case) -> (n rays timed, cast() -> t float64)).
# A case is a dict: o, d (N, 3) float64, shape (leading shape the rays are given in), res.

def durer_api(v, f, threads):
    b, scene = timed_build(lambda: _durer_scene(v, f))

    def make(case):
        args = _api_input(case)
        scene.cast_rays(*[a[:4] for a in args])
        return len(case["o"]), lambda: scene.cast_rays(*args)["t_hit"].reshape(-1).astype(np.float64)
    return b, make


def durer_occlusions(v, f, threads):
    scene = _durer_scene(v, f)

    def make(case):
        args = _api_input(case)
        scene.test_occlusions(*[a[:4] for a in args])
        return len(case["o"]), lambda: np.where(scene.test_occlusions(*args).reshape(-1), 1.0, np.inf)
    return None, make


def durer_kernel(v, f, threads):
    b, acc = timed_build(lambda: BVHAccelerator(compile_scene(Scene(camera=None, group=Group([TriangleMesh(v, f)])))))

    def make(case):
        o, d = case["o"], case["d"]
        width = case["res"] if len(case["shape"]) == 2 else 0
        acc.closest_hit(o[:64], d[:64])
        return len(o), lambda: acc.closest_hit(o, d, width=width).t
    return b, make


def _durer_scene(v, f) -> RaycastingScene:
    s = RaycastingScene()
    s.add_triangles(v, f)
    s.build()
    return s


def _api_input(case) -> tuple:
    o32, d32 = case["o"].astype(np.float32), case["d"].astype(np.float32)
    if len(case["shape"]) == 2:
        return (np.concatenate([o32, d32], axis=1).reshape(*case["shape"], 6),)
    return o32, d32


def embreex(v, f, threads):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh as EmbreeMesh

    tri = v[f].astype(np.float32)

    def build():
        s = rtcore_scene.EmbreeScene()
        EmbreeMesh(s, tri)
        s.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32), output=1)  # commits the scene
        return s

    b, scene = timed_build(build)
    pool = ThreadPoolExecutor(threads)

    def make(case):
        o32, d32 = case["o"].astype(np.float32), case["d"].astype(np.float32)
        parts = [(np.ascontiguousarray(a), np.ascontiguousarray(c))
                 for a, c in zip(np.array_split(o32, threads), np.array_split(d32, threads), strict=True)]

        def cast():
            rs = list(pool.map(lambda p: scene.run(*p, output=1), parts))
            geom = np.concatenate([r["geomID"] for r in rs])
            return np.where(geom >= 0, np.concatenate([r["tfar"] for r in rs]), np.inf).astype(np.float64)
        return len(o32), cast
    return b, make


def open3d(v, f, threads):
    import open3d as o3d

    def build():
        s = o3d.t.geometry.RaycastingScene()
        s.add_triangles(o3d.core.Tensor(v.astype(np.float32)), o3d.core.Tensor(f.astype(np.uint32)))
        s.cast_rays(o3d.core.Tensor(np.zeros((1, 6), np.float32)))  # Open3D builds on the first query
        return s

    b, scene = timed_build(build)

    def make(case):
        rays = o3d.core.Tensor(np.hstack([case["o"], case["d"]]).astype(np.float32))
        return len(case["o"]), lambda: scene.cast_rays(rays, nthreads=threads)["t_hit"].numpy().astype(np.float64)
    return b, make


def mitsuba_llvm(v, f, threads):
    if os.path.exists(LLVM):
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")
    dr.set_thread_count(threads)
    # Dr.Jit keeps freed arrays in its own cache; while it holds them, the next engine's calls ran 1.5-3x slower
    # (durer's cast_rays 0.25 -> 0.5-0.7 s for a million rays, even 2 s later): hand the memory back after each call
    if dr.flush_malloc_cache not in AFTER_CALL:
        AFTER_CALL.append(dr.flush_malloc_cache)
    b, scene = timed_build(lambda: _mitsuba_scene(mi, v, f))

    def make(case):
        mi.set_variant("llvm_ad_rgb")
        ray = mi.Ray3f(mi.Point3f(*[mi.Float(x) for x in case["o"].T.astype(np.float32)]),
                       mi.Vector3f(*[mi.Float(x) for x in case["d"].T.astype(np.float32)]))

        def cast():
            si = scene.ray_intersect(ray)
            dr.eval(si.t)
            dr.sync_thread()  # the LLVM backend launches asynchronously
            t = np.array(si.t, dtype=np.float64)
            return np.where(np.isfinite(t), t, np.inf)
        cast()  # JIT-compiles the kernel
        return len(case["o"]), cast
    return b, make


def mitsuba_scalar(v, f, threads):
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    b, scene = timed_build(lambda: _mitsuba_scene(mi, v, f))

    def make(case):
        mi.set_variant("scalar_rgb")
        step = max(1, len(case["o"]) // SCALAR_RAYS)
        o, d = case["o"][::step].astype(np.float32), case["d"][::step].astype(np.float32)
        rays = [mi.Ray3f(mi.Point3f(*a), mi.Vector3f(*c)) for a, c in zip(o.tolist(), d.tolist(), strict=True)]

        def cast():
            t = np.array([scene.ray_intersect(r).t for r in rays], dtype=np.float64)
            full = np.full(len(case["o"]), np.nan)  # only the subset is compared
            full[::step] = np.where(np.isfinite(t), t, np.inf)
            return full
        return len(rays), cast
    return b, make


def _mitsuba_scene(mi, v, f):
    mesh = mi.Mesh("m", len(v), len(f))
    params = mi.traverse(mesh)
    scalar = mi.variant().startswith("scalar")  # scalar variants take NumPy arrays for these buffers
    pos, idx = v.astype(np.float32).ravel(), f.astype(np.uint32).ravel()
    params["vertex_positions"] = pos if scalar else mi.Float(pos)
    params["faces"] = idx if scalar else mi.UInt32(idx)
    params.update()
    return mi.load_dict({"type": "scene", "m": mesh})


ENGINES = {
    "durer cast_rays": (durer_api, "public API, float32 input, all outputs (t, ids, uvs, normals): "
                                    "float32 outputs for float32 input, as Open3D and Embree return"),
    "durer test_occlusions": (durer_occlusions, "public API, any hit"),
    "durer kernel": (durer_kernel, "BVHAccelerator.closest_hit: float64 arrays, no checks, no normals"),
    "embreex": (embreex, "rtcIntersect1 per ray, two Python threads (run() frees the GIL)"),
    "open3d": (open3d, "RaycastingScene.cast_rays, Embree inside"),
    "mitsuba llvm": (mitsuba_llvm, "llvm_ad_rgb, Embree packets"),
    "mitsuba scalar": (mitsuba_scalar, f"scalar_rgb, one Python call per ray, {SCALAR_RAYS:,} of the rays, 1 thread"),
}


def bench_case(name: str, case: dict, engines: dict, repeat: int) -> dict:
    """Every engine on one case, interleaved: returns {engine: (Mrays/s, t)}."""
    casts = {}
    for e, make in engines.items():
        casts[e] = make(case)
    times: dict[str, list[float]] = {e: [] for e in casts}
    outs = {}
    names = list(casts)
    for r in range(repeat):
        for e in names[r % len(names):] + names[:r % len(names)]:  # each round starts one engine later
            cast = casts[e][1]
            time.sleep(SETTLE)  # the previous engine's worker threads stop spinning (TBB, OpenMP, Dr.Jit)
            start = time.perf_counter()
            outs[e] = cast()
            times[e].append(time.perf_counter() - start)
            for hook in AFTER_CALL:  # untimed
                hook()
    ref = outs["durer cast_rays"]
    print(f"\n### {name}: {len(case['o']):,} rays, {100 * np.isfinite(ref).mean():.1f}% hit")
    print("| engine | Mrays/s | durer cast_rays / engine | agreement with durer cast_rays |")
    print("|---|---|---|---|")
    res = {}
    for e, (n, _) in casts.items():
        rate = n / np.median(times[e]) / 1e6
        res[e] = rate
        t = outs[e]
        sel = ~np.isnan(t)
        agree = ("reference" if e == "durer cast_rays" else
                 f"hit/miss {100 * (np.isfinite(t[sel]) == np.isfinite(ref[sel])).mean():.4f}%"
                 if e == "durer test_occlusions" else agreement(ref[sel], t[sel]))
        ratio = res["durer cast_rays"] / rate
        print(f"| {e} | {rate:.2f} | {ratio:.2f} | {agree} |")
    return res


def bench_mesh(name: str, mesh: trimesh.Trimesh, cases: dict, engine_names: list[str], threads: int,
               repeat: int) -> dict:
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    print(f"\n## {name}: {len(f):,} triangles")
    engines, builds = {}, {}
    for e in engine_names:
        try:
            builds[e], engines[e] = ENGINES[e][0](v, f, threads)
        except (ImportError, OSError, RuntimeError) as err:
            print(f"- {e}: not available ({err})")
    b_api = median_time(lambda: _durer_scene(v, f), min(repeat, 3))[0]
    acc = BVHAccelerator(compile_scene(Scene(camera=None, group=Group([TriangleMesh(v, f)]))))
    idx = v.nbytes + f.nbytes
    print(f"- durer build: RaycastingScene {b_api:.3f} s (median), BVHAccelerator {acc.build_seconds:.3f} s; "
          f"structure {acc.nbytes / 1e6:.1f} MB = {acc.nbytes / idx:.2f}x the float64/int64 vertex + index arrays")
    print("- peer builds (one each): " + ", ".join(f"{e} {b:.3f} s" for e, b in builds.items()
                                                  if b is not None and not e.startswith("durer")))
    print("- engines: " + "; ".join(f"{e}: {ENGINES[e][1]}" for e in engines))
    return {c: bench_case(f"{name}, {c}", case, engines, repeat) for c, case in cases.items()}


def scaling(bunny: trimesh.Trimesh, big: trimesh.Trimesh | None, res: int, repeat: int) -> None:
    """cast_rays (flat float32 pinhole rays) and build time against triangle count, 1k to 1.1M."""
    sizes: list[trimesh.Trimesh] = []
    try:
        import open3d as o3d

        om = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(bunny.vertices),
                                       o3d.utility.Vector3iVector(bunny.faces))
        for target in (1000, 4000, 16000):
            s = om.simplify_quadric_decimation(target)
            sizes.append(trimesh.Trimesh(np.asarray(s.vertices), np.asarray(s.triangles), process=False))
    except ImportError:
        sizes.append(trimesh.creation.icosphere(4))
    sizes += [bunny, bunny.subdivide()] + ([big] if big is not None else [])
    print(f"\n## Scaling (durer cast_rays, flat float32 {res}x{res} pinhole rays)")
    print("| triangles | build s | Mrays/s | hit % |")
    print("|---|---|---|---|")
    for m in sizes:
        v, f = np.asarray(m.vertices), np.asarray(m.faces)
        b, scene = median_time(lambda v=v, f=f: _durer_scene(v, f), repeat)
        o, d = camera_rays(m, res)
        o32, d32 = o.astype(np.float32), d.astype(np.float32)
        sec, h = median_time(lambda s=scene, o=o32, d=d32: s.cast_rays(o, d), repeat)
        print(f"| {len(f):,} | {b:.3f} | {len(o) / sec / 1e6:.2f} | {100 * np.isfinite(h['t_hit']).mean():.1f} |")


def startup(scene_file: Path) -> None:
    """First-call compile seconds (empty Numba cache) and warm/cold `durer raycast` wall time."""
    code = ("import time, numpy as np; t = time.perf_counter(); from durer import RaycastingScene; "
            "s = RaycastingScene(); s.add_triangles(np.eye(3), [[0, 1, 2]]); "
            "s.cast_rays(np.zeros((4, 3)), np.ones((4, 3))); s.test_occlusions(np.zeros((4, 3)), np.ones((4, 3))); "
            "print(time.perf_counter() - t)")
    print("\n## Start-up")
    with tempfile.TemporaryDirectory() as cache:
        out = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, NUMBA_CACHE_DIR=cache),
                             capture_output=True, text=True)
        if out.returncode == 0:
            sec = float(out.stdout.split()[-1])
            print(f"- first cast_rays + test_occlusions with an empty Numba cache: {sec:.1f} s")
        else:
            print(f"- first query failed: {out.stderr.strip().splitlines()[-1:]}")
    exe = shutil.which("durer")
    if exe is None or not scene_file.exists():
        print(f"- durer raycast: skipped ({'no durer command' if exe is None else f'{scene_file} missing'})")
        return
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [exe, "raycast", "-input", str(scene_file), "-size", "200", "200", "-output", f"{tmp}/x.tga"]
        for label, env in (("cold (empty Numba cache)", dict(os.environ, NUMBA_CACHE_DIR=f"{tmp}/cache")),
                           ("warm", dict(os.environ))):
            if label == "warm":
                subprocess.run(cmd, env=env, capture_output=True)
            start = time.perf_counter()
            r = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=scene_file.parent)
            sec = time.perf_counter() - start
            status = "" if r.returncode == 0 else f" (exit {r.returncode}: {r.stderr.strip()[-200:]})"
            print(f"- `durer raycast -input {scene_file.name} -size 200 200` {label}: {sec:.2f} s{status}")


def summary(results: dict) -> None:
    print("\n## Summary (Mrays/s, median; durer = cast_rays; ratios > 1 favour durer)")
    print("| case | durer cast_rays | durer test_occlusions | durer kernel | embreex | Open3D | Mitsuba llvm | "
          "Mitsuba scalar | durer / embreex | durer / Mitsuba llvm |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for case, r in results.items():
        def g(e, r=r):
            return f"{r[e]:.2f}" if e in r else "-"

        def ratio(e, r=r):
            return f"**{r['durer cast_rays'] / r[e]:.2f}**" if e in r else "-"
        print(f"| {case} | {g('durer cast_rays')} | {g('durer test_occlusions')} | {g('durer kernel')} | "
              f"{g('embreex')} | {g('open3d')} | {g('mitsuba llvm')} | {g('mitsuba scalar')} | "
              f"{ratio('embreex')} | {ratio('mitsuba llvm')} |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="256x256 rays, bunny only, no scaling, no start-up")
    ap.add_argument("--res", type=int, default=None, help="image side in rays (default 1024, quick 256)")
    ap.add_argument("--repeat", type=int, default=5, help="timed rounds; figures are medians")
    ap.add_argument("--threads", type=int, default=2, help="threads for every engine that takes a count")
    ap.add_argument("--meshes", type=Path, default=SHARED / "meshes", help="folder with the bunny PLY files")
    ap.add_argument("--engines", default=",".join(ENGINES), help="comma-separated engines to run if installed")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--no-startup", action="store_true")
    ap.add_argument("--open3d-only", action="store_true",
                    help="only Open3D's rows: count_intersections, list_intersections, build (open3d_rows.py)")
    args = ap.parse_args(argv)
    res = args.res or (256 if args.quick else 1024)
    engines = [e for e in args.engines.split(",") if e]
    for must in ("durer cast_rays",):
        if must not in engines:
            engines.insert(0, must)
    numba.set_num_threads(min(args.threads, numba.config.NUMBA_NUM_THREADS))
    bunny = load_mesh(args.meshes, "bun_zipper.ply")
    big = None if args.quick else load_mesh(args.meshes, "bun_zipper_subdiv2.ply")
    print(f"# durer ray casting benchmark, {time.strftime('%Y-%m-%d %H:%M')}")
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.2f}, Python {platform.python_version()}, numba {numba.__version__}; "
          f"{args.threads} threads; median of {args.repeat} interleaved rounds")
    print("Meshes: Stanford bunny (Stanford Computer Graphics Laboratory).")
    if args.open3d_only:
        open3d_rows(bunny, big, res, args.repeat, args.threads, camera_rays, random_rays)
        return
    o, d = camera_rays(bunny, res)
    ro, rd = random_rays(bunny, res * res)
    results = {}
    cases = {"pinhole flat (N,3)": dict(o=o, d=d, shape=(res * res,), res=res),
             "pinhole image (H,W,6)": dict(o=o, d=d, shape=(res, res), res=res),
             "incoherent (random points to random surface points)": dict(o=ro, d=rd, shape=(res * res,), res=res)}
    for c, r in bench_mesh("bunny", bunny, cases, engines, args.threads, args.repeat).items():
        results[f"bunny, {c}"] = r
    if big is not None:
        o, d = camera_rays(big, res)
        cases = {"pinhole flat (N,3)": dict(o=o, d=d, shape=(res * res,), res=res)}
        for c, r in bench_mesh("1.1M bunny", big, cases, engines, args.threads, args.repeat).items():
            results[f"1.1M bunny, {c}"] = r
    summary(results)
    open3d_rows(bunny, big, res, args.repeat, args.threads, camera_rays, random_rays)
    if not (args.quick or args.no_scaling):
        scaling(bunny, big, min(res, 512), 3)
    if not (args.quick or args.no_startup):
        startup(SHARED / "scenes" / "mit6837" / "assignment1" / "scene1_01.txt")


if __name__ == "__main__":
    main()
