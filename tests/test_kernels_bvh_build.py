"""The SAH build (kernels/bvh/build.py) and its triangle inputs (kernels/bvh/items.py): tree invariants on random
boxes (every item in exactly one leaf, every box containing what it holds, the depth it reports), the threaded
build giving the serial tree, a mesh built through its indices giving the tree of its triangles, and that tree's
closest hits against brute force."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from durer.accel.brute import BruteForce
from durer.accel.bvh import Shape, TwoLevelBVH
from durer.accel.compile import compile_scene
from durer.kernels.bvh import build
from durer.kernels.bvh.layout import MAX_LEAF, leaf_slots
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh


def _boxes(rng: np.random.Generator, n: int, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """n random boxes: scattered, many sharing one centroid (the build's halving split), or flat in z."""
    c = rng.uniform(-5, 5, (n, 3))
    if kind == "coincident":
        c[: n // 2] = 1.0
    elif kind == "flat":
        c[:, 2] = 0.0
    half = rng.uniform(0.0, 0.5, (n, 3))
    if kind == "flat":
        half[:, 2] = 0.0
    return c - half, c + half


def _check_tree(lo, hi, bounds, child, order, depth):
    """Every item in exactly one leaf; each lane's (float32) box contains its leaf's items or its child's lanes;
    depth is the tree's depth; leaves hold at most 7 items (the leaf code's limit)."""
    n = len(lo)
    assert sorted(order.tolist()) == list(range(n))
    first, count = leaf_slots(np.where(child < 0, child, -1).astype(np.int64))
    leaf = child < 0
    seen = np.zeros(n, np.int64)
    for s, c in zip(first[leaf], count[leaf], strict=True):
        seen[s:s + c] += 1
    np.testing.assert_array_equal(seen, np.ones(n, np.int64))  # every item in exactly one leaf
    assert count[leaf].max(initial=0) <= 7
    b = bounds.astype(np.float64)
    for node, lane in zip(*np.nonzero(child != 0), strict=True):
        box_lo, box_hi = b[node, :3, lane], b[node, 3:, lane]
        code = child[node, lane]
        if code < 0:
            items = order[first[node, lane]:first[node, lane] + count[node, lane]]
            assert np.all(box_lo <= lo[items]) and np.all(hi[items] <= box_hi)
        else:
            sub = b[code][:, child[code] != 0]
            assert np.all(box_lo[:, None] <= sub[:3]) and np.all(sub[3:] <= box_hi[:, None])
    levels, frontier = 0, [0]
    while frontier:
        levels += 1
        frontier = [int(c) for node in frontier for c in child[node] if c > 0]
    assert depth == levels


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 600), kind=st.sampled_from(["scattered", "coincident", "flat"]),
       max_leaf=st.sampled_from([1, MAX_LEAF]))
def test_every_item_in_one_leaf_and_boxes_contain_their_contents(seed, n, kind, max_leaf):
    lo, hi = _boxes(np.random.default_rng(seed), n, kind)
    bounds, child, order, depth = build.build_wide_bvh(lo, hi, max_leaf)
    if n:
        _check_tree(lo, hi, bounds, child, order, depth)
    else:
        assert np.all(np.isinf(bounds)) and not child.any()


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
@pytest.mark.parametrize("kind", ["scattered", "coincident", "flat"])
def test_threaded_build_gives_the_serial_tree(monkeypatch, kind):
    """Subtrees built on other threads and stitched in: the same arrays as the one-thread build."""
    lo, hi = _boxes(np.random.default_rng(7), 5000, kind)
    serial = build.build_wide_bvh(lo, hi)
    monkeypatch.setattr(build, "PARALLEL_BUILD", 1000)
    threaded = build.build_wide_bvh(lo, hi)
    for a, b in zip(serial, threaded, strict=True):
        np.testing.assert_array_equal(a, b)
    _check_tree(lo, hi, *threaded)


def _mesh(rng: np.random.Generator, n_vert: int, n_tri: int, float32: bool) -> tuple[np.ndarray, np.ndarray]:
    v = rng.uniform(-2, 2, (n_vert, 3))
    if float32:
        v = v.astype(np.float32).astype(np.float64)
    return v, rng.integers(0, n_vert, (n_tri, 3))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(0, 400), float32=st.booleans(), narrow=st.booleans())
