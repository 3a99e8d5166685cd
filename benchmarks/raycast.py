"""Ray casting benchmark: durer's BVH against embreex, Open3D and Mitsuba 3 (each when installed), same rays,
same run, so the ratios are fair on a shared machine.

    python benchmarks/raycast.py                 # bunny + 1.1M bunny, 1024x1024 rays, scaling table, CLI timing
    python benchmarks/raycast.py --quick         # 256x256 rays, bunny only, no scaling table, no cold start

Meshes: the Stanford bunny and its subdivided version (Stanford Computer Graphics Laboratory), looked up in
../shared/meshes next to the repository or in --meshes. Prints build seconds, Mrays/s on 1 and 2 threads,
structure memory, first-call (compile) seconds, warm and cold `durer raycast` wall time, and per peer: its
build and Mrays/s, hit/miss agreement and t agreement with durer, and durer / peer.
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

from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"


def best_of(fn, repeat: int) -> tuple[float, object]:
    """Fastest wall time of `repeat` calls, and the last result."""
    best, out = np.inf, None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - start)
    return best, out


def camera_rays(mesh: trimesh.Trimesh, res: int) -> tuple[np.ndarray, np.ndarray]:
    """res x res pinhole rays (30 degree field of view) looking at the mesh along -z, framed to fill the view."""
    lo, hi = mesh.bounds
    c, r = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    eye = c + np.array([0.0, 0.0, 2.6 * r])
    s = np.tan(np.radians(15))
    j, i = np.meshgrid(np.arange(res), np.arange(res))
    d = np.stack([((j + 0.5) / res * 2 - 1) * s, (1 - (i + 0.5) / res * 2) * s, -np.ones((res, res))], -1)
    d = d.reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(np.broadcast_to(eye, d.shape)), d


def agreement(t_ref: np.ndarray, t: np.ndarray) -> str:
    """Hit/miss agreement and the median / 99.9th percentile relative t difference where both hit."""
    h0, h1 = np.isfinite(t_ref), np.isfinite(t)
    both = h0 & h1
    rel = np.abs(t[both] - t_ref[both]) / np.maximum(np.abs(t_ref[both]), 1e-30)
    med, p999 = (np.median(rel), np.percentile(rel, 99.9)) if both.any() else (0.0, 0.0)
    return f"hit/miss agree {100 * (h0 == h1).mean():.4f}%, rel dt median {med:.1e}, p99.9 {p999:.1e}"


# ------------------------------------------------------------------------------------------------------ peers

def peer_embreex(v, f, o, d, repeat):
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh as EmbreeMesh

    tri = v[f].astype(np.float32)

    def build():
        s = rtcore_scene.EmbreeScene()
        EmbreeMesh(s, tri)
        return s

    b, scene = best_of(build, repeat)
    o32, d32 = o.astype(np.float32), d.astype(np.float32)
    scene.run(o32[:1000], d32[:1000], output=1)
    out = {"build": b, "note": "rtcIntersect1 per ray; 2 threads = two Python threads, its run() frees the GIL"}
    for n in (1, 2):
        parts = [(np.ascontiguousarray(a), np.ascontiguousarray(b_))
                 for a, b_ in zip(np.array_split(o32, n), np.array_split(d32, n), strict=True)]
        with ThreadPoolExecutor(n) as pool:
            def cast(parts=parts, pool=pool):
                return list(pool.map(lambda p: scene.run(*p, output=1), parts))

            sec, rs = best_of(cast, repeat)
        out[n] = sec
    geom = np.concatenate([r["geomID"] for r in rs])
    tfar = np.concatenate([r["tfar"] for r in rs])
    out["t"] = np.where(geom >= 0, tfar, np.inf).astype(np.float64)
    return out


def peer_open3d(v, f, o, d, repeat):
    import open3d as o3d

    vt = o3d.core.Tensor(v.astype(np.float32))
    ft = o3d.core.Tensor(f.astype(np.uint32))

    def build():
        s = o3d.t.geometry.RaycastingScene()
        s.add_triangles(vt, ft)
        s.cast_rays(o3d.core.Tensor(np.zeros((1, 6), np.float32)))  # Open3D builds lazily on the first query
        return s

    b, scene = best_of(build, repeat)
    rays = o3d.core.Tensor(np.hstack([o, d]).astype(np.float32))
    out = {"build": b, "note": "Embree inside"}
    for n in (1, 2):
        sec, r = best_of(lambda n=n: scene.cast_rays(rays, nthreads=n), repeat)
        out[n] = sec
    out["t"] = r["t_hit"].numpy().astype(np.float64)
    return out


def peer_mitsuba(v, f, o, d, repeat):
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_rgb")

    def build():
        mesh = mi.Mesh("m", len(v), len(f))
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(v.astype(np.float32).ravel())
        params["faces"] = mi.UInt32(f.astype(np.uint32).ravel())
        params.update()
        return mi.load_dict({"type": "scene", "m": mesh})

    b, scene = best_of(build, repeat)
    ray = mi.Ray3f(mi.Point3f(*[mi.Float(x) for x in o.T.astype(np.float32)]),
                   mi.Vector3f(*[mi.Float(x) for x in d.T.astype(np.float32)]))
    out = {"build": b, "note": "llvm_ad_rgb, Embree packets"}
    for n in (1, 2):
        dr.set_thread_count(n)

        def cast():
            si = scene.ray_intersect(ray)
            dr.eval(si.t)
            dr.sync_thread()  # the LLVM backend launches asynchronously
            return si

        cast()  # JIT-compiles the kernel
        sec, si = best_of(cast, repeat)
        out[n] = sec
    dr.set_thread_count(os.cpu_count() or 2)
    t = np.array(si.t, dtype=np.float64)
    out["t"] = np.where(np.isfinite(t), t, np.inf)
    return out


PEERS = {"embreex": peer_embreex, "open3d": peer_open3d, "mitsuba": peer_mitsuba}


# ------------------------------------------------------------------------------------------------------ durer

def query_api(v, f, o, d, res, repeat) -> dict:
    """durer's public query API on the same rays, given as an image: validation, packets, normals and all."""
    from durer import RaycastingScene

    rays = np.concatenate([o, d], axis=1).reshape(res, res, 6)

    def build():
        s = RaycastingScene()
        s.add_triangles(v, f)
        s.build()
        return s

    b, scene = best_of(build, repeat)
    scene.cast_rays(rays[:4, :4])
    out = {"build": b}
    for k in (1, 2):
        numba.set_num_threads(min(k, numba.config.NUMBA_NUM_THREADS))
        out[k], r = best_of(lambda: scene.cast_rays(rays), repeat)
    out["t"] = r["t_hit"].reshape(-1)
    return out


