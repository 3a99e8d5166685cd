"""The one-ray walks of kernels/bvh/single.py: the closest-hit walk against brute force on grazing rays, float32 and
float64 leaves, deep stacks; and the simd loads it is built from (kernels/bvh/simd.py)."""

from __future__ import annotations

import numba as nb
import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from durer.accel.brute import BruteForce
from durer.accel.bvh import build_tree
from durer.accel.compile import compile_scene
from durer.kernels.bvh.simd import row4
from durer.kernels.bvh.single import blas_any, blas_closest
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh

_E3, _E1, _E34 = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3, 4))


@nb.njit
def _row(child, r):
    return row4(child, np.uint64(r))


@nb.njit
def _walk(bounds, child, leaf_prim, leaf_tri, o, d, stack_size, out, hit):
    """blas_closest and blas_any over the rays one by one, as trace.closest_hit_bvh calls them."""
    stack_node = np.empty(stack_size, np.int32)
    stack_t = np.empty(stack_size)
    for i in range(o.shape[0]):
        t, kind, prim, u, v = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, _E3, _E1, _E34, o[i, 0], o[i, 1],
                                           o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf, stack_node, stack_t)
        out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4] = t, kind, prim, u, v
        hit[i] = blas_any(bounds, child, 0, leaf_prim, leaf_tri, _E3, _E1, _E34, o[i, 0], o[i, 1], o[i, 2], d[i, 0],
                          d[i, 1], d[i, 2], 0.0, np.inf, stack_node)


def _check_against_brute_force(tri: np.ndarray, o: np.ndarray, d: np.ndarray) -> None:
    """The walk on float64 leaves and on the same leaves as float32 (exact: the vertices are rounded to float32 values first) gives
    brute force's closest hit to the bit (the same watertight test), and any_hit its hit flags."""
    tri = tri.astype(np.float32).astype(np.float64)
    tree = build_tree(tri, np.zeros((0, 3)), np.zeros((0, 3)))
    cs = compile_scene(Scene(camera=None, group=Group([TriangleMesh(tri.reshape(-1, 3),
                                                                    np.arange(3 * len(tri)).reshape(-1, 3))])))
    ref = BruteForce(cs).closest_hit(o, d, t_min=0.0)
    for leaves in (tree.leaf_tri.astype(np.float64), tree.leaf_tri.astype(np.float32)):
        out, hit = np.empty((len(o), 5)), np.empty(len(o), np.bool_)
        _walk(tree.bounds.reshape(-1), tree.child, tree.leaf_prim, leaves.reshape(-1), o, d, tree.stack_size, out,
              hit)
        np.testing.assert_array_equal(out[:, 1], ref.kind)
        np.testing.assert_array_equal(out[:, 0], ref.t)
        same = out[:, 2] == ref.prim
        assert np.all(same | (out[:, 0] == ref.t))  # another triangle only on an exact tie in t
        np.testing.assert_array_equal(out[same, 3], ref.u[same])
        np.testing.assert_array_equal(out[same, 4], ref.v[same])
        np.testing.assert_array_equal(hit, ref.hit)


@settings(max_examples=30, deadline=None)
@given(rows=st.integers(1, 50), data=st.data())
def test_child_codes_are_the_row(rows, data):
    """simd.row4 (one 16-byte load) reads row r of an (N, 4) int32 array, whatever r."""
    child = np.array(data.draw(st.lists(st.integers(-2**31, 2**31 - 1), min_size=4 * rows, max_size=4 * rows)),
                     np.int32).reshape(rows, 4)
    r = data.draw(st.integers(0, rows - 1))
    assert _row(child, r) == tuple(int(c) for c in child[r])


def test_child_codes_refuse_a_strided_array():
    """row4's flat offset holds for C-contiguous rows only: any other layout does not compile."""
    with pytest.raises(nb.core.errors.TypingError):
        _row(np.zeros((3, 8), np.int32)[:, ::2], 1)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 300))
@example(seed=64684, n_tri=300)  # ray 328 in triangle 81's plane, edge functions all rounding leftovers of one sign
def test_closest_walk_equals_brute_force_on_grazing_rays(seed, n_tri):
    """Vertices on a quarter grid, so that many boxes share planes, and rays that graze them: origins on the grid,
    directions along an axis (a zero component: the 1e-300 reciprocal) or towards a vertex (through edges and
    corners of triangles and boxes), in random order (no coherent chunks)."""
    rng = np.random.default_rng(seed)
    tri = np.round(rng.uniform(0, 4, (n_tri, 3, 3)) * 4) / 4
    n = 400
    o = np.round(rng.uniform(-1, 5, (n, 3)) * 4) / 4
    d = tri.reshape(-1, 3)[rng.integers(0, 3 * n_tri, n)] - o  # aimed at a vertex
    axis = rng.random(n) < 0.5  # or along an axis, in a plane of the grid
    d[axis] = 0.0
    d[axis, rng.integers(0, 3, int(axis.sum()))] = rng.choice([-1.0, 1.0], int(axis.sum()))
    d[np.all(d == 0.0, axis=1)] = (0.0, 0.0, 1.0)
    _check_against_brute_force(tri, o, d)


