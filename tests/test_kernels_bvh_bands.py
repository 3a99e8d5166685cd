"""kernels/bvh/bands.py: reading the user's rays band by band, checking them as they are copied."""

from __future__ import annotations

import numpy as np
import pytest

from durer.kernels.bvh.bands import BAND, band_scratch, check_bands, first_problem, load_band, n_bands

_EYE = np.ascontiguousarray(np.eye(4)[:3])


def _check(rays: np.ndarray, band: int = BAND):
    n = len(rays)
    first = np.empty((n_bands(n, band), 3), np.int64)
    lo, hi = np.broadcast_to(0.0, (n,)), np.broadcast_to(np.inf, (n,))
    check_bands(rays[:, :3], rays[:, 3:], lo, hi, _EYE, band, first, 0, len(first))
    return first_problem(first)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_copies_a_band_exactly_as_float64(dtype):
    rays = np.random.default_rng(0).normal(size=(3 * BAND + 5, 6)).astype(dtype)
    t_min = np.random.default_rng(1).uniform(0, 1, len(rays))
    o, d, lo, hi = band_scratch(BAND)
    first = np.empty((4, 3), np.int64)
    r0, m, clean = load_band(rays[:, :3], rays[:, 3:], t_min, np.broadcast_to(np.inf, (len(rays),)), _EYE, False,
                             3, BAND, o, d, lo, hi, first)
    assert (r0, m, clean) == (3 * BAND, 5, True) and first[3].tolist() == [-1, -1, -1]
    np.testing.assert_array_equal(o[:5], rays[3 * BAND:, :3].astype(np.float64))
    np.testing.assert_array_equal(d[:5], rays[3 * BAND:, 3:].astype(np.float64))
    np.testing.assert_array_equal(lo[:5], t_min[3 * BAND:])
    assert (hi[:5] == np.inf).all() and o.dtype == np.float64 and o.flags.c_contiguous


def test_moves_rays_into_object_space():
    rays = np.random.default_rng(2).normal(size=(7, 6))
    w2o = np.ascontiguousarray(np.random.default_rng(3).normal(size=(3, 4)))
    o, d, lo, hi = band_scratch(16)
    first = np.empty((1, 3), np.int64)
    inf = np.broadcast_to(np.inf, (7,))
    assert load_band(rays[:, :3], rays[:, 3:], inf, inf, w2o, True, 0, 16, o, d, lo, hi, first) == (0, 7, True)
    np.testing.assert_allclose(o[:7], rays[:, :3] @ w2o[:, :3].T + w2o[:, 3], rtol=1e-12)
    np.testing.assert_allclose(d[:7], rays[:, 3:] @ w2o[:, :3].T, rtol=1e-12)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_reports_the_first_bad_ray_and_its_half_across_bands(value):
    rays = np.ones((3 * BAND, 6))
    rays[2 * BAND + 7, 1] = value      # a later band, in the origin
    rays[BAND + 3, 4] = value          # an earlier band, in the direction
    rays[2 * BAND + 1, 3:] = 0.0       # zero directions: the first one is reported
    rays[BAND + 9, 3:] = 0.0
    assert _check(rays) == (BAND + 3, 1, BAND + 9)
    assert _check(rays.astype(np.float32), band=64) == (BAND + 3, 1, BAND + 9)


def test_empty_batch():
    assert _check(np.zeros((0, 6))) == (-1, -1, -1)