def durer_accel(v, f) -> BVHAccelerator:
    return BVHAccelerator(compile_scene(Scene(camera=None, group=Group([TriangleMesh(v, f)]))))


def bench_mesh(name: str, mesh: trimesh.Trimesh, res: int, repeat: int, peers: list[str]) -> None:
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    o, d = camera_rays(mesh, res)
    n = len(o)
    cs = compile_scene(Scene(camera=None, group=Group([TriangleMesh(v, f)])))
    builds = [BVHAccelerator(cs).build_seconds for _ in range(repeat)]
    acc = BVHAccelerator(cs)
    acc.closest_hit(o[:100], d[:100])
    res_durer = {"build": min(builds)}
    threads = numba.get_num_threads()
    for k in (1, 2):
        numba.set_num_threads(min(k, numba.config.NUMBA_NUM_THREADS))
        res_durer[k], h = best_of(lambda: acc.closest_hit(o, d, width=res), repeat)
    api = query_api(v, f, o, d, res, repeat)
    numba.set_num_threads(threads)
    t = h.t
    idx_bytes = v.astype(np.float32).nbytes + f.astype(np.int32).nbytes
    print(f"\n## {name}: {len(f):,} triangles, {res}x{res} = {n:,} pinhole rays, {100 * h.hit.mean():.1f}% hit")
    print(f"durer BVH: {acc.nbytes / 1e6:.1f} MB = {acc.nbytes / idx_bytes:.2f}x float32 vertices + int32 indices "
          f"({idx_bytes / 1e6:.1f} MB), {acc.nbytes / (v.nbytes + f.nbytes):.2f}x trimesh's float64/int64 arrays")
    print("| engine | build s | Mrays/s 1 thread | Mrays/s 2 threads | durer/peer (2 thr vs best) | agreement |")
    print("|---|---|---|---|---|---|")

    def mr(sec):
        return "-" if sec is None else f"{n / sec / 1e6:.2f}"

    print(f"| durer (BVHAccelerator.closest_hit, rays as a {res}-wide image: 4x4 packets) | {res_durer['build']:.3f} | "
          f"{mr(res_durer[1])} | {mr(res_durer[2])} | 1 | reference |")
    print(f"| durer RaycastingScene.cast_rays ((H, W, 6) rays, all outputs as Open3D's) | {api['build']:.3f} | "
          f"{mr(api[1])} | {mr(api[2])} | {min(api[1], api[2]) / res_durer[2]:.2f} | {agreement(t, api['t'])} |")
    for p in peers:
        try:
            r = PEERS[p](v, f, o, d, repeat)
        except ImportError as e:
            print(f"| {p} | not installed ({e.name}) | | | | |")
            continue
        peer_best = min(s for s in (r[1], r[2]) if s is not None)
        ratio = peer_best / res_durer[2]
        print(f"| {p} ({r['note']}) | {r['build']:.3f} | {mr(r[1])} | {mr(r[2])} | {ratio:.2f} | "
              f"{agreement(t, r['t'])} |")