def test_closest_walk_through_a_deep_stack():
    """2,000 triangles in a row, crossed along the row from both ends and obliquely: the walk defers many
    subtrees at once (the ordered stack near its size) and must still find the nearest."""
    rng = np.random.default_rng(4)
    x = np.sort(rng.uniform(0, 100, 2000))
    tri = np.stack([np.stack([x, np.zeros_like(x) - 1, np.zeros_like(x) - 1], 1),
                    np.stack([x, np.ones_like(x), np.zeros_like(x) - 1], 1),
                    np.stack([x, np.zeros_like(x), np.ones_like(x)], 1)], 1)
    n = 300
    o = np.column_stack([rng.choice([-10.0, 110.0], n), rng.uniform(-0.5, 0.5, (n, 2))])
    d = np.column_stack([np.where(o[:, 0] < 0, 1.0, -1.0), rng.normal(scale=0.003, size=(n, 2))])
    _check_against_brute_force(tri, o, d)


@nb.njit
def _any_with_and_without_spheres(bounds, child, leaf_prim, leaf_tri, o, d, t_max, stack_size, out):
    """blas_any per ray twice: sphere arrays empty and holding one sphere that no leaf names (the slots are still
    told apart by leaf_prim's sign, whatever the sphere arrays hold)."""
    stack_node = np.empty(stack_size, np.int32)
    center, radius, w2o = np.zeros((1, 3)), np.ones(1), np.zeros((1, 3, 4))
    for i in range(o.shape[0]):
        out[i, 0] = blas_any(bounds, child, 0, leaf_prim, leaf_tri, _E3, _E1, _E34, o[i, 0], o[i, 1], o[i, 2],
                             d[i, 0], d[i, 1], d[i, 2], 0.0, t_max[i], stack_node)
        out[i, 1] = blas_any(bounds, child, 0, leaf_prim, leaf_tri, center, radius, w2o, o[i, 0], o[i, 1], o[i, 2],
                             d[i, 0], d[i, 1], d[i, 2], 0.0, t_max[i], stack_node)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 200))
@example(seed=5025, n_tri=156)  # an edge-on triangle's false hit at t = 0.571 (edge_tie)
def test_any_walk_on_shadow_ray_limits(seed, n_tri):
    """blas_any answers as brute force, with or without sphere arrays beside a triangle tree, on grid vertices with
    rays aimed at vertices and t_max just before (nothing is closer than the closest hit) and after the closest hit."""
    rng = np.random.default_rng(seed)
    tri = np.round(rng.uniform(0, 4, (n_tri, 3, 3)) * 4) / 4
    n = 300
    o = np.round(rng.uniform(-1, 5, (n, 3)) * 4) / 4
    d = tri.reshape(-1, 3)[rng.integers(0, 3 * n_tri, n)] - o
    d[np.all(d == 0.0, axis=1)] = (0.0, 0.0, 1.0)
    tree = build_tree(tri, np.zeros((0, 3)), np.zeros((0, 3)))
    cs = compile_scene(Scene(camera=None, group=Group([TriangleMesh(tri.reshape(-1, 3),
                                                                    np.arange(3 * n_tri).reshape(-1, 3))])))
    ref = BruteForce(cs).closest_hit(o, d, t_min=0.0)
    for scale, expect in ((np.inf, ref.hit), (0.999, np.zeros(n, np.bool_)), (1.001, ref.hit)):
        t_max = np.where(ref.hit, ref.t * scale, np.inf) if scale != np.inf else np.full(n, np.inf)
        out = np.empty((n, 2), np.bool_)
        _any_with_and_without_spheres(tree.bounds.reshape(-1), tree.child, tree.leaf_prim, tree.leaf_tri.reshape(-1),
                                      o, d, t_max, tree.stack_size, out)
        np.testing.assert_array_equal(out[:, 0], out[:, 1])
        np.testing.assert_array_equal(out[:, 0], expect)  # nothing is closer than the closest hit
