"""SHA-1 of count_intersections and list_intersections on fixed scenes and rays (issue 21 item 4): run it on two
checkouts to check that a change to the all-hits walks gives the same counts and lists, to the bit.

Scenes: the bunny alone, and the bunny placed twice (one copy rotated and moved) beside a sphere; rays: 256²
camera rays given flat and as an image (4 x 4 tile packets), 2^18 incoherent rays, each in float32 and float64.

    PYTHONPATH=src python benchmarks/crossings_sha.py [--meshes ../shared/meshes]
"""

from __future__ import annotations

import argparse
import hashlib
from pathlib import Path

import numpy as np
from raycases import SHARED, camera_rays, load_mesh, random_rays

from durer import RaycastingScene


def scenes(mesh) -> dict:
    v, f = np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)
    one = RaycastingScene()
    one.add_triangles(v, f)
    two = RaycastingScene()
    g = two.add_triangles(v, f)
    c, r = 0.5 * (mesh.bounds[0] + mesh.bounds[1]), float(np.linalg.norm(mesh.bounds[1] - mesh.bounds[0]))
    a = np.radians(30.0)
    m = np.eye(4)
    m[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    m[:3, 3] = c - m[:3, :3] @ c + [0.3 * r, 0.0, -0.2 * r]
    two.add_instance(g, m)
    two.add_sphere(c + [-0.3 * r, 0.05 * r, 0.0], 0.15 * r)
    return {"bunny": one, "bunny x2 + sphere": two}


def digest(out) -> str:
    h = hashlib.sha1()
    if isinstance(out, dict):
        for k in sorted(out):
            h.update(k.encode())
            h.update(np.ascontiguousarray(np.asarray(out[k])).tobytes())
    else:
        h.update(np.ascontiguousarray(np.asarray(out)).tobytes())
    return h.hexdigest()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--meshes", type=Path, default=SHARED / "meshes")
    args = ap.parse_args()
    mesh = load_mesh(args.meshes, "bun_zipper.ply")
    o, d = camera_rays(mesh, 256)
    ro, rd = random_rays(mesh, 1 << 18)
    batches = {"camera flat": np.hstack([o, d]), "camera image": np.hstack([o, d]).reshape(256, 256, 6),
               "incoherent": np.hstack([ro, rd])}
    total = hashlib.sha1()
    for sname, scene in scenes(mesh).items():
        for bname, r in batches.items():
            for dt in (np.float32, np.float64):
                rays = r.astype(dt)
                c, lists = digest(scene.count_intersections(rays)), digest(scene.list_intersections(rays))
                total.update((c + lists).encode())
                print(f"{sname:18s} {bname:13s} {dt.__name__:8s} counts {c[:12]} lists {lists[:12]}")
    print("all:", total.hexdigest())


if __name__ == "__main__":
    main()
