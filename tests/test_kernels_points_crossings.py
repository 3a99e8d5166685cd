"""One ray's signed crossings as the winding number of closed meshes (kernels/points/crossings.py), and the default
inside test built on it (accel/distance.DistanceIndex.inside): the winding rule's answers, faster."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from durer import RaycastingScene
from durer.accel.distance import closed_mesh


def _torus() -> trimesh.Trimesh:
    return trimesh.creation.torus(1.0, 0.35, major_sections=64, minor_sections=32)


def _points(v: np.ndarray, grid: int, n: int, seed: int = 3) -> np.ndarray:
    """A grid x grid x grid lattice over the bounds grown 10% a side (rows through vertices and edges included),
    plus n uniform random points there."""
    lo, hi = v.min(0), v.max(0)
    lo, hi = lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)
    axes = [np.linspace(lo[i], hi[i], grid) for i in range(3)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return np.vstack([lattice, np.random.default_rng(seed).uniform(lo, hi, (n, 3))])


def _scene(v, f) -> RaycastingScene:
    s = RaycastingScene()
    s.add_triangles(np.asarray(v, np.float64), np.asarray(f, np.int64))
    return s


def test_closed_mesh_checks_edge_balance():
    t = _torus()
    tris = np.asarray(t.vertices)[np.asarray(t.faces)].reshape(-1, 9)
    assert closed_mesh(tris)
    assert not closed_mesh(tris[1:])  # a hole
    flipped = tris.copy()
    flipped[0] = flipped[0].reshape(3, 3)[::-1].ravel()  # one triangle wound the other way
    assert not closed_mesh(flipped)
    assert closed_mesh(tris.reshape(-1, 3, 3)[:, ::-1].reshape(-1, 9))  # all wound the other way: closed


def test_closed_torus_takes_the_rays_and_gives_the_exact_winding_rule():
    t = _torus()
    s = _scene(t.vertices, t.faces)
    index = s._distance_index()
    assert index.closed
    p = _points(np.asarray(t.vertices), 28, 10000)
    exact = np.abs(index.winding_numbers(p, np.inf, want_err=False)[0]) > 0.5
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, exact)
    # the signed count itself: +1 inside (outward wound), 0 outside, on the rays that were clean
    inside = exact.sum()
    assert 0.05 * len(p) < inside < 0.5 * len(p)


def test_points_on_faces_fall_back_to_the_winding_rule():
    """Face centres lie on the surface (winding about 1/2): the ray from each meets its own triangle at t = 0, so
    those points are unsure and take the winding rule, whose answer compute_occupancy must give. (A point exactly
    on an edge or a vertex where the surface folds away from its ray is met by no crossing and stays with the
    ray's answer: there the winding rule itself is rounding noise, 0.48 to 1.43 on this torus's edge midpoints.)"""
    t = _torus()
    v, f = np.asarray(t.vertices), np.asarray(t.faces)
    s = _scene(v, f)
    p = v[f].mean(axis=1)
    index = s._distance_index()
    rule = np.abs(index.winding_numbers(p, 1.5, want_err=False)[0]) > 0.5
    assert 0 < rule.sum() < len(p)  # the rule's answers on the surface are mixed: the fallback is seen
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, rule)


@pytest.mark.parametrize("mirror", [False, True])
def test_instances_and_spheres_sum_like_winding_numbers(mirror):
    """Two placements of the torus (one mirrored when asked) overlapping, and a sphere: the ray path's inside
    answers equal the exact winding rule's over all instances."""
    t = _torus()
    s = RaycastingScene()
    g = s.add_triangles(np.asarray(t.vertices), np.asarray(t.faces))
    m = np.eye(4)
    m[:3, 3] = [0.6, 0.2, 0.1]
    if mirror:
        m[:3, :3] = np.diag([-1.0, 1.0, 1.0])
    s.add_instance(g, m)
    s.add_sphere([0.0, 0.0, 0.9], 0.4)
    index = s._distance_index()
    assert index.closed
    p = _points(np.array([[-1.5, -1.5, -0.6], [2.1, 1.7, 1.4]]), 17, 6000)
    exact = np.abs(index.winding_numbers(p, np.inf, want_err=False)[0]) > 0.5
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, exact)
