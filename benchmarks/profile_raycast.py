"""Where the time of `RaycastingScene.cast_rays` / `test_occlusions` goes, case by case (issue 9, item 1).

    python benchmarks/profile_raycast.py            # bunny: flat, image, incoherent; 1.1M bunny: flat
    python benchmarks/profile_raycast.py --quick    # 256x256 and 65k incoherent rays, bunny only

For each case it times the stages of a query on float32 input, median of --repeat runs: the input's parsing
(`_rays`: shapes, dtypes, the image width; the rays themselves are read by the kernels), the traversal kernel
alone on 1 and 2 threads (`TwoLevelBVH.closest_hit` / `any_hit` on contiguous float64 rays made untimed), and
what `cast_rays` spends beyond it (loading and checking the rays, ids, uvs, normals, the outputs); it reports
the share of 16-ray chunks the packet kernels can take (same direction signs and axis permutation), and, from a counting
copy of the one-ray traversal, node visits and triangle tests per ray (nearest-first closest hit).
"""

from __future__ import annotations

import argparse

import numba as nb
import numpy as np
from raycases import SHARED, camera_rays, load_mesh, median_time, random_rays

from durer import RaycastingScene
from durer.kernels.bvh.layout import LEAF_COUNT_MASK, PACKET, TILE


@nb.njit(cache=True)
def _count_visits(bounds, child, o, d, t_ref):
    """Node visits and leaf-item tests per ray of a traversal that culls with each ray's final t from the start:
    a floor on the work of any closest-hit traversal of this tree (a real one finds its hit on the way)."""
    n = o.shape[0]
    visits = np.zeros(n, np.int64)
    tests = np.zeros(n, np.int64)
    stack = np.empty(256, np.int64)
    for i in range(n):
        ox, oy, oz = o[i, 0], o[i, 1], o[i, 2]
        ix = 1.0 / d[i, 0] if d[i, 0] != 0.0 else 1e300
        iy = 1.0 / d[i, 1] if d[i, 1] != 0.0 else 1e300
        iz = 1.0 / d[i, 2] if d[i, 2] != 0.0 else 1e300
        far = t_ref[i] * (1 + 1e-12) if np.isfinite(t_ref[i]) else np.inf
        stack[0] = 0
        sp = 1
        while sp > 0:
            sp -= 1
            node = stack[sp]
            if node < 0:
                v = -node - 1
                tests[i] += v & LEAF_COUNT_MASK
                continue
            visits[i] += 1
            for lane in range(4):
                c = child[node, lane]
                if c == 0:
                    continue
                b = bounds[node]
                t0x, t1x = (b[0, lane] - ox) * ix, (b[3, lane] - ox) * ix
                t0y, t1y = (b[1, lane] - oy) * iy, (b[4, lane] - oy) * iy
                t0z, t1z = (b[2, lane] - oz) * iz, (b[5, lane] - oz) * iz
                tn = max(max(min(t0x, t1x), min(t0y, t1y)), max(min(t0z, t1z), 0.0))
                tf = min(min(max(t0x, t1x), max(t0y, t1y)), min(max(t0z, t1z), far))
                if tn <= tf:
                    stack[sp] = c
                    sp += 1
    return visits, tests


