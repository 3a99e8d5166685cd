"""An environment map as a light: radiance lookups by direction (Mitsuba's latitude-longitude convention, see
scene.lights.EnvironmentMap) and importance sampling proportional to the map's luminance times sin(theta), so bright
skies and small suns are found by light sampling rather than by chance. The tables are built here once per render;
lookups, sampling (O(log n): two binary searches, each started from a guide table) and pdfs are the Numba functions
of kernels/path/envmap.py, which the path tracer's bounce calls per path and the methods below call on arrays."""

from __future__ import annotations

import numpy as np

from ..kernels.path.envmap import GUIDE, envmap_eval_kernel, envmap_pdf_kernel, envmap_sample_kernel, guide_of
from ..scene.lights import EnvironmentMap

LUMINANCE = np.array([0.212671, 0.715160, 0.072169])  # linear sRGB / Rec. 709 luminance weights


class EnvMapLight:
    """Lookups and sampling of one EnvironmentMap. The image is extended by one column (the first, repeated) so that
    u wraps; texel (i, j) sits at u = (i + 1/2) / W, v = j / (H - 1), bilinearly interpolated (measured against
    Mitsuba 3.5's envmap: its lookups agree to 1e-3 with this half-texel offset in u and none in v).
    Sampling picks a cell of that grid by a 2-D table (luminance of its corners' mean times sin(theta) at its
    centre), then a point uniformly in it; pdf() is that density per solid angle. `tables`: the kernels' arrays."""

    def __init__(self, env: EnvironmentMap):
        img = env.image * env.scale
        self.grid = np.concatenate([img, img[:, :1]], axis=1)  # (H, W + 1, 3)
        self.h, self.w = img.shape[0], img.shape[1]
        m = env.to_world[:3, :3]
        self.to_world, self.to_local = m, np.linalg.inv(m)
        cells = 0.25 * (self.grid[:-1, :-1] + self.grid[1:, :-1] + self.grid[:-1, 1:] + self.grid[1:, 1:])
        theta = (np.arange(self.h - 1) + 0.5) / (self.h - 1) * np.pi
        weight = (cells @ LUMINANCE) * np.sin(theta)[:, None] + 1e-12  # (H - 1, W); never exactly 0
        self.cell_pdf = weight / weight.sum()
        self.row_cdf = np.concatenate([[0.0], np.cumsum(self.cell_pdf.sum(axis=1))])
        rows = np.cumsum(self.cell_pdf, axis=1)
        self.col_cdf = np.concatenate([np.zeros((self.h - 1, 1)), rows / rows[:, -1:]], axis=1)
        self.row_cdf /= self.row_cdf[-1]
        self.tables = tuple(np.ascontiguousarray(a, dtype=np.float64) for a in (
            self.grid, self.cell_pdf, self.row_cdf, self.col_cdf, self.to_local, self.to_world)) + (
            guide_of(self.row_cdf, self.h - 1), guide_of(self.col_cdf, self.w))

    def eval(self, d: np.ndarray) -> np.ndarray:
        """Radiance (N,3) arriving from directions d (N,3) (pointing away from the scene)."""
        out = np.empty((len(d), 3))
        envmap_eval_kernel(self.tables, np.ascontiguousarray(d, dtype=np.float64), out)
        return out

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Directions (N,3) drawn with density pdf(d) from numbers u (N,2) in [0, 1), and that pdf per solid
        angle."""
        n = len(u)
        d, weight, pdf = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        envmap_sample_kernel(self.tables, np.ascontiguousarray(u, dtype=np.float64), d, weight, pdf)
        return d, pdf

    def pdf(self, d: np.ndarray) -> np.ndarray:
        """Density per solid angle with which sample() picks direction d (N,3)."""
        out = np.empty(len(d))
        envmap_pdf_kernel(self.tables, np.ascontiguousarray(d, dtype=np.float64), out)
        return out


def no_envmap() -> tuple[np.ndarray, ...]:
    """The tables of kernels/path/envmap.py for a scene without a map: the same array types, empty (one
    compilation of the kernels serves both)."""
    return (np.zeros((0, 1, 3)), np.zeros((0, 0)), np.zeros(0), np.zeros((0, 1)), np.eye(3), np.eye(3),
            np.zeros(GUIDE + 1, np.int32), np.zeros((0, GUIDE + 1), np.int32))
