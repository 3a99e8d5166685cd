"""The environment map's guided cdf search (kernels/path/envmap._guided over guide_of's tables) finds the index the
plain bisection (_last_at_most) finds, for any cdf and any u: cells of zero width (ties), buckets with no cdf value
in them, and u on a bucket's end or on a cdf value itself."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.path.envmap import GUIDE, _guided, _last_at_most, guide_of


def _cdf(weights: list[float]) -> np.ndarray:
    c = np.concatenate([[0.0], np.cumsum(weights)])
    return c / c[-1]


weights = st.lists(st.sampled_from([0.0, 0.0, 1e-12, 0.3, 1.0, 7.0, 400.0]), min_size=1, max_size=300).filter(
    lambda w: sum(w) > 0)


@settings(max_examples=60, deadline=None)
@given(weights, st.lists(st.floats(0.0, 1.0, exclude_max=True), min_size=1, max_size=20))
def test_guided_search_finds_the_bisections_index(w, us):
    cdf = _cdf(w)
    n = len(cdf) - 1
    guide = guide_of(cdf, n)
    assert guide.shape == (GUIDE + 1,) and guide[0] >= 0 and guide[-1] <= n - 1
    ends = np.arange(GUIDE) / GUIDE
    for u in [*us, *ends, *cdf[:-1], *np.nextafter(cdf[1:-1], 0.0)]:
        if 0.0 <= u < 1.0:
            assert _guided(cdf, guide, n, u) == _last_at_most(cdf, n, u), u


def test_guide_rows_of_a_2d_cdf_are_each_rows_guide():
    rng = np.random.default_rng(3)
    rows = np.stack([_cdf(list(rng.random(40) * (rng.random(40) < 0.3))) for _ in range(5)])
    g = guide_of(rows, 40)
    assert g.shape == (5, GUIDE + 1)
    for k in range(5):
        np.testing.assert_array_equal(g[k], guide_of(rows[k], 40))
        assert g[k, 0] == _last_at_most(rows[k], 40, 0.0) and g[k, GUIDE] == 39
