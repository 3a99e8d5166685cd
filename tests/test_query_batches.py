"""RaycastingScene reads the user's rays as given (accel/batches.py, kernels/bvh/queries.py): float32 or float64, any
strides, scalar or per-ray t ranges, many bands per call, and every scene shape (one instance, moved or not; the
world tree; a shared shape's two-level tree) give the answers of the same rays as contiguous float64 arrays."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import trimesh

from durer.kernels.bvh.bands import BAND
from durer.query import INVALID_ID, RaycastingScene

KEYS = ("t_hit", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals")


def _affine(rng) -> np.ndarray:
    m = np.eye(4)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    m[:3, :3] = q @ np.diag(rng.uniform(0.5, 2.0, 3))
    m[:3, 3] = rng.uniform(-1, 1, 3)
    return m


def _scenes() -> dict[str, RaycastingScene]:
    """One scene for each path of accel/batches.py."""
    rng = np.random.default_rng(5)
    ball = trimesh.creation.icosphere(subdivisions=3)
    box = trimesh.creation.box(extents=[1.0, 2.0, 0.5])
    scenes = {name: RaycastingScene() for name in ("alone", "moved", "world", "shared")}
    scenes["alone"].add_triangles(ball.vertices, ball.faces)
    scenes["moved"].add_triangles(ball.vertices, ball.faces, transform=_affine(rng))
    for name in ("world", "shared"):
        s = scenes[name]
        s.add_triangles(ball.vertices, ball.faces, transform=_affine(rng))
        s.add_triangles(box.vertices, box.faces, transform=_affine(rng) @ np.diag([1.0, -1.0, 1.0, 1.0]))
        s.add_sphere([0.5, 0.0, 0.0], 0.7, transform=_affine(rng))
    scenes["shared"].add_instance(1, _affine(rng))
    assert scenes["world"]._tree().world is not None and scenes["shared"]._tree().world is None
    return scenes


@pytest.fixture(scope="module")
def scenes():
    return _scenes()


def _random_rays(n: int, seed: int = 1) -> np.ndarray:
    """(n, 6) float32-exact rays from around the scenes towards their middle: about half hit something."""
    rng = np.random.default_rng(seed)
    o = rng.uniform(-4, 4, (n, 3))
    d = rng.uniform(-1.5, 1.5, (n, 3)) - o
    return np.concatenate([o, d], 1).astype(np.float32).astype(np.float64)


def _all_queries(s: RaycastingScene, *rays, **kw) -> dict:
    out = dict(s.cast_rays(*rays, **kw))
    out["occluded"] = s.test_occlusions(*rays, **kw)
    out["counts"] = s.count_intersections(*rays, **kw)
    listed = s.list_intersections(*rays, **kw)
    out.update({f"list_{k}": v for k, v in listed.items()})
    return out


# the outputs that follow the rays' float type: cast_rays' and list_intersections'
FLOAT_OUTPUTS = ("t_hit", "primitive_uvs", "primitive_normals", "list_t_hit", "list_primitive_uvs")


def _rounded(ref: dict) -> dict:
    """cast_rays' float outputs of float64 rays rounded to float32: what the same rays given in float32 get."""
    return {k: v.astype(np.float32) if k in FLOAT_OUTPUTS else v for k, v in ref.items()}


def _assert_same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for key in a:
        assert a[key].dtype == b[key].dtype, key
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


@pytest.mark.parametrize("name", ["alone", "moved", "world", "shared"])
def test_float32_strided_and_six_column_rays_give_the_float64_answers(scenes, name):
    """Several bands (BAND rays each) of float32 rays, strided views and (N, 6) rows answer exactly as contiguous
    float64 (N, 3) arrays of the same values, on every query and every scene path: cast_rays' t, uvs and normals
    in float32 for float32 rays (the float64 answers rounded once), every other output in its own type."""
    s = scenes[name]
    rays = _random_rays(2 * BAND + 123)
    ref = _all_queries(s, np.ascontiguousarray(rays[:, :3]), np.ascontiguousarray(rays[:, 3:]))
    assert 0.2 < np.isfinite(ref["t_hit"]).mean() < 0.9
    assert ref["t_hit"].dtype == np.float64 and ref["primitive_ids"].dtype == np.uint32
    assert ref["list_t_hit"].dtype == np.float64
    r32 = rays.astype(np.float32)
    got = _all_queries(s, r32)
    assert {got[k].dtype for k in FLOAT_OUTPUTS} == {np.dtype(np.float32)}
    assert (got["primitive_uvs"] != ref["primitive_uvs"]).any()  # the rounding is there to see
    _assert_same(got, _rounded(ref))
    _assert_same(_all_queries(s, r32[:, :3], r32[:, 3:]), _rounded(ref))
    _assert_same(_all_queries(s, r32[:, :3], rays[:, 3:]), ref)  # one float64 array: float64 outputs
    _assert_same(_all_queries(s, np.asfortranarray(rays[:, :3]), np.asfortranarray(rays[:, 3:])), ref)
    every_other = np.empty((2 * len(rays), 6), np.float32)
    every_other[::2] = r32
    _assert_same(_all_queries(s, every_other[::2]), _rounded(ref))  # rows 48 bytes apart


