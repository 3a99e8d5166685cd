"""The ray batches every ray casting benchmark uses (benchmarks/raycast.py, benchmarks/profile_raycast.py).

* camera rays: res x res pinhole rays (30 degree field of view) looking at the mesh along -z, framed to fill
  the view, in row-major image order;
* incoherent rays: from random points in the mesh's bounding box (grown by half its size on each side) towards
  random points on the surface (area-weighted), the kind of batch a visibility or path-tracing query makes.

Meshes: the Stanford bunny and its subdivided version (Stanford Computer Graphics Laboratory), never shipped.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
import trimesh

SHARED = Path(os.environ.get("DURER_SHARED", Path(__file__).resolve().parents[2] / "shared"))  # as tests/conftest.py


def camera_rays(mesh: trimesh.Trimesh, res: int) -> tuple[np.ndarray, np.ndarray]:
    """res x res pinhole rays looking at the mesh along -z: origins, unit directions (res * res, 3) float64."""
    lo, hi = mesh.bounds
    c, r = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    eye = c + np.array([0.0, 0.0, 2.6 * r])
    s = np.tan(np.radians(15))
    j, i = np.meshgrid(np.arange(res), np.arange(res))
    d = np.stack([((j + 0.5) / res * 2 - 1) * s, (1 - (i + 0.5) / res * 2) * s, -np.ones((res, res))], -1)
    d = d.reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(np.broadcast_to(eye, d.shape)), d


def random_rays(mesh: trimesh.Trimesh, n: int, seed: int = 9) -> tuple[np.ndarray, np.ndarray]:
    """n rays from uniform random points in the grown bounding box to area-weighted random surface points."""
    rng = np.random.default_rng(seed)
    lo, hi = mesh.bounds
    size = hi - lo
    o = rng.uniform(lo - size / 2, hi + size / 2, (n, 3))
    tri = np.asarray(mesh.triangles)
    area = np.asarray(mesh.area_faces)
    f = rng.choice(len(tri), n, p=area / area.sum())
    a, b = rng.random(n), rng.random(n)
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    p = tri[f, 0] + a[:, None] * (tri[f, 1] - tri[f, 0]) + b[:, None] * (tri[f, 2] - tri[f, 0])
    d = p - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return o, d


def load_mesh(folder: Path, file: str) -> trimesh.Trimesh:
    path = Path(folder) / file
    if not path.exists():
        raise SystemExit(f"mesh not found: {path} (pass --meshes FOLDER)")
    return trimesh.load(path, process=False)


def median_time(fn, repeat: int) -> tuple[float, object]:
    """Median wall time of `repeat` calls, and the last result."""
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), out
