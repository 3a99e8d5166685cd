"""Open3D's own RaycastingScene tests (python/test/t/geometry/test_raycasting_scene.py, 0.19-0.20), their inputs
and expected values, run on durer with NumPy inputs (no open3d needed): the drop-in answers them as Open3D does."""

from __future__ import annotations

import numpy as np
import pytest

from durer import RaycastingScene

TRIANGLE = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]], np.float32), np.array([[0, 1, 2]], np.uint32))
# Open3D's TriangleMesh.create_box(): the unit cube [0, 1]^3, 12 triangles wound outwards
BOX_V = np.array([[0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 1], [0, 1, 0], [1, 1, 0], [0, 1, 1], [1, 1, 1]], np.float32)
BOX_F = np.array([[4, 7, 5], [4, 6, 7], [0, 2, 4], [2, 6, 4], [0, 1, 2], [1, 3, 2], [1, 5, 7], [1, 7, 3],
                  [2, 3, 7], [2, 7, 6], [0, 4, 1], [1, 4, 5]], np.uint32)
BOX_RAYS = np.array([[0.5, 0.5, -1, 0, 0, 1], [0.5, 0.5, 0.5, 0, 0, 1], [10, 10, 10, 1, 0, 0]], np.float32)


def _scene(v, f) -> RaycastingScene:
    scene = RaycastingScene()
    assert scene.add_triangles(v, f) == 0
    return scene


def test_cast_rays_and_occlusions():
    scene = _scene(*TRIANGLE)
    rays = np.array([[0.2, 0.1, 1, 0, 0, -1], [10, 10, 10, 1, 0, 0]], np.float32)
    ans = scene.cast_rays(rays)
    assert ans["geometry_ids"][0] == 0 and np.isclose(ans["t_hit"][0].item(), 1.0)
    assert ans["geometry_ids"][1] == RaycastingScene.INVALID_ID and np.isinf(ans["t_hit"][1].item())
    assert scene.test_occlusions(rays).tolist() == [True, False]
    assert not scene.test_occlusions(rays, tfar=0.5).any() and not scene.test_occlusions(rays, tnear=1.5).any()


def test_box_counts_lists_distances_and_occupancy():
    scene = _scene(BOX_V, BOX_F)
    np.testing.assert_equal(scene.count_intersections(BOX_RAYS).numpy(), [2, 1, 0])
    np.testing.assert_allclose(scene.list_intersections(BOX_RAYS)["t_hit"].numpy(), [1.0, 2.0, 0.5], rtol=1e-6,
                               atol=1e-6)
    points = np.array([[0.5, 0.5, 0.5], [-0.5, -0.5, -0.5], [0, 0, 0]], np.float32)
    np.testing.assert_allclose(scene.compute_distance(points).numpy(), [0.5, np.sqrt(3 * 0.5**2), 0.0])
    np.testing.assert_allclose(scene.compute_signed_distance(points).numpy(), [-0.5, np.sqrt(3 * 0.5**2), 0.0])
    for method in ("winding", "parity"):
        np.testing.assert_allclose(scene.compute_occupancy(points[:2], method=method).numpy(), [1.0, 0.0])


def test_closest_points():
    scene = _scene(*TRIANGLE)
    ans = scene.compute_closest_points(np.array([[0.2, 0.1, 1], [10, 10, 10]], np.float32))
    assert (ans["geometry_ids"] == 0).all() and (ans["primitive_ids"] == 0).all()
    np.testing.assert_allclose(ans["points"].numpy(), [[0.2, 0.1, 0.0], [1, 1, 0]], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("shape", ([11], [1, 2, 3], [32, 14]))
def test_output_shapes(shape):
    scene = _scene(*TRIANGLE)
    rs = np.random.RandomState(123)
    rays = rs.uniform(size=shape + [6]).astype(np.float32)
    points = rs.uniform(size=shape + [3]).astype(np.float32)
    for ans in (scene.count_intersections(rays), scene.compute_distance(points),
                scene.compute_signed_distance(points), scene.compute_occupancy(points)):
        assert list(ans.shape) == shape
    last = {"t_hit": [], "geometry_ids": [], "primitive_ids": [], "primitive_uvs": [2], "primitive_normals": [3],
            "points": [3]}
    for ans in (scene.cast_rays(rays), scene.compute_closest_points(points)):
        for key, value in ans.items():
            assert list(value.shape) == shape + last[key], key
    listed = scene.list_intersections(rays)
    hits = int(scene.count_intersections(rays).sum())
    assert listed["ray_splits"].shape == (int(np.prod(shape)) + 1,)
    assert listed["t_hit"].shape == listed["ray_ids"].shape == (hits,) and listed["primitive_uvs"].shape == (hits, 2)
