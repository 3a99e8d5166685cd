"""RaycastingScene against Open3D's own (open3d.t.geometry.RaycastingScene) on the same inputs, where installed:
calling forms, dtypes, ids, pinhole rays, and the answers on random batches."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from durer import RaycastingScene

o3d = pytest.importorskip("open3d")
O3D = o3d.t.geometry.RaycastingScene


def _box_scenes():
    box = o3d.geometry.TriangleMesh.create_box()
    mesh = o3d.t.geometry.TriangleMesh.from_legacy(box)
    ours, theirs = RaycastingScene(nthreads=0, device=o3d.core.Device("CPU:0")), O3D()
    assert ours.add_triangles(mesh) == theirs.add_triangles(mesh) == 0
    return ours, theirs


def _dict(result) -> dict:
    return {k: (v.numpy() if hasattr(v, "numpy") else v) for k, v in result.items()}


def test_open3d_calling_forms_and_types():
    ours, theirs = _box_scenes()
    rays = np.array([[0.5, 0.5, -1, 0, 0, 1], [0.5, 0.5, 0.5, 0, 0, 1], [10, 10, 10, 1, 0, 0],
                     [0, 0, 0, 0, 0, 0], [np.nan, 0, 0, 0, 0, 1], [0.5, 0.5, -1, 0, 0, np.inf]], np.float32)
    tensor = o3d.core.Tensor(rays)
    for a, b in ((ours.cast_rays(rays=tensor), theirs.cast_rays(rays)),
                 (ours.cast_rays(rays, 0), theirs.cast_rays(rays, 0))):
        a, b = _dict(a), _dict(b)
        assert a.keys() == b.keys()
        for key in a:
            assert a[key].dtype == b[key].dtype and a[key].shape == b[key].shape, key
        np.testing.assert_array_equal(a["geometry_ids"], b["geometry_ids"])
        np.testing.assert_allclose(a["t_hit"], b["t_hit"], rtol=1e-6)
        np.testing.assert_allclose(a["primitive_normals"], b["primitive_normals"], atol=1e-6)
    assert RaycastingScene.INVALID_ID == O3D.INVALID_ID == 2**32 - 1
    for args in ((rays, 0.0, 1.5), (rays, 0.0, 0.7), (rays,)):
        got, want = ours.test_occlusions(*args).numpy(), theirs.test_occlusions(*args).numpy()
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    counts = ours.count_intersections(tensor, nthreads=-1)
    assert counts.numpy().dtype == theirs.count_intersections(tensor).numpy().dtype == np.int32
    listed = _dict(ours.list_intersections(rays))
    for key, value in _dict(theirs.list_intersections(rays)).items():
        assert listed[key].dtype == value.dtype, key
    vertices, faces = np.asarray(o3d.geometry.TriangleMesh.create_box().vertices), np.asarray(
        o3d.geometry.TriangleMesh.create_box().triangles)
    assert RaycastingScene().add_triangles(vertex_positions=vertices, triangle_indices=faces) == 0
    points = np.array([[0.5, 0.5, 0.4], [2, 2, 2]], np.float32)
    for name in ("compute_distance", "compute_signed_distance", "compute_occupancy"):
        got, want = getattr(ours, name)(points).numpy(), getattr(theirs, name)(points).numpy()
        assert got.dtype == want.dtype, name
        np.testing.assert_allclose(got, want, atol=1e-6, err_msg=name)
    got, want = _dict(ours.compute_closest_points(points)), _dict(theirs.compute_closest_points(points))
    for key in want:
        assert got[key].dtype == want[key].dtype, key
    np.testing.assert_allclose(got["points"], want["points"], atol=1e-6)


@pytest.mark.parametrize("seed", range(4))
def test_create_rays_pinhole_both_forms_equal_open3d(seed):
    rng = np.random.default_rng(seed)
    eye, center, up = rng.normal(size=(3, 3))
    fov, w, h = rng.uniform(20, 120), int(rng.integers(1, 40)), int(rng.integers(1, 40))
    ours = RaycastingScene.create_rays_pinhole(fov, center, eye, up, w, h)
    theirs = O3D.create_rays_pinhole(fov, center, eye, up, w, h).numpy()
    assert ours.dtype == theirs.dtype == np.float32 and ours.shape == theirs.shape
    np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-6 * np.abs(theirs).max())
    k = np.array([[rng.uniform(50, 500), 0, w / 2], [0, rng.uniform(50, 500), h / 2], [0, 0, 1]])
    e = np.eye(4)
    e[:3, :3] = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    e[:3, 3] = rng.normal(size=3)
    ours = RaycastingScene.create_rays_pinhole(k, e, w, h)
    theirs = O3D.create_rays_pinhole(o3d.core.Tensor(k), o3d.core.Tensor(e), w, h).numpy()
    np.testing.assert_allclose(ours, theirs, rtol=1e-6, atol=1e-6 * np.abs(theirs).max())


def test_random_batches_answer_as_open3d():
    """The bunny-like icosphere, random rays in float32: the same hits (ids, t to float32 rounding, normals)
    wherever the hit is not a near tie between two triangles, the same occlusions and counts."""
    mesh = trimesh.creation.icosphere(subdivisions=3)
    ours, theirs = RaycastingScene(), O3D()
    ours.add_triangles(mesh.vertices.astype(np.float32), mesh.faces)  # the same float32 vertices in both scenes
    theirs.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                         o3d.core.Tensor(mesh.faces.astype(np.uint32)))
    rng = np.random.default_rng(1)
    o = rng.uniform(-3, 3, (5000, 3))
    rays = np.concatenate([o, rng.uniform(-1.5, 1.5, (5000, 3)) - o], 1).astype(np.float32)
    a, b = _dict(ours.cast_rays(rays)), _dict(theirs.cast_rays(rays))
    assert 0.2 < np.isfinite(b["t_hit"]).mean() < 0.9
    same = a["primitive_ids"] == b["primitive_ids"]
    assert same.mean() > 0.999
    np.testing.assert_allclose(a["t_hit"][same], b["t_hit"][same], rtol=1e-5)
    np.testing.assert_array_equal(ours.test_occlusions(rays).numpy(), theirs.test_occlusions(rays).numpy())
    np.testing.assert_array_equal(ours.count_intersections(rays).numpy(), theirs.count_intersections(rays).numpy())
