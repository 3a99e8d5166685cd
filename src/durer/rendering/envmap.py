"""An environment map as a light: radiance lookups by direction (Mitsuba's latitude-longitude convention, see
scene.lights.EnvironmentMap) and importance sampling proportional to the map's luminance times sin(theta), so bright
skies and small suns are found by light sampling rather than by chance."""

from __future__ import annotations

import numpy as np

from ..scene.lights import EnvironmentMap

LUMINANCE = np.array([0.212671, 0.715160, 0.072169])  # linear sRGB / Rec. 709 luminance weights


class EnvMapLight:
    """Lookups and sampling of one EnvironmentMap. The image is extended by one column (the first, repeated) so that
    u wraps; texel (i, j) sits at u = (i + 1/2) / W, v = j / (H - 1), bilinearly interpolated (measured against
    Mitsuba 3.5's envmap: its lookups agree to 1e-3 with this half-texel offset in u and none in v).
    Sampling picks a cell of that grid by a 2-D table (luminance of its corners' mean times sin(theta) at its
    centre), then a point uniformly in it; pdf() is that density per solid angle."""

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

    def _xy(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Continuous texel coordinates (x in [0, W), y in [0, H - 1]) of directions d."""
        v = d @ self.to_local.T
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        u = np.arctan2(v[:, 0], -v[:, 2]) / (2 * np.pi)
        x = np.mod(u * self.w - 0.5, self.w)
        return x, np.arccos(np.clip(v[:, 1], -1.0, 1.0)) / np.pi * (self.h - 1)

    def eval(self, d: np.ndarray) -> np.ndarray:
        """Radiance (N,3) arriving from directions d (N,3) (pointing away from the scene)."""
        x, y = self._xy(d)
        i = np.minimum(x.astype(np.int64), self.w - 1)
        j = np.minimum(y.astype(np.int64), self.h - 2)
        fx, fy = (x - i)[:, None], (y - j)[:, None]
        g = self.grid
        top = (1 - fx) * g[j, i] + fx * g[j, i + 1]
        bottom = (1 - fx) * g[j + 1, i] + fx * g[j + 1, i + 1]
        return (1 - fy) * top + fy * bottom

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Directions (N,3) drawn with density pdf(d), and that pdf per solid angle."""
        j = np.clip(np.searchsorted(self.row_cdf, u[:, 0], side="right") - 1, 0, self.h - 2)
        u0 = (u[:, 0] - self.row_cdf[j]) / np.maximum(self.row_cdf[j + 1] - self.row_cdf[j], 1e-300)
        cdf = self.col_cdf[j]
        i = np.clip((cdf <= u[:, 1:2]).sum(axis=1) - 1, 0, self.w - 1)
        c0, c1 = cdf[np.arange(len(j)), i], cdf[np.arange(len(j)), i + 1]
        u1 = (u[:, 1] - c0) / np.maximum(c1 - c0, 1e-300)
        x, y = i + np.clip(u1, 0, 1), j + np.clip(u0, 0, 1)
        theta, phi = y / (self.h - 1) * np.pi, (x + 0.5) / self.w * 2 * np.pi
        s = np.sin(theta)
        local = np.column_stack([s * np.sin(phi), np.cos(theta), -s * np.cos(phi)])
        d = local @ self.to_world.T
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d, self.pdf(d)

    def pdf(self, d: np.ndarray) -> np.ndarray:
        """Density per solid angle with which sample() picks direction d (N,3)."""
        x, y = self._xy(d)
        i = np.minimum(x.astype(np.int64), self.w - 1)
        j = np.minimum(y.astype(np.int64), self.h - 2)
        s = np.sin(y / (self.h - 1) * np.pi)
        p_uv = self.cell_pdf[j, i] * self.w * (self.h - 1)
        return np.where(s > 0, p_uv / (2 * np.pi * np.pi * np.maximum(s, 1e-300)), 0.0)
