"""The path tracer's random stream and warps: determinism, independence of keys, uniformity, and each warp's
density against its stated pdf."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.path import warps as W
from durer.rendering import sampling as S


def test_stream_is_a_pure_function_of_its_key():
    k = S.key(7, np.arange(1000), np.full(1000, 3))
    a, b = S.uniform(k, 5), S.uniform(k[::-1].copy(), 5)[::-1]
    np.testing.assert_array_equal(a, b)  # order does not matter
    assert not np.array_equal(a, S.uniform(k, 6))
    assert not np.array_equal(a, S.uniform(S.key(8, np.arange(1000), np.full(1000, 3)), 5))
    assert 0 <= a.min() and a.max() < 1


def test_uniform_is_uniform_and_dimensions_are_uncorrelated():
    k = S.key(0, np.arange(200000), np.zeros(200000))
    u, v = S.uniform(k, 0), S.uniform(k, 1)
    counts = np.bincount((u * 20).astype(int), minlength=20)
    assert abs(counts - 10000).max() < 5 * math.sqrt(10000)
    assert abs(np.corrcoef(u, v)[0, 1]) < 0.01


@settings(deadline=None)  # the first example may compile the kernel (cold Numba cache)
@given(st.integers(0, 2**32 - 1), st.integers(0, 30), st.sampled_from([4, 16, 64]))
def test_sobol_pairs_stratify_every_pixel(pixel_key, dim, n):
    p = S.sobol_pair(np.full(n, pixel_key, np.uint64), np.arange(n), dim)
    assert 0 <= p.min() and p.max() < 1
    s = math.isqrt(n) if math.isqrt(n) ** 2 == n else None
    if s:  # one point in each cell of the s x s grid
        cells = np.floor(p[:, 0] * s).astype(int) * s + np.floor(p[:, 1] * s).astype(int)
        assert len(np.unique(cells)) == n
    # and in each 1-D stratum of width 1/n, in both dimensions
    assert len(np.unique(np.floor(p[:, 0] * n))) == n and len(np.unique(np.floor(p[:, 1] * n))) == n


def _uniform_2d(n, seed=0):
    return np.random.default_rng(seed).random((n, 2))


def _warp(fn, u, *extra) -> np.ndarray:
    """A scalar warp of kernels/path/warps.py applied to each row of u (N,2)."""
    return np.array([fn(a, b, *extra) for a, b in u])


def test_cosine_hemisphere_density():
    d = _warp(W.cosine_hemisphere3, _uniform_2d(200000))
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-12)
    assert d[:, 2].min() >= 0
    # E[cos] under pdf cos/pi is 2/3; P(cos > 0.5) = 1 - 0.25
    assert d[:, 2].mean() == pytest.approx(2 / 3, abs=3e-3)
    assert (d[:, 2] > 0.5).mean() == pytest.approx(0.75, abs=3e-3)


def test_uniform_sphere_and_cone():
    d = _warp(W.uniform_sphere3, _uniform_2d(200000))
    assert abs(d.mean(axis=0)).max() < 0.01 and (d[:, 2] > 0.5).mean() == pytest.approx(0.25, abs=3e-3)
    c = _warp(W.uniform_cone3, _uniform_2d(200000, 1), 0.8)
    assert c[:, 2].min() >= 0.8 - 1e-12
    # uniform in solid angle: cos theta uniform on [cos_max, 1]
    assert c[:, 2].mean() == pytest.approx(0.9, abs=2e-3)
    assert W.uniform_cone_pdf(0.8) == pytest.approx(1 / (2 * np.pi * 0.2))


def test_frames_are_orthonormal_and_invert():
    n = S.normalize(np.random.default_rng(2).normal(size=(1000, 3)))
    n[0] = [0, 0, -1]
    v = np.random.default_rng(3).normal(size=(1000, 3))
    for k in range(len(n)):
        s, t = W.frame3(*n[k])
        np.testing.assert_allclose(np.cross(s, t), n[k], atol=1e-12)  # right-handed and orthonormal
        assert abs(np.dot(s, n[k])) < 1e-12
        local = W.to_local3(*v[k], s, t, *n[k])
        np.testing.assert_allclose(W.to_world3(*local, s, t, *n[k]), v[k], atol=1e-12)