def scaling(meshes: dict[str, trimesh.Trimesh], res: int, repeat: int) -> None:
    """Rays/s and build time against triangle count, 1k to 1.1M (bunny decimated, original, subdivided)."""
    bunny = meshes["bunny"]
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
    sizes.append(bunny)
    sizes.append(bunny.subdivide())
    if "bunny 1.1M" in meshes:
        sizes.append(meshes["bunny 1.1M"])
    print("\n## Scaling (durer, 2 threads)")
    print("| triangles | build s | Mrays/s | hit % |")
    print("|---|---|---|---|")
    for m in sizes:
        acc = durer_accel(np.asarray(m.vertices), np.asarray(m.faces))
        b = min([acc.build_seconds] + [durer_accel(np.asarray(m.vertices), np.asarray(m.faces)).build_seconds
                                       for _ in range(repeat - 1)])
        o, d = camera_rays(m, res)
        sec, h = best_of(lambda acc=acc, o=o, d=d: acc.closest_hit(o, d, width=res), repeat)
        print(f"| {len(m.faces):,} | {b:.3f} | {len(o) / sec / 1e6:.2f} | {100 * h.hit.mean():.1f} |")


def startup(scene_file: Path) -> None:
    """First-call compile seconds (empty Numba cache) and warm/cold `durer raycast` wall time."""
    code = ("import time, numpy as np, trimesh; t = time.perf_counter(); "
            "from durer.accel.bvh import BVHAccelerator; from durer.accel.compile import compile_scene; "
            "from durer.scene.graph import Group, Scene; from durer.scene.shapes import TriangleMesh; "
            "m = trimesh.creation.icosphere(2); "
            "a = BVHAccelerator(compile_scene(Scene(None, Group([TriangleMesh(m.vertices, m.faces)])))); "
            "a.closest_hit(np.zeros((4, 3)), np.ones((4, 3))); a.any_hit(np.zeros((4, 3)), np.ones((4, 3))); "
            "print(time.perf_counter() - t)")
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
        print("\n## Start-up")
        if out.returncode == 0:
            print(f"- BVH first call with an empty Numba cache (build + closest + any kernels compiled): "
                  f"{float(out.stdout.split()[-1]):.1f} s")
        else:
            print(f"- BVH first call failed: {out.stderr.strip().splitlines()[-1:]}")
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


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="256x256 rays, bunny only, no scaling, no start-up")
    ap.add_argument("--res", type=int, default=None, help="image side in rays (default 1024, quick 256)")
    ap.add_argument("--repeat", type=int, default=3, help="timed repetitions, the best is kept")
    ap.add_argument("--meshes", type=Path, default=SHARED / "meshes", help="folder with the bunny PLY files")
    ap.add_argument("--peers", default="embreex,open3d,mitsuba", help="comma-separated peers to run if installed")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--no-startup", action="store_true")
    args = ap.parse_args(argv)
    res = args.res or (256 if args.quick else 1024)
    peers = [p for p in args.peers.split(",") if p]
    files = {"bunny": "bun_zipper.ply"} if args.quick else {"bunny": "bun_zipper.ply",
                                                             "bunny 1.1M": "bun_zipper_subdiv2.ply"}
    meshes = {}
    for name, file in files.items():
        path = args.meshes / file
        if not path.exists():
            sys.exit(f"mesh not found: {path} (pass --meshes FOLDER)")
        meshes[name] = trimesh.load(path, process=False)
    print(f"# durer ray casting benchmark, {time.strftime('%Y-%m-%d %H:%M')}")
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, numba {numba.__version__}, threading layer {numba.config.THREADING_LAYER}")
    print("Meshes: Stanford bunny (Stanford Computer Graphics Laboratory); Mrays/s are best of "
          f"{args.repeat}; peers use float32, durer float64.")
    for name, mesh in meshes.items():
        bench_mesh(name, mesh, res, args.repeat, peers)
    if not (args.quick or args.no_scaling):
        scaling(meshes, min(res, 512), args.repeat)
    if not (args.quick or args.no_startup):
        startup(SHARED / "scenes" / "mit6837" / "assignment1" / "scene1_01.txt")


if __name__ == "__main__":
    main()
