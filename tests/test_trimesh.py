"""durer.trimesh.RayMeshIntersector against trimesh's embree backend (trimesh.ray.ray_pyembree) where installed, and
on the behaviours trimesh's own tests/test_ray.py checks: hits on vertices and edges once, points a hair outside,
duplicate hits of a huge box, empty results."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from durer.trimesh import RayMeshIntersector


def _box(**kwargs) -> trimesh.Trimesh:
    mesh = trimesh.creation.box(**kwargs)
    mesh.ray = RayMeshIntersector(mesh)
    return mesh


def test_on_vertex_each_ray_hits_once():
    """trimesh's test_on_vertex: rays from the box's centre through its 8 corners hit once each."""
    m = _box()
    origins, vectors = np.zeros_like(m.vertices), m.vertices.copy()
    assert m.ray.intersects_any(ray_origins=origins, ray_directions=vectors).all()
    _, index_ray, _ = m.ray.intersects_location(ray_origins=origins, ray_directions=vectors)
    assert np.bincount(index_ray, minlength=len(origins)).tolist() == [1] * 8


def test_on_edges_and_vertices_from_outside_count_two():
    """Rays from outside through the centre and a vertex or an edge's midpoint of an icosphere cross twice."""
    ico = trimesh.creation.icosphere(subdivisions=2)
    ico.ray = RayMeshIntersector(ico)
    mids = ico.vertices[ico.edges_unique].mean(axis=1)
    for targets in (ico.vertices, mids):
        _, index_ray, _ = ico.ray.intersects_location(-3 * targets, targets)
        assert np.bincount(index_ray, minlength=len(targets)).tolist() == [2] * len(targets)


def test_contains_points_near_faces_edges_and_vertices():
    """trimesh's test_contains and test_on_edge in kind: vertices scaled in are inside, out are outside, a point a
    hair outside a face is outside and one a hair inside is inside, also in line with edges and vertices."""
    m = _box()
    assert m.ray.contains_points(m.vertices / 1.5).all() and not m.ray.contains_points(m.vertices * 1.5).any()
    assert m.ray.contains_points([m.center_mass]).all()
    far = np.random.default_rng(0).random((30, 3)) * 100 + 1.0 + m.bounds[1]
    assert not m.ray.contains_points(far).any()
    points = [[0.5 + 1e-6, 0, 0], [0.5 - 1e-6, 0, 0], [0, 0.5 + 1e-6, 0.5 - 1e-6], [0.5 - 1e-6, 0.5 - 1e-6, 0],
              [0, -1e-6 - 0.5, 0]]
    np.testing.assert_array_equal(m.ray.contains_points(points), [False, True, False, True, False])


def test_huge_box_has_no_duplicate_hits():
    """trimesh's test_embree_duplicate_hits: a ray from the top face of a box 10,000 wide down through its middle
    (the bottom face's diagonal) leaves the box once."""
    m = trimesh.creation.box()
    m.apply_scale(10000.0)
    m.ray = RayMeshIntersector(m)
    index_tri, index_ray = m.ray.intersects_id([[0.0, 0.0, 5000.0]], [[0.0, 0.0, -1.0]], multiple_hits=True)
    assert len(index_tri) == 1 and index_ray.tolist() == [0]


def test_empty_results_and_types():
    m = _box()
    origins = np.random.default_rng(1).random((100, 3))
    origins[:, 2] = -5
    directions = np.tile([0.0, 1.0, 0.0], (100, 1))
    tri, ray, loc = m.ray.intersects_id(origins + [5, 0, 0], directions, return_locations=True)
    assert tri.shape == ray.shape == (0,) and loc.shape == (0, 3)
    assert tri.dtype == ray.dtype == np.int64 and loc.dtype == np.float64
    assert m.ray.intersects_first(origins, directions).tolist() == [-1] * 100
    assert m.ray.intersects_first(origins, directions).dtype == np.int32
    assert not m.ray.intersects_any(origins, directions).any()
    assert m.ray.intersects_id(np.zeros((0, 3)), np.zeros((0, 3)))[0].shape == (0,)
    with pytest.raises(ValueError, match="don't match"):
        m.ray.intersects_id(np.zeros((2, 3)), np.zeros((3, 3)))


def test_the_mesh_changing_rebuilds_the_tree():
    m = _box()
    ray = ([[0.0, 0.0, -5.0]], [[0.0, 0.0, 1.0]])
    assert m.ray.intersects_location(*ray)[0][0, 2] == pytest.approx(-0.5)
    m.apply_translation([0.0, 0.0, 1.0])
    assert m.ray.intersects_location(*ray)[0][0, 2] == pytest.approx(0.5)


def test_answers_equal_the_embree_backend():
    """Random rays at an icosphere: the same triangles, rays, order and (to float32 rounding) locations as trimesh's
    embree backend, for first hits, every hit and max_hits."""
    pytest.importorskip("embreex")
    from trimesh.ray.ray_pyembree import RayMeshIntersector as Embree

    mesh = trimesh.creation.icosphere(subdivisions=3)
    ours, theirs = RayMeshIntersector(mesh), Embree(mesh)
    rng = np.random.default_rng(2)
    o = rng.uniform(-3, 3, (3000, 3))
    d = rng.uniform(-0.9, 0.9, (3000, 3)) - o
    np.testing.assert_array_equal(ours.intersects_first(o, d), theirs.intersects_first(o, d))
    np.testing.assert_array_equal(ours.intersects_any(o, d), theirs.intersects_any(o, d))
    for kwargs in ({}, {"multiple_hits": False}, {"max_hits": 1}):
        a, b = ours.intersects_id(o, d, return_locations=True, **kwargs), theirs.intersects_id(
            o, d, return_locations=True, **kwargs)
        for x, y in zip(a, b, strict=True):
            assert x.dtype == y.dtype and x.shape == y.shape
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])
        np.testing.assert_allclose(a[2], b[2], atol=1e-5)
    points = rng.uniform(-1.2, 1.2, (2000, 3))
    np.testing.assert_array_equal(ours.contains_points(points), theirs.contains_points(points))
