"""Position and UV of camera rays' first hits: Mitsuba's `aov` integrator's `position` and `uv` outputs.

They are computed for each pixel's centre sample only (the sample units.py keeps for depth and normals), after the
integrator has traced it, whatever the integrator: the position is the ray's origin plus the integrator's own t
along its direction (so it agrees with the depth), and the UV comes from the closest hit found again by the
accelerator (one more ray per pixel and pass, none per sample): mesh UVs interpolated at the point (0 on a mesh
without UVs), analytic shapes' Mitsuba parametrisation (CompiledScene.analytic_uv), 0 on planes. A miss gives 0
for both, as Mitsuba's aov does. The colour and every other output stay as they are: nothing here draws a random
number or changes a ray the integrator traces.
"""

from __future__ import annotations

import numpy as np

from ..accel.compile import SPHERE, TRIANGLE
from .context import RenderContext

WIDTH = 5  # position (3) then uv (2)


def hit_points(ctx: RenderContext, origins: np.ndarray, directions: np.ndarray, t_min: float,
               t: np.ndarray) -> np.ndarray:
    """(N, WIDTH): world position o + t d and surface UV of each ray's first hit (t from the integrator, inf on a
    miss); zeros where the ray escapes."""
    out = np.zeros((len(t), WIDTH))
    hit = np.isfinite(t)
    if not hit.any():
        return out
    o = np.ascontiguousarray(origins[hit], dtype=np.float64)
    d = np.ascontiguousarray(directions[hit], dtype=np.float64)
    out[hit, :3] = o + t[hit, None] * d
    hits = ctx.accel.closest_hit(o, d, t_min=t_min)
    points = o + np.where(hits.hit, hits.t, 0.0)[:, None] * d
    uv = np.zeros((len(o), 2))
    tri, analytic = hits.kind == TRIANGLE, hits.kind == SPHERE
    cs = ctx.compiled
    if tri.any():
        uv[tri] = cs.uv_at(hits.prim[tri], points[tri])
    if analytic.any():
        uv[analytic] = cs.analytic_uv(hits.prim[analytic], points[analytic])
    out[hit, 3:] = uv
    return out
