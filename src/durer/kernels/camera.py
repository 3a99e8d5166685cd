"""The pinhole and orthographic cameras' rays in one pass (Numba), for their generate_rays: per ray, the camera's
closed form in NumPy's order of operations (no fused multiply-add: Numba's default contracts none), without the
temporary (N, 3) arrays and the norm's reduction an array expression makes."""

from __future__ import annotations

import math

import numba as nb

from .common import JIT


@nb.njit(**JIT)
def perspective_rays(points, width, height, center, direction, horizontal, up, extent, origins, directions):
    """origins[i] = center, directions[i] = the unit direction through film point points[i] (pixels, y up) of a
    width x height image, for a camera whose screen is `extent` wide per unit along its longer side:
    d = (direction + (sx extent) horizontal) + (sy extent) up, over its length (sum of squares in NumPy's order)."""
    side = float(max(width, height))
    hw, hh = 0.5 * width, 0.5 * height
    for i in range(points.shape[0]):
        a = ((points[i, 0] - hw) / side) * extent
        b = ((points[i, 1] - hh) / side) * extent
        d0 = direction[0] + a * horizontal[0] + b * up[0]
        d1 = direction[1] + a * horizontal[1] + b * up[1]
        d2 = direction[2] + a * horizontal[2] + b * up[2]
        n = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        directions[i, 0] = d0 / n
        directions[i, 1] = d1 / n
        directions[i, 2] = d2 / n
        origins[i, 0] = center[0]
        origins[i, 1] = center[1]
        origins[i, 2] = center[2]


@nb.njit(**JIT)
def orthographic_rays(points, width, height, center, direction, horizontal, up, size, origins, directions):
    """OrthographicCamera.generate_rays per ray, in NumPy's order (the same bits): origins[i] = center + (sx size)
    horizontal + (sy size) up for film point points[i]'s offsets (sx, sy) from the image centre in units of the
    longer side, directions[i] = direction."""
    side = float(max(width, height))
    hw, hh = 0.5 * width, 0.5 * height
    for i in range(points.shape[0]):
        a = ((points[i, 0] - hw) / side) * size
        b = ((points[i, 1] - hh) / side) * size
        for k in range(3):
            origins[i, k] = center[k] + a * horizontal[k] + b * up[k]
            directions[i, k] = direction[k]
