"""Open3D's pinhole camera rays (Numba): one pass over the image writing float32 rays (pinhole.py's engine)."""

from __future__ import annotations

import numba as nb
import numpy as np

from .common import JIT


@nb.njit(**JIT)
def pinhole_rays(m, origin, out):
    """out[y, x] = (origin, m (x + 0.5, y + 0.5, 1)) for an image out (h, w, 6) float32; m (3, 3) = R^T K^-1 and
    origin (3,) float64. Each direction is summed in Eigen's order, (m0 x + m1 y) + m2, in float64 and rounded
    once, so the rays equal Open3D's."""
    h, w = out.shape[0], out.shape[1]
    for y in range(h):
        py = y + 0.5
        ry0, ry1, ry2 = m[0, 1] * py, m[1, 1] * py, m[2, 1] * py
        for x in range(w):
            px = x + 0.5
            out[y, x, 0] = origin[0]
            out[y, x, 1] = origin[1]
            out[y, x, 2] = origin[2]
            out[y, x, 3] = np.float32((m[0, 0] * px + ry0) + m[0, 2])
            out[y, x, 4] = np.float32((m[1, 0] * px + ry1) + m[1, 2])
            out[y, x, 5] = np.float32((m[2, 0] * px + ry2) + m[2, 2])
