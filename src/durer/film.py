"""The film: where on each pixel the camera rays go (sampling) and how samples become pixels (filtering).

Film points are in pixel units, x right and y up from the bottom-left corner (see cameras.py). Images are
(H, W, ...) with row 0 at the top, so pixel (row r, column c) covers x in [c, c+1], y in [H-1-r, H-r].
"""

from __future__ import annotations

import numpy as np

from .cameras import pixel_centers
from .options import RenderOptions


def sample_points(width: int, height: int, options: RenderOptions) -> tuple[np.ndarray, np.ndarray]:
    """Film points (N,2) of every sample and the flat pixel index (row-major, row 0 on top) each belongs to."""
    if options.samples != 1 or options.sampler != "uniform":
        raise NotImplementedError("supersampling")
    points = pixel_centers(width, height).reshape(-1, 2)
    return points, np.arange(width * height)


def reconstruct(points: np.ndarray, pixel: np.ndarray, values: np.ndarray, width: int, height: int,
                options: RenderOptions) -> np.ndarray:
    """Filter sample values (N,C) into pixels (H*W, C)."""
    if options.samples != 1 or options.sampler != "uniform":
        raise NotImplementedError("supersampling")
    out = np.zeros((width * height,) + values.shape[1:])
    out[pixel] = values
    return out
