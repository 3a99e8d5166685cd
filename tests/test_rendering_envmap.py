"""The environment map's Numba lookups, sampling and pdf (kernels/path/envmap.py, through rendering/envmap.py)
against the NumPy implementation they replaced (kept here as the reference: O(width) column search per sample),
and the sampler's histogram against its pdf (chi-square)."""

from __future__ import annotations

import numpy as np
import pytest

from durer.kernels.path.envmap import envmap_sample_kernel
from durer.rendering.envmap import EnvMapLight
from durer.scene.lights import EnvironmentMap
from durer.scene.transforms import rotate

N = 200000


def _sky(h: int = 16, w: int = 32) -> np.ndarray:
    v = (np.arange(h)[:, None] + 0.5) / h
    u = (np.arange(w)[None, :] + 0.5) / w
    img = np.zeros((h, w, 3))
    img[..., 0], img[..., 1], img[..., 2] = 0.3 + 0.5 * u, 0.4 * (1 - v), 0.8 * (1 - v) + 0.1
    img[3:5, 20:22] = [40.0, 35.0, 30.0]  # a small sun
    return img


class Reference:
    """rendering/envmap.EnvMapLight's NumPy lookups before they moved to Numba (over the same tables)."""

    def __init__(self, light: EnvMapLight):
        self.light = light

    def xy(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lt = self.light
        v = d @ lt.to_local.T
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        u = np.arctan2(v[:, 0], -v[:, 2]) / (2 * np.pi)
        x = np.mod(u * lt.w - 0.5, lt.w)
        return x, np.arccos(np.clip(v[:, 1], -1.0, 1.0)) / np.pi * (lt.h - 1)

    def eval(self, d: np.ndarray) -> np.ndarray:
        lt = self.light
        x, y = self.xy(d)
        i = np.minimum(x.astype(np.int64), lt.w - 1)
        j = np.minimum(y.astype(np.int64), lt.h - 2)
        fx, fy = (x - i)[:, None], (y - j)[:, None]
        g = lt.grid
        top = (1 - fx) * g[j, i] + fx * g[j, i + 1]
        bottom = (1 - fx) * g[j + 1, i] + fx * g[j + 1, i + 1]
        return (1 - fy) * top + fy * bottom

    def sample(self, u: np.ndarray) -> np.ndarray:
        lt = self.light
        j = np.clip(np.searchsorted(lt.row_cdf, u[:, 0], side="right") - 1, 0, lt.h - 2)
        u0 = (u[:, 0] - lt.row_cdf[j]) / np.maximum(lt.row_cdf[j + 1] - lt.row_cdf[j], 1e-300)
        cdf = lt.col_cdf[j]
        i = np.clip((cdf <= u[:, 1:2]).sum(axis=1) - 1, 0, lt.w - 1)
        c0, c1 = cdf[np.arange(len(j)), i], cdf[np.arange(len(j)), i + 1]
        u1 = (u[:, 1] - c0) / np.maximum(c1 - c0, 1e-300)
        x, y = i + np.clip(u1, 0, 1), j + np.clip(u0, 0, 1)
        theta, phi = y / (lt.h - 1) * np.pi, (x + 0.5) / lt.w * 2 * np.pi
        s = np.sin(theta)
        d = np.column_stack([s * np.sin(phi), np.cos(theta), -s * np.cos(phi)]) @ lt.to_world.T
        return d / np.linalg.norm(d, axis=1, keepdims=True)

    def pdf(self, d: np.ndarray) -> np.ndarray:
        lt = self.light
        x, y = self.xy(d)
        i = np.minimum(x.astype(np.int64), lt.w - 1)
        j = np.minimum(y.astype(np.int64), lt.h - 2)
        s = np.sin(y / (lt.h - 1) * np.pi)
        p_uv = lt.cell_pdf[j, i] * lt.w * (lt.h - 1)
        return np.where(s > 0, p_uv / (2 * np.pi * np.pi * np.maximum(s, 1e-300)), 0.0)


def _light(h: int = 16, w: int = 32) -> EnvMapLight:
    return EnvMapLight(EnvironmentMap(_sky(h, w), 2.0, rotate((0, 1, 0), 30) @ rotate((1, 0, 0), 20)))


@pytest.mark.parametrize("h,w", [(16, 32), (65, 200)])
def test_lookups_sampling_and_pdf_agree_with_the_numpy_reference(h, w):
    """Random directions (and near the poles, the seam and axis directions): the same radiance and pdf as the NumPy
    code to float rounding; the same numbers u give the same sampled directions (the bisections find the cells
    the O(width) count found) with the pdf of those directions and their radiance / pdf as weight."""
    light = _light(h, w)
    ref = Reference(light)
    rng = np.random.default_rng(7)
    d = rng.normal(size=(N, 3))
    # beside the poles (at a pole the longitude is rounding noise, and so is the top row's lookup), the seam
    near = np.array([[1e-3, 1.0, 2e-3], [-1e-3, -1.0, 1e-3], [0.0, 0.3, -1.0], [0.0, 0.0, -1.0]])
    d = np.concatenate([d, np.eye(3), -np.eye(3), near @ light.to_world.T])
    np.testing.assert_allclose(light.eval(d), ref.eval(d), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(light.pdf(d), ref.pdf(d), rtol=1e-9, atol=1e-12)
    u = np.concatenate([rng.random((N, 2)), [[0.0, 0.0], [1 - 2**-53, 1 - 2**-53], [0.5, 0.0]]])
    s, weight, pdf = np.empty((N + 3, 3)), np.empty((N + 3, 3)), np.empty(N + 3)
    envmap_sample_kernel(light.tables, u, s, weight, pdf)
    np.testing.assert_allclose(s, ref.sample(u), rtol=0, atol=1e-12)
    np.testing.assert_allclose(light.sample(u)[0], s, rtol=0, atol=0)
    # the sampler's pdf and radiance are taken at the sampled texel coordinates, the reference's from the direction
    # mapped back: the same up to that round trip (acos near the poles), but for samples on a cell's edge (the
    # last two u), which the round trip may put in the neighbour cell
    np.testing.assert_allclose(pdf[:N], ref.pdf(s[:N]), rtol=1e-6)
    np.testing.assert_allclose(weight[:N] * pdf[:N, None], ref.eval(s[:N]), rtol=1e-6)
    assert (pdf[:N] > 0).all() and np.isfinite(pdf).all()  # u = (0, 0) is the pole: pdf 0, the sample unused
    np.testing.assert_allclose(np.linalg.norm(s, axis=1), 1.0, rtol=1e-14)


def test_pdf_integrates_to_one_over_the_sphere():
    """The midpoint rule on 6 x 6 points per cell of the 200 x 64 grid (pdf * sin(theta) is constant per cell)."""
    light = _light(65, 200)
    th = (np.arange(64 * 6) + 0.5) / (64 * 6) * np.pi
    ph = ((np.arange(200 * 6) + 0.5) / 6 + 0.5) / 200 * 2 * np.pi
    tt, pp = np.meshgrid(th, ph, indexing="ij")
    local = np.column_stack([(np.sin(tt) * np.sin(pp)).ravel(), np.cos(tt).ravel(),
                             -(np.sin(tt) * np.cos(pp)).ravel()])
    total = (light.pdf(local @ light.to_world.T) * np.sin(tt).ravel()).sum() * (th[1] - th[0]) * (ph[1] - ph[0])
    assert total == pytest.approx(1.0, rel=1e-9)


def test_sampled_directions_follow_the_pdf():
    """Histogram of 200,000 sampled directions over 2 x 2 bins per cell of the texel grid (1,920 bins) against
    N times the pdf integrated over each bin (midpoint rule): the chi-square statistic is that of a correct
    sampler (p > 0.001), and a sampler off by a cell's sin(theta) weighting would fail it by far."""
    stats = pytest.importorskip("scipy.stats")
    light = _light()
    ref = Reference(light)
    s, _ = light.sample(np.random.default_rng(11).random((N, 2)))
    x, y = ref.xy(s)
    bx, by = 2 * light.w, 2 * (light.h - 1)
    observed = np.histogram2d(y, x, bins=(by, bx), range=((0, light.h - 1), (0, light.w)))[0]
    # bin (r, c) covers texel x in [c / 2, (c + 1) / 2), y in [r / 2, (r + 1) / 2): 4 x 4 midpoints each
    k = 4
    yy = (np.arange(by * k) + 0.5) / (by * k) * (light.h - 1)
    xx = (np.arange(bx * k) + 0.5) / (bx * k) * light.w
    theta, phi = np.meshgrid(yy / (light.h - 1) * np.pi, (xx + 0.5) / light.w * 2 * np.pi, indexing="ij")
    local = np.column_stack([(np.sin(theta) * np.sin(phi)).ravel(), np.cos(theta).ravel(),
                             -(np.sin(theta) * np.cos(phi)).ravel()])
    dens = light.pdf(local @ light.to_world.T).reshape(theta.shape) * np.sin(theta)
    d_omega = (np.pi / (by * k)) * (2 * np.pi / (bx * k))
    expected = N * dens.reshape(by, k, bx, k).sum(axis=(1, 3)) * d_omega
    assert expected.sum() == pytest.approx(N, rel=1e-9)
    chi2 = ((observed - expected) ** 2 / expected).sum()
    dof = expected.size - 1
    assert stats.chi2.sf(chi2, dof) > 1e-3, (chi2, dof)
    # the same histogram against a pdf without the sin(theta) of each cell is rejected
    flat = expected / np.sin(theta).reshape(by, k, bx, k).mean(axis=(1, 3))
    flat *= N / flat.sum()
    assert stats.chi2.sf(((observed - flat) ** 2 / flat).sum(), dof) < 1e-12
