"""kernels/points/order.py: the counting sort of query points by grid cell, and the point queries that use it
(accel/distance.cell_order) giving the same answers as in the caller's order."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from durer.accel.distance import SORT_MIN_POINTS, cell_order, restore_order
from durer.kernels.points.order import MAX_BITS, grid_bits, sort_by_cell
from durer.query import RaycastingScene


def morton(cells: np.ndarray, bits: int) -> np.ndarray:
    """Morton codes of integer cells (N, 3), bit by bit (independent of the kernel's bit tricks)."""
    code = np.zeros(len(cells), np.int64)
    for b in range(bits):
        for a in range(3):
            code |= ((cells[:, a] >> b) & 1) << (3 * b + a)
    return code


def sorted_by_cell(points: np.ndarray, bits: int) -> tuple[np.ndarray, np.ndarray]:
    out, order = np.empty_like(points), np.empty(len(points), np.int64)
    sort_by_cell(points, bits, out, order)
    return out, order


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 300), st.just(3)),
              elements=st.floats(-1e3, 1e3, allow_nan=False)), st.integers(1, 5))
def test_sort_by_cell_is_a_stable_permutation_in_morton_order(points, bits):
    out, order = sorted_by_cell(points, bits)
    assert np.array_equal(np.sort(order), np.arange(len(points)))
    np.testing.assert_array_equal(out, points[order])
    lo, hi = points.min(axis=0), points.max(axis=0)
    scale = np.divide(1 << bits, hi - lo, out=np.zeros(3), where=hi > lo)
    cells = np.clip(((points - lo) * scale).astype(np.int64), 0, (1 << bits) - 1)
    key = morton(cells, bits)[order]
    assert np.all(np.diff(key) >= 0)
    same = np.diff(key) == 0
    assert np.all(np.diff(order)[same] > 0)  # stable: equal cells keep the caller's order


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 300), st.just(3)),
              elements=st.floats(-1e3, 1e3, allow_nan=False)), st.integers(1, 5),
       arrays(np.float64, (2, 3), elements=st.floats(-1.2e3, 1.2e3, allow_nan=False)))
def test_sort_by_cell_in_a_box_places_the_points_inside_it_in_morton_order(points, bits, corners):
    """With a box, exactly the points inside it (faces included) are placed, in Morton order of a grid over
    their own box within it, stably; the count placed is returned."""
    box = corners.min(axis=0), corners.max(axis=0)
    out, order = np.empty_like(points), np.empty(len(points), np.int64)
    placed = sort_by_cell(points, bits, out, order, box)
    inside = np.flatnonzero(np.all((points >= box[0]) & (points <= box[1]), axis=1))
    assert placed == len(inside)
    out, order = out[:placed], order[:placed]
    assert np.array_equal(np.sort(order), inside)
    np.testing.assert_array_equal(out, points[order])
    if placed:
        lo = np.maximum(points.min(axis=0), box[0])
        hi = np.minimum(points.max(axis=0), box[1])
        scale = np.divide(1 << bits, hi - lo, out=np.zeros(3), where=hi > lo)
        cells = np.clip(((out - lo) * scale).astype(np.int64), 0, (1 << bits) - 1)
        key = morton(cells, bits)
        assert np.all(np.diff(key) >= 0)
        assert np.all(np.diff(order)[np.diff(key) == 0] > 0)


@pytest.mark.parametrize("n", [SORT_MIN_POINTS - 1, 3 * SORT_MIN_POINTS])
def test_cell_order_in_a_box_and_restore_order_fill_the_rest_with_zeros(n):
    pts = np.random.default_rng(n).uniform(-1.0, 1.0, (n, 3))
    box = np.full(3, -0.5), np.full(3, 0.5)
    kept, perm = cell_order(pts, box)
    inside = np.all(np.abs(pts) <= 0.5, axis=1)
    assert np.array_equal(np.sort(perm), np.flatnonzero(inside))
    np.testing.assert_array_equal(kept, pts[perm])
    back = restore_order(perm, np.ones(len(kept)), n=n)[0]
    np.testing.assert_array_equal(back, inside.astype(float))


def test_sort_by_cell_of_coincident_and_flat_points():
    same = np.ones((10, 3))
    out, order = sorted_by_cell(same, 3)
    assert np.array_equal(order, np.arange(10)) and np.array_equal(out, same)
    flat = np.stack([np.linspace(0, 1, 8), np.zeros(8), np.zeros(8)], axis=1)[::-1].copy()
    out, order = sorted_by_cell(flat, 3)
    assert np.array_equal(order, np.arange(8)[::-1])  # x descending in, ascending out; y and z one cell


def test_grid_bits_grows_with_the_batch_and_stays_bounded():
    assert grid_bits(1) == 1
    assert grid_bits(4 * 8**4) == 4
    assert grid_bits(4 * 8**5) == 5
    assert grid_bits(10**12) == MAX_BITS


def test_small_batches_keep_the_callers_order():
    pts = np.random.default_rng(0).uniform(size=(SORT_MIN_POINTS - 1, 3))
    same, perm = cell_order(pts)
    assert same is pts and perm is None
    assert restore_order(None, pts)[0] is pts


def test_point_queries_answer_the_same_in_any_order():
    """A batch large enough to be sorted gives, point for point, the answers of the same points queried in
    small batches (never sorted), shuffled or not."""
    mesh = trimesh.creation.torus(1.0, 0.4)
    scene = RaycastingScene()
    scene.add_triangles(mesh.vertices, mesh.faces)
    pts = np.random.default_rng(1).uniform(-1.6, 1.6, (3 * SORT_MIN_POINTS, 3))
    small = np.array_split(pts, 8)
    assert all(len(s) < SORT_MIN_POINTS for s in small)
    for query in (scene.compute_distance, scene.compute_occupancy, scene.compute_winding_number,
                  lambda p: scene.compute_occupancy(p, method="parity")):
        whole = query(pts)
        np.testing.assert_array_equal(whole, np.concatenate([query(s) for s in small]))
        shuffle = np.random.default_rng(2).permutation(len(pts))
        np.testing.assert_array_equal(query(pts[shuffle]), whole[shuffle])
    closest = scene.compute_closest_points(pts)
    parts = [scene.compute_closest_points(s) for s in small]
    for key, value in closest.items():
        np.testing.assert_array_equal(value, np.concatenate([p[key] for p in parts]), err_msg=key)


@pytest.mark.parametrize("n", [SORT_MIN_POINTS, 50_000])
def test_restore_order_inverts_the_sort(n):
    pts = np.random.default_rng(n).normal(size=(n, 3))
    sorted_pts, perm = cell_order(pts)
    assert perm is not None
    back, = restore_order(perm, sorted_pts)
    np.testing.assert_array_equal(back, pts)
