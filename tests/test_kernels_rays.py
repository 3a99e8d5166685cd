"""kernels/rays.py: splitting and checking ray batches across parallel chunks."""

from __future__ import annotations

import numpy as np
import pytest

from durer.kernels.rays import CHUNK, first_problem, n_chunks, split_rays


def _split(rays: np.ndarray):
    n = len(rays)
    o, d = np.empty((n, 3)), np.empty((n, 3))
    first = np.empty((n_chunks(n), 3), np.int64)
    split_rays(rays[:, :3], rays[:, 3:], o, d, first)
    return o, d, first_problem(first)


def test_copies_both_halves_exactly():
    rays = np.random.default_rng(0).normal(size=(3 * CHUNK + 5, 6))
    o, d, problem = _split(rays)
    np.testing.assert_array_equal(o, rays[:, :3])
    np.testing.assert_array_equal(d, rays[:, 3:])
    assert o.flags.c_contiguous and d.flags.c_contiguous
    assert problem == (-1, -1, -1)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_reports_the_first_bad_ray_and_its_half_across_chunks(value):
    rays = np.ones((3 * CHUNK, 6))
    rays[2 * CHUNK + 7, 1] = value      # a later chunk, in the origin
    rays[CHUNK + 3, 4] = value          # an earlier chunk, in the direction
    rays[2 * CHUNK + 1, 3:] = 0.0       # zero directions: the first one is reported
    rays[CHUNK + 9, 3:] = 0.0
    assert _split(rays)[2] == (CHUNK + 3, 1, CHUNK + 9)


def test_empty_batch():
    assert _split(np.zeros((0, 6)))[2] == (-1, -1, -1)
