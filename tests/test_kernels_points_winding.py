"""kernels/points/winding.py through RaycastingScene.compute_winding_number: exact values on closed meshes, the fast
(Barill) evaluation within its stated error bound, and the bunny's holes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from conftest import MESHES, needs_meshes
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.accel.bvh import Shape, TwoLevelBVH
from durer.accel.caps import boundary_cap
from durer.accel.distance import DistanceIndex
from durer.kernels.points.winding import lane_bounds
from durer.query import RaycastingScene


def _scene(mesh) -> RaycastingScene:
    s = RaycastingScene()
    s.add_triangles(mesh.vertices, mesh.faces)
    return s


@pytest.fixture(scope="module")
def closed():
    return [trimesh.creation.torus(1.0, 0.4, major_sections=48, minor_sections=24),
            trimesh.creation.icosphere(subdivisions=4), trimesh.creation.box(extents=[1.5, 1.0, 0.5])]


def test_exact_winding_numbers_of_closed_meshes_are_one_inside_zero_outside(closed):
    pts = np.random.default_rng(0).uniform(-1.6, 1.6, (3000, 3))
    for mesh in closed:
        s = _scene(mesh)
        w = s.compute_winding_number(pts, beta=np.inf)
        np.testing.assert_allclose(w, mesh.contains(pts).astype(float), atol=1e-9)
        flipped = _scene(trimesh.Trimesh(mesh.vertices, mesh.faces[:, ::-1], process=False))
        np.testing.assert_allclose(flipped.compute_winding_number(pts, beta=np.inf), -w, atol=1e-9)


@pytest.mark.parametrize("order", [1, 2])
@pytest.mark.parametrize("beta", [1.5, 2.0, 3.0])
def test_fast_winding_numbers_stay_within_the_stated_bound(closed, order, beta):
    pts = np.random.default_rng(1).uniform(-1.6, 1.6, (3000, 3))
    for mesh in closed:
        s = _scene(mesh)
        exact = s.compute_winding_number(pts, beta=np.inf)
        w, bound = s.compute_winding_number(pts, beta=beta, order=order, return_error_bound=True)
        err = np.abs(w - exact)
        assert np.all(err <= bound + 1e-12)
        assert err.max() > 0 or bound.max() == 0  # the far field is really used
        inside = mesh.contains(pts)
        np.testing.assert_allclose(w, inside, atol=0.1 if beta >= 2 else 0.2)
        # the sign is right wherever the bound says it cannot flip
        sure = bound < 0.49
        np.testing.assert_array_equal((np.abs(w) > 0.5)[sure], inside[sure])


def test_error_shrinks_with_beta_and_order(closed):
    pts = np.random.default_rng(2).uniform(-1.6, 1.6, (3000, 3))
    s = _scene(closed[0])
    exact = s.compute_winding_number(pts, beta=np.inf)
    errs = {(o, b): np.abs(s.compute_winding_number(pts, beta=b, order=o) - exact).mean()
            for o in (1, 2) for b in (1.5, 3.0)}
    assert errs[(1, 3.0)] < errs[(1, 1.5)] and errs[(2, 3.0)] < errs[(2, 1.5)]
    assert errs[(2, 1.5)] < errs[(1, 1.5)] and errs[(2, 3.0)] < errs[(1, 3.0)]


def test_far_away_points_see_only_the_root_lanes():
    s = _scene(trimesh.creation.icosphere(subdivisions=3))
    w, bound = s.compute_winding_number([[100.0, 0, 0], [0, 0, 0]], return_error_bound=True)
    assert abs(w[0]) < 1e-9 and 0 < bound[0] < 1e-6  # approximated, and the bound is tiny
    assert w[1] == pytest.approx(1.0, abs=0.1) and abs(w[1] - 1.0) <= bound[1]


def test_an_open_hemisphere_gives_the_solid_angle_of_its_rim():
    """On the axis of an open hemisphere of radius 1, the winding number is the cap's solid angle / 4 pi,
    (1 - z / sqrt(1 + z^2)) / 2 for the rim circle seen from height z: it varies smoothly through the hole."""
    sphere = trimesh.creation.icosphere(subdivisions=5)
    keep = sphere.triangles_center[:, 2] < 0
    cap = trimesh.Trimesh(sphere.vertices, sphere.faces[keep], process=False)
    s = _scene(cap)
    z = np.linspace(0.05, 3.0, 30)
    w = s.compute_winding_number(np.stack([0 * z, 0 * z, z], axis=1), beta=np.inf)
    np.testing.assert_allclose(w, 0.5 * (1 - z / np.sqrt(1 + z**2)), atol=5e-3)  # the polygon's rim is not a circle
    assert np.all(np.diff(w) < 0)


@needs_meshes
@pytest.mark.slow
def test_the_bunny_holes_degrade_smoothly():
    """The Stanford bunny (Stanford Computer Graphics Laboratory) is open at its base and wound clockwise:
    |w| is 1 deep inside, 0 far outside, and changes continuously (no jumps) along a line through a hole."""
    bunny = trimesh.load(MESHES / "bun_zipper.ply", process=False)
    s = _scene(bunny)
    lo, hi = bunny.bounds
    centre = (lo + hi) / 2
    rng = np.random.default_rng(3)
    pts = rng.uniform(lo - 0.3 * (hi - lo), hi + 0.3 * (hi - lo), (4000, 3))
    w, bound = s.compute_winding_number(pts, return_error_bound=True)
    exact = s.compute_winding_number(pts[:500], beta=np.inf)
    assert np.all(np.abs(w[:500] - exact) <= bound[:500] + 1e-12)
    outside = np.any((pts < lo) | (pts > hi), axis=1)
    d = s.compute_distance(pts)
    assert np.abs(w[outside]).max() < 0.5 and np.abs(w[d > 0.1]).max() < 0.05
    deep = ~outside & (d > 0.01) & (np.abs(w) > 0.5)
    # clockwise: -1 inside, a little less near the hole
    assert deep.sum() > 100 and np.median(np.abs(w[deep] + 1)) < 0.02 and np.all(np.abs(w[deep] + 1) < 0.25)
    # a vertical line through the base: w goes from about -1 inside to 0 below with no jump
    x = centre + np.array([0.0, 0, 0.0])
    line = np.stack([np.full(400, x[0]), np.linspace(lo[1] - 0.02, centre[1], 400), np.full(400, x[2])], axis=1)
    wl = s.compute_winding_number(line, beta=np.inf)
    dl = s.compute_distance(line)
    steps = np.abs(np.diff(wl))
    crossing = (dl[:-1] < 2e-3) | (dl[1:] < 2e-3)  # a jump of 1 is right where the line crosses the surface
    assert steps[~crossing].max() < 0.05


@settings(max_examples=6, deadline=None)
@given(st.integers(5, 40), st.integers(0, 3))
def test_lane_bounds_at_every_level_hold_the_exact_winding_number(step, levels):
    """winding.lane_bounds from the lanes `levels` below the roots (DistanceIndex.root_lanes) is at least |w| of
    the tree's triangles, summed exactly, at random points: what lets inside() skip the caps' winding number where
    it is below 1/2. A holed torus's cap, placed with a rotation and a uniform scale."""
    t = trimesh.creation.torus(1.0, 0.35, major_sections=32, minor_sections=16)
    tris = np.asarray(t.vertices)[np.asarray(t.faces)].reshape(-1, 9)[np.arange(len(t.faces)) % step != 0]
    cap = boundary_cap(tris)
    m = np.eye(4)
    m[:3, :3] = 1.7 * np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    m[:3, 3] = [0.2, -0.1, 0.3]
    index = DistanceIndex(TwoLevelBVH([Shape.mesh(cap.reshape(-1, 3, 3))], [(0, m)]))
    p = np.random.default_rng(step).uniform(-8.0, 8.0, (3000, 3))
    exact = np.abs(index.winding_numbers(p, np.inf, want_err=False)[0])
    bound = np.empty(len(p))
    lanes = index.root_lanes(levels)
    lane_bounds(lanes, p, bound)
    assert len(lanes) >= 4 or levels == 0
    assert np.all(bound >= exact - 1e-12)
    assert np.any(bound < 0.5)  # the bound decides somewhere