@pytest.mark.parametrize("name", ["alone", "world", "shared"])
def test_scalar_t_range_equals_the_same_range_per_ray(scenes, name):
    """A scalar t_min / t_max (read through a stride-0 view) answers as the same value given for every ray, and
    per-ray ranges still apply ray by ray."""
    s = scenes[name]
    rays = _random_rays(BAND + 77, seed=2)
    n = len(rays)
    for lo, hi in ((0.0, np.inf), (0.3, 0.9), (-np.inf, 0.6)):
        a = _all_queries(s, rays, t_min=lo, t_max=hi)
        b = _all_queries(s, rays, t_min=np.full(n, lo), t_max=np.full(n, hi))
        _assert_same(a, b)
        c = _all_queries(s, rays, t_min=np.full(n, lo), t_max=hi)  # one of each
        _assert_same(a, c)
    hi = np.random.default_rng(3).uniform(0.0, 1.0, n)
    per_ray = s.cast_rays(rays, t_max=hi)["t_hit"]
    full = s.cast_rays(rays)["t_hit"]
    np.testing.assert_array_equal(per_ray, np.where(full < hi, full, np.inf))


def test_image_rays_answer_as_the_same_rays_given_flat(scenes):
    """(H, W, 6) rays go in bands of 4 image rows (4 x 4 tiles); the same rays flat, and in random order, give
    the same t to the bit and the same hits."""
    s = scenes["world"]
    rays = RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [1.0, 2.0, 8.0], [0, 1, 0], 96, 64)
    img = s.cast_rays(rays.astype(np.float32))
    flat = s.cast_rays(rays.reshape(-1, 6).astype(np.float32))
    order = np.random.default_rng(4).permutation(96 * 64)
    shuffled = s.cast_rays(rays.reshape(-1, 6)[order].astype(np.float32))
    assert img["t_hit"].shape == (64, 96) and img["primitive_normals"].shape == (64, 96, 3)
    assert 0.1 < np.isfinite(img["t_hit"]).mean() < 0.95
    for key in KEYS:
        np.testing.assert_array_equal(img[key].reshape(flat[key].shape), flat[key], err_msg=key)
        np.testing.assert_array_equal(flat[key][order], shuffled[key], err_msg=key)


@pytest.mark.parametrize("name", ["alone", "shared"])
def test_bad_rays_in_any_band_are_misses(scenes, name):
    """A NaN, an infinity or a zero direction makes that ray a miss (Open3D's and Embree's answer), in any band,
    and leaves the other rays' answers as they were."""
    s = scenes[name]
    rays = _random_rays(3 * BAND).astype(np.float32)
    bad = rays.copy()
    bad[2 * BAND + 5, 1] = np.inf
    bad[BAND + 9, 3:] = 0.0
    bad[7, 4] = np.nan
    rows = [7, BAND + 9, 2 * BAND + 5]
    keep = np.setdiff1d(np.arange(len(rays)), rows)
    ref = s.cast_rays(rays)
    for args in ((bad,), (bad[:, :3], bad[:, 3:])):
        got = s.cast_rays(*args)
        assert np.isinf(got["t_hit"][rows]).all() and (got["geometry_ids"][rows] == INVALID_ID).all()
        np.testing.assert_array_equal(got["t_hit"][keep], ref["t_hit"][keep])
        assert not s.test_occlusions(*args)[rows].any() and not s.count_intersections(*args)[rows].any()
        assert np.isin(rows, s.list_intersections(*args)["ray_ids"], invert=True).all()
    empty = RaycastingScene()
    assert not empty.test_occlusions(bad).any() and (empty.cast_rays(bad)["geometry_ids"] == INVALID_ID).all()


def test_cast_rays_allocates_its_outputs_and_little_else(scenes):
    """No ray-sized copies of the input: the peak of NumPy's allocations during cast_rays on float32 rays is the
    outputs (32 bytes a ray: t, uvs and normals in float32, ids in int32) plus a little that does not grow with the batch (flat_image_width's probe of the
    first 16k rays, ~2 MB); the copies and per-ray t ranges this replaced were ~100 bytes a ray."""
    s = scenes["alone"]
    rays = _random_rays(64 * BAND).astype(np.float32)
    s.cast_rays(rays[:16])
    tracemalloc.start()
    try:
        s.cast_rays(rays)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    outputs = len(rays) * (4 + 4 + 4 + 8 + 12)
    assert outputs <= peak < outputs * 1.02 + 2_500_000


def test_lists_longer_than_the_work_items_buffers_come_whole_and_sorted_by_t():
    """list_intersections' one pass (queries.hit_lists_two_level) starts each work item with room for 4 hits a
    ray (at least 256): rays through 600 stacked squares overflow it, are walked again in grown buffers, and list
    every crossing in t order, the counts equal count_intersections', beside rays with one hit."""
    planes = 600
    z = np.arange(planes, dtype=np.float64)[::-1]  # added far to near, so the walk's order is not t order
    quad = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], np.float64)
    v = np.concatenate([np.column_stack([quad, np.full(4, zi)]) for zi in z])
    f = np.concatenate([np.array([[0, 1, 2], [0, 2, 3]]) + 4 * k for k in range(planes)])
    scene = RaycastingScene()
    scene.add_triangles(v, f)
    rays = np.array([[0.1, 0.2, -1.0, 0, 0, 1], [0.3, -0.4, -1.0, 0, 0, 1], [0.1, 0.2, planes - 1.5, 0, 0, 1],
                     [5.0, 5.0, -1.0, 0, 0, 1]])
    out = scene.list_intersections(rays)
    counts = np.diff(out["ray_splits"].astype(np.int64))
    assert counts.tolist() == [planes, planes, 1, 0]
    assert np.array_equal(counts, scene.count_intersections(rays))
    assert np.array_equal(out["ray_ids"], np.repeat(np.arange(4), counts))
    for i, start in enumerate((1.0, 1.0, 0.5)):
        t = out["t_hit"][out["ray_splits"][i]:out["ray_splits"][i + 1]]
        assert np.allclose(t, start + np.arange(counts[i]), rtol=0, atol=1e-12)