def coherent_share(d: np.ndarray, width: int) -> float:
    """Share of PACKET-ray chunks whose rays share direction signs and dominant axis (the packet kernels' test)."""
    n = len(d) // PACKET * PACKET
    if width:
        h = n // width
        idx = np.arange(n).reshape(h // TILE, TILE, width // TILE, TILE).transpose(0, 2, 1, 3).reshape(-1, PACKET)
    else:
        idx = np.arange(n).reshape(-1, PACKET)
    key = (d < 0) @ np.array([1, 2, 4]) + 8 * np.argmax(np.abs(d), axis=1)
    k = key[idx]
    return float((k == k[:, :1]).all(axis=1).mean())


def profile_case(name: str, scene: RaycastingScene, o: np.ndarray, d: np.ndarray, shape, repeat: int) -> None:
    o32 = o.astype(np.float32).reshape(*shape, 3)
    d32 = d.astype(np.float32).reshape(*shape, 3)
    n = len(o)
    tree = scene._tree()
    sec_in, rays = median_time(lambda: scene._rays(o32, d32, 0.0, np.inf), repeat)
    # the kernel alone, on the arrays it traces: contiguous float64 rays and per-ray t ranges, made untimed
    oo, dd = o32.reshape(-1, 3).astype(np.float64), d32.reshape(-1, 3).astype(np.float64)
    lo, hi = np.zeros(n), np.full(n, np.inf)
    width = rays.width
    kern = {}
    for k in (1, 2):
        nb.set_num_threads(k)
        kern[k], res = median_time(lambda: tree.closest_hit(oo, dd, lo, hi, width), repeat)
        kern[f"any{k}"], _ = median_time(lambda: tree.any_hit(oo, dd, lo, hi, width), repeat)
    t = res[0]
    sec_api, _ = median_time(lambda: scene.cast_rays(o32, d32), repeat)
    sec_occ, _ = median_time(lambda: scene.test_occlusions(o32, d32), repeat)
    sec_out = max(sec_api - sec_in - kern[2], 0.0)
    bvh = scene._shapes[0].tree
    visits, tests = _count_visits(bvh.bounds, bvh.child, oo, dd, t)
    share = coherent_share(dd, width)

    def ms(s):
        return f"{1e3 * s:.0f} ms"

    print(f"| {name} | {n / sec_api / 1e6:.2f} | {n / sec_occ / 1e6:.2f} | {ms(sec_in)} | {ms(kern[1])} / "
          f"{ms(kern[2])} ({kern[1] / kern[2]:.2f}x) | {ms(kern['any2'])} | {ms(sec_out)} | "
          f"{100 * kern[2] / sec_api:.0f}% | {100 * kern['any2'] / sec_occ:.0f}% | {100 * share:.0f}% | "
          f"{visits.mean():.1f} / {tests.mean():.1f} | {100 * np.isfinite(t).mean():.0f}% |")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--meshes", default=SHARED / "meshes")
    args = ap.parse_args(argv)
    res = 256 if args.quick else 1024
    bunny = load_mesh(args.meshes, "bun_zipper.ply")
    cases = []
    o, d = camera_rays(bunny, res)
    cases += [("bunny, pinhole, flat (N,3)", bunny, o, d, (res * res,)),
              ("bunny, pinhole, (H,W,3) image", bunny, o, d, (res, res))]
    o, d = random_rays(bunny, res * res)
    cases.append(("bunny, incoherent", bunny, o, d, (res * res,)))
    if not args.quick:
        big = load_mesh(args.meshes, "bun_zipper_subdiv2.ply")
        o, d = camera_rays(big, res)
        cases.append(("1.1M bunny, pinhole, flat", big, o, d, (res * res,)))
    print(f"{res * res:,} rays per case, float32 input, median of {args.repeat}; kernel = TwoLevelBVH.closest_hit")
    print("| case | cast_rays Mrays/s (2 thr) | test_occlusions Mrays/s | input parse (_rays) | closest kernel "
          "1 / 2 threads (scaling) | any kernel 2 thr | rest of cast_rays (load + check, ids, uvs, normals, "
          "outputs) | kernel share of cast_rays | of test_occlusions | coherent 16-ray chunks | nodes / triangle "
          "tests per ray (one-ray floor) | hit |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    scenes: dict[int, RaycastingScene] = {}
    for name, mesh, o, d, shape in cases:
        if id(mesh) not in scenes:
            s = RaycastingScene()
            s.add_triangles(mesh.vertices, mesh.faces)
            s.cast_rays(np.zeros((16, 6), np.float32) + [0, 0, 0, 0, 0, 1])
            scenes[id(mesh)] = s
        profile_case(name, scenes[id(mesh)], o, d, shape, args.repeat)
    nb.set_num_threads(nb.config.NUMBA_NUM_THREADS)


if __name__ == "__main__":
    main()
