"""rendering/filters.py: Mitsuba's gaussian read from its table (filters.gauss) against the closed form it tabulates."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.options import RenderOptions
from durer.rendering import filters


def _exact(x: np.ndarray, sigma: float) -> np.ndarray:
    """Mitsuba 3's gaussian: exp(-x^2 / 2 sigma^2) less its value at 4 sigma, zero beyond."""
    a = -1.0 / (2.0 * sigma * sigma)
    return np.maximum(0.0, np.exp(a * x * x) - math.exp(a * 16.0 * sigma * sigma))


@settings(max_examples=60, deadline=None)
@given(st.floats(0.1, 3.0), st.floats(-20.0, 20.0))
def test_the_gaussian_table_is_the_closed_form_within_its_interpolation_error(sigma, x):
    o = RenderOptions(filter="mitsuba_gaussian", filter_radius=sigma)
    got = filters.filter_weight(o, x, 0.0)
    exact = _exact(np.array([x]), sigma)[0] * _exact(np.array([0.0]), sigma)[0]
    assert abs(got - exact) <= 2.0 / filters.GAUSS_STEPS ** 2  # linear interpolation of exp(-8 u^2): h^2 / 8 * 16
    if abs(x) >= 4 * sigma:
        assert got == 0.0


def test_the_gaussian_table_meets_the_closed_form_at_its_nodes_and_is_monotone():
    sigma = 0.5
    nodes = np.arange(filters.GAUSS_STEPS + 1) / filters.GAUSS_STEPS * 4 * sigma
    o = RenderOptions(filter="mitsuba_gaussian", filter_radius=sigma)
    at = filters.filter_weight(o, nodes, 0.0) / _exact(np.array([0.0]), sigma)[0]
    np.testing.assert_allclose(at, _exact(nodes, sigma), rtol=0, atol=1e-15)
    fine = filters.filter_weight(o, np.linspace(0.0, 2.5, 20001), 0.0)
    assert (np.diff(fine) <= 0).all() and fine[-1] == 0.0
