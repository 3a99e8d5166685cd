"""kernels/bvh/queued.py: the count-only queued walk finds exactly the hits of the storing stack walk."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from durer import RaycastingScene
from durer.kernels.bvh.layout import MAX_LEAF
from durer.kernels.bvh.queued import QUEUE_FIFO, blas_count, ring_for
from durer.kernels.bvh.single import blas_all
from durer.kernels.intersect import intersect_triangle


@nb.njit(cache=False)
def _counts_and_peak(o, d, bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack_size):
    """blas_count and blas_all's count (nothing stored) of each ray, and the ring's length."""
    ring = ring_for(stack_size)
    stack = np.empty(4 * stack_size, np.int32)
    e, ei, ek = np.empty(0), np.empty(0, np.int32), np.empty(0, np.int8)
    out = np.empty((o.shape[0], 2), np.int64)
    for i in range(o.shape[0]):
        out[i, 0] = blas_count(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                               o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, ring)
        out[i, 1] = blas_all(bounds, child, root, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                             o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack, e, ei, ek, e,
                             e, 0)
    return out, ring.shape[0]


def _tree(scene: RaycastingScene):
    p = scene._tree().packed
    return (*p.blas[:2], int(p.top.inst_root[0]), *p.blas[2:], p.stack)


def test_a_ray_through_a_stack_of_squares_counts_each_once_when_the_queue_overflows_its_fifo_part():
    """300 unit squares stacked along z and a ray up through them: every box of the tree holds the ray, so the
    queue's front outgrows QUEUE_FIFO and the walk goes depth first; each square is crossed once (300), as the
    stack walk and the brute-force watertight test count."""
    n = 300
    z = np.repeat(np.arange(n, dtype=np.float64), 4)
    v = np.column_stack([np.tile([0.0, 1.0, 1.0, 0.0], n), np.tile([0.0, 0.0, 1.0, 1.0], n), z])
    q = 4 * np.arange(n)[:, None]
    f = np.vstack([q + [0, 1, 2], q + [0, 2, 3]])
    s = RaycastingScene()
    s.add_triangles(v, f)
    o, d = np.array([[0.3, 0.4, -1.0]]), np.array([[0.001, 0.001, 1.0]])
    out, ring_size = _counts_and_peak(o, d, *_tree(s))
    assert QUEUE_FIFO < ring_size < 2 * n // MAX_LEAF  # smaller than the front of leaves a FIFO alone would hold
    tris = v[f]
    brute = sum(intersect_triangle(*o[0], *d[0], tri, 0.0, np.inf)[0] < np.inf for tri in tris)
    assert brute == n
    assert out.tolist() == [[n, n]]
    assert int(np.asarray(s.count_intersections(o, d))[0]) == n


@pytest.mark.slow
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.booleans())
def test_queued_counts_equal_the_stack_walks_and_brute_force_on_random_soups(seed, with_sphere):
    """A random triangle soup (beside a sphere) and random rays from all around it, many grazing its triangles'
    edges (rays aimed at vertices): blas_count equals blas_all's count ray by ray, and on the soup alone the
    brute-force count of the watertight test; count_intersections equals list_intersections' hits a ray."""
    rng = np.random.default_rng(seed)
    n = 200
    v = rng.uniform(-2, 2, (n, 3, 3))
    v[:, 1:] = v[:, :1] + rng.normal(scale=0.6, size=(n, 2, 3))
    s = RaycastingScene()
    s.add_triangles(v.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3))
    if with_sphere:
        s.add_sphere(rng.uniform(-1, 1, 3), float(rng.uniform(0.3, 1.0)))
    m = 400
    o = rng.uniform(-4, 4, (m, 3))
    target = np.where(rng.random((m, 1)) < 0.3, v.reshape(-1, 3)[rng.integers(0, 3 * n, m)],
                      rng.uniform(-2, 2, (m, 3)))
    d = target - o
    if with_sphere:  # the sphere is its own instance: the soup's tree alone here, the scene below
        counts = np.asarray(s.count_intersections(o, d))
        lists = s.list_intersections(o, d)
        np.testing.assert_array_equal(counts, np.diff(np.asarray(lists["ray_splits"]).astype(np.int64)))
        return
    out, _ = _counts_and_peak(o, d, *_tree(s))
    np.testing.assert_array_equal(out[:, 0], out[:, 1])
    brute = np.array([sum(intersect_triangle(*o[i], *d[i], tri, 0.0, np.inf)[0] < np.inf for tri in v)
                      for i in range(m)])
    np.testing.assert_array_equal(out[:, 0], brute)
    np.testing.assert_array_equal(np.asarray(s.count_intersections(o, d)), brute)
    assert brute.sum() > 0