def test_a_mesh_built_through_its_indices_is_the_mesh_of_its_triangles(seed, n_tri, float32, narrow):
    """Shape.indexed(v, f) (no (F, 3, 3) copy) gives Shape.mesh(v[f])'s tree, leaves (float32 exactly when
    every vertex is one and the tree is large), normals and bounds, to the bit."""
    import durer.accel.bvh as bvh

    v, f = _mesh(np.random.default_rng(seed), max(3, n_tri // 2), n_tri, float32)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(bvh, "NARROW_LEAVES_FROM", 1 if narrow else 10**9)
        a, b = Shape.mesh(v[f]), Shape.indexed(v, f)
    for name in ("bounds", "child", "leaf_prim", "leaf_tri"):
        x, y = getattr(a.tree, name), getattr(b.tree, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    assert a.tree.depth == b.tree.depth
    assert b.tree.leaf_tri.dtype == (np.float32 if narrow and float32 and n_tri else np.float64)
    for name in ("normals", "lo", "hi"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 300))
def test_closest_hits_through_the_indexed_tree_equal_brute_force(seed, n_tri):
    rng = np.random.default_rng(seed)
    v, f = _mesh(rng, n_tri, n_tri, True)
    tree = TwoLevelBVH([Shape.indexed(v, f)], [(0, np.eye(4))])
    brute = BruteForce(compile_scene(Scene(camera=None, group=Group([TriangleMesh(v, f)]))))
    o = rng.uniform(-4, 4, (400, 3))
    d = rng.uniform(-2, 2, (400, 3)) - o
    t, _, kind, prim, _, _ = tree.closest_hit(o, d, np.full(400, 1e-6), np.full(400, np.inf))
    ref = brute.closest_hit(o, d, t_min=1e-6)
    np.testing.assert_array_equal(kind, ref.kind)
    np.testing.assert_array_equal(t, ref.t)  # the same watertight test: t to the bit
    assert np.all((prim == ref.prim) | (t == ref.t))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(0, 300), float32=st.booleans())
def test_indexed_items_give_the_item_rows_of_the_triangles_boxes(seed, n_tri, float32):
    """The item rows a mesh's one pass makes (items.indexed_items) are build.item_rows of its triangles' boxes:
    each row's box and centroid, the root's box and centroid bounds, to the bit."""
    from durer.kernels.bvh.items import indexed_items, item_boxes

    v, f = _mesh(np.random.default_rng(seed), max(3, n_tri // 2), n_tri, float32)
    _, lo, hi, ib, root_box, root_cb = indexed_items(v, f)
    box_lo, box_hi = item_boxes(v[f].reshape(-1, 9), np.zeros((0, 3)), np.zeros((0, 3)))
    want = build.item_rows(box_lo, box_hi)
    for got, ref in zip((ib, root_box, root_cb), want, strict=True):
        np.testing.assert_array_equal(got, ref)
    np.testing.assert_array_equal(root_box, np.concatenate([lo, hi]))
    if n_tri:
        np.testing.assert_array_equal(ib[:, 6:], 0.5 * (ib[:, :3] + ib[:, 3:6]))


def _best_root_split(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The binned SAH's split of the root written out in NumPy over every bin and plane (the kernel sweeps the
    non-empty bins only): which items go left (bin <= the cheapest plane; axes in order, the strict < keeping
    the first of equal costs)."""
    n = len(lo)
    c = 0.5 * (lo + hi)
    c0, c1 = c.min(axis=0), c.max(axis=0)
    nbins = min(build.N_BINS if n >= 16 else 8, max(4, 2 * n))

    def area(box_lo, box_hi):
        ex, ey, ez = (float(box_hi[a] - box_lo[a]) for a in range(3))
        return 0.0 if ex < 0.0 else ex * ey + ey * ez + ez * ex

    best, best_left = np.inf, None
    for a in range(3):
        ext = c1[a] - c0[a]
        if not ext > 0.0:
            continue
        bins = np.minimum((c[:, a] - c0[a]) * (nbins * (1.0 - 1e-9) / ext), nbins - 1).astype(np.int64)
        for b in range(nbins - 1):
            left = bins <= b
            nl = int(left.sum())
            if nl == 0 or nl == n:
                continue
            cost = (area(lo[left].min(axis=0), hi[left].max(axis=0)) * nl
                    + area(lo[~left].min(axis=0), hi[~left].max(axis=0)) * (n - nl))
            if cost < best:
                best, best_left = cost, left
    return best_left


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(MAX_LEAF + 1, 300), kind=st.sampled_from(["scattered", "flat"]))
def test_the_root_splits_at_the_cheapest_binned_plane(seed, n, kind):
    """The root's children hold the items of the cheapest plane over all bins (brute force above), though the
    kernel sweeps only the non-empty bins and (under 16 items) uses 8."""
    lo, hi = _boxes(np.random.default_rng(seed), n, kind)
    box, left, right, start, count, order = build.build_bvh2(lo, hi)
    want = _best_root_split(lo, hi)
    assert want is not None and left[0] >= 0  # more items than a leaf holds: split
    got = np.zeros(n, bool)
    got[order[start[left[0]]:start[left[0]] + count[left[0]]]] = True
    np.testing.assert_array_equal(got, want)


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two Numba threads")
@pytest.mark.parametrize("float32", [True, False])
def test_items_and_leaves_in_pieces_equal_one_pass(monkeypatch, float32):
    """indexed_items and indexed_leaves on every thread (large meshes) give the one-pass arrays to the bit."""
    from durer.kernels.bvh import items

    v, f = _mesh(np.random.default_rng(3), 3000, 5000, float32)
    one = items.indexed_items(v, f)
    order = build.build_wide_bvh_rows(one[3].copy(), *one[4:])[2]  # (it reorders the rows it is given)
    leaves = items.indexed_leaves(v, f, order, True)
    monkeypatch.setattr(items, "PARALLEL_ITEMS", 100)
    for a, b in zip(one, items.indexed_items(v, f), strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(leaves, items.indexed_leaves(v, f, order, True), strict=True):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert leaves[1].dtype == (np.float32 if float32 else np.float64)


_EDGES = np.array([0.0, np.float32(1e-45), 1.1754942e-38, 1.1754944e-38, 1.1754945e-38, 1.0, 2.0, 0.75, 1.0000001,
                   1.9999999, 2.0**127, 3.4028235e38, np.inf], np.float32)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(width=32, allow_nan=False) | st.sampled_from([float(e) for e in np.concatenate([_EDGES, -_EDGES])]))
def test_collapse_rounds_boxes_outwards_as_nextafter(x):
    """The collapse's float32 step below a value (a product or quotient where it is normal) is np.nextafter's, to
    the bit and sign, at every binade edge (the whole float32 range was checked once: 0 mismatches)."""
    y = np.float32(x)
    for got, want in ((build._step_down(y), np.nextafter(y, np.float32(-np.inf))),
                      (-build._step_down(-y), np.nextafter(y, np.float32(np.inf)))):
        assert np.float32(got).tobytes() == want.tobytes(), (y, got, want)
