"""render(): a scene and an image size in, colour, depth and normal arrays out."""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from .cameras import pixel_centers
from .compile import compile_scene
from .hits import BruteForce
from .integrators import RenderContext, RenderOptions, SampleResult, raycast
from .io.images import depth_visualization, normal_visualization, save_image
from .scene import Scene

CHUNK = 1 << 15  # rays per batch: big enough to keep the kernels busy, small enough for a live progress bar


@dataclass
class RenderResult:
    """The arrays of one render, each (H, W, ...), row 0 at the top.

    color: float32 (H,W,3) linear radiance; depth: float32 (H,W) ray parameter t of the closest hit (inf on a miss);
    normals: float32 (H,W,3) unit world-space normals of the closest hit (0 on a miss).
    """

    color: np.ndarray
    depth: np.ndarray
    normals: np.ndarray
    seconds: float = 0.0

    def save(self, path: str | os.PathLike, *, course: bool = False) -> None:
        """Write the colour image (8-bit formats sRGB-encoded, or truncated like the course with course=True)."""
        save_image(os.fspath(path), self.color, course=course)

    def save_depth(self, path: str | os.PathLike, near: float | None = None, far: float | None = None) -> None:
        """Write depth: raw t for .npy/.pfm, else grey with near = white and far = black (default: the hit range)."""
        path = os.fspath(path)
        if path.lower().endswith((".npy", ".pfm")):
            save_image(path, self.depth)
            return
        finite = self.depth[np.isfinite(self.depth)]
        if near is None:
            near = float(finite.min()) if finite.size else 0.0
        if far is None:
            far = float(finite.max()) if finite.size else 1.0
        if far == near:
            far = near + 1.0
        save_image(path, depth_visualization(self.depth, near, far), course=True)

    def save_normals(self, path: str | os.PathLike) -> None:
        """Write normals: raw for .npy/.pfm, else |n| per channel."""
        path = os.fspath(path)
        if path.lower().endswith((".npy", ".pfm")):
            save_image(path, self.normals)
            return
        save_image(path, normal_visualization(self.normals), course=True)


def make_context(scene: Scene, options: RenderOptions | None = None, accelerator: str = "auto") -> RenderContext:
    """Compile the scene and build its accelerator."""
    cs = compile_scene(scene)
    return RenderContext(scene=scene, compiled=cs, accel=BruteForce(cs), options=options or RenderOptions())


def _progress(total: int, quiet: bool):
    """A progress bar on stderr that appears only after a second, and never when quiet or not on a terminal."""
    disable = quiet or not sys.stderr.isatty()
    return tqdm(total=total, unit="ray", unit_scale=True, delay=1.0, disable=disable, leave=False,
                desc="rendering", file=sys.stderr)


def render(scene: Scene, width: int, height: int, *, shade_back: bool = False, quiet: bool = True,
           integrator=None, options: RenderOptions | None = None) -> RenderResult:
    """Cast one ray through each pixel centre and shade it; returns colour, depth and normal arrays."""
    if int(width) != width or int(height) != height or width < 1 or height < 1:
        raise ValueError(f"image size must be positive integers, got {width} x {height}")
    width, height = int(width), int(height)
    start = time.perf_counter()
    if options is None:
        options = RenderOptions(shade_back=shade_back)
    ctx = make_context(scene, options)
    integrate = integrator or raycast
    points = pixel_centers(width, height).reshape(-1, 2)
    origins, directions, valid = scene.camera.generate_rays(points, width, height)
    n = len(points)
    color = np.zeros((n, 3))
    depth = np.full(n, np.inf)
    normals = np.zeros((n, 3))
    idx = np.flatnonzero(valid)
    with _progress(len(idx), quiet) as bar:
        for lo in range(0, len(idx), CHUNK):
            sel = idx[lo:lo + CHUNK]
            r: SampleResult = integrate(ctx, origins[sel], directions[sel], scene.camera.t_min)
            color[sel], depth[sel], normals[sel] = r.color, r.t, r.normal
            bar.update(len(sel))
    return RenderResult(
        color=color.reshape(height, width, 3).astype(np.float32),
        depth=depth.reshape(height, width).astype(np.float32),
        normals=normals.reshape(height, width, 3).astype(np.float32),
        seconds=time.perf_counter() - start,
    )
