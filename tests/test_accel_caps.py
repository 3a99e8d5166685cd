"""Caps closing open meshes (accel/caps.py) and the inside test built on them (accel/distance.DistanceIndex.inside):
one ray per point and the caps' few triangles give the exact winding rule's answers on meshes with holes."""

from __future__ import annotations

import numpy as np
import trimesh
from conftest import MESHES, needs_meshes
from hypothesis import given, settings
from hypothesis import strategies as st

from durer import RaycastingScene
from durer.accel.caps import boundary_cap
from durer.accel.distance import closed_mesh


def _torus(major: int = 32, minor: int = 16) -> trimesh.Trimesh:
    return trimesh.creation.torus(1.0, 0.35, major_sections=major, minor_sections=minor)


def _tris(mesh: trimesh.Trimesh, keep: np.ndarray | None = None) -> np.ndarray:
    f = np.asarray(mesh.faces) if keep is None else np.asarray(mesh.faces)[keep]
    return np.asarray(mesh.vertices)[f].reshape(-1, 9)


def _points(v: np.ndarray, grid: int, n: int, seed: int = 5) -> np.ndarray:
    lo, hi = v.min(0), v.max(0)
    lo, hi = lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)
    axes = [np.linspace(lo[i], hi[i], grid) for i in range(3)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return np.vstack([lattice, np.random.default_rng(seed).uniform(lo, hi, (n, 3))])


def _scene(tris: np.ndarray) -> RaycastingScene:
    s = RaycastingScene()
    s.add_triangles(tris.reshape(-1, 3), np.arange(len(tris) * 3).reshape(-1, 3))
    return s


def _exact_inside(index, p: np.ndarray) -> np.ndarray:
    """|w| > 1/2 by the winding rule summed exactly where its far field's error bound does not settle it."""
    w, err = index.winding_numbers(p, 2.0)
    for beta in (6.0, 20.0, np.inf):  # tighter far fields for the points a looser one leaves unsettled
        open_ = np.flatnonzero(np.abs(np.abs(w) - 0.5) <= err + 1e-9)
        w[open_], err[open_] = index.winding_numbers(p[open_], beta)
    return np.abs(w) > 0.5


def test_closed_mesh_needs_no_cap():
    assert boundary_cap(_tris(_torus())).shape == (0, 9)
    assert boundary_cap(np.zeros((0, 9))).shape == (0, 9)


def test_single_triangle_cap_is_its_reverse_fan():
    tri = np.array([[0.0, 0, 0, 1, 0, 0, 0, 1, 0]])
    cap = boundary_cap(tri)
    assert cap.shape == (3, 9)
    assert closed_mesh(np.vstack([tri, cap]))
    apex = np.float32(1 / 3)
    np.testing.assert_array_equal(cap.reshape(-1, 3, 3)[:, 2], [[apex, apex, 0.0]] * 3)  # the loop's mean vertex


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 60), st.integers(0, 59), st.booleans())
def test_cap_closes_holes_and_flipped_triangles(step, offset, flip):
    """Faces removed (every step-th from offset: one hole or many) and, when asked, one triangle wound backwards:
    mesh plus cap is closed, and its exact winding number is an integer at random points off the surfaces."""
    t = _torus()
    keep = np.arange(len(t.faces)) % step != offset % step
    tris = _tris(t, keep)
    if flip:
        tris[0] = tris[0].reshape(3, 3)[::-1].ravel()
    cap = boundary_cap(tris)
    assert len(cap) > 0
    assert closed_mesh(np.vstack([tris, cap]))
    whole = _scene(np.vstack([tris, cap]))._distance_index()
    p = np.random.default_rng(step).uniform(-1.6, 1.6, (200, 3))
    w = whole.winding_numbers(p, np.inf, want_err=False)[0]
    np.testing.assert_allclose(w, np.round(w), atol=1e-9)


@settings(max_examples=6, deadline=None)
@given(st.integers(12, 90), st.integers(0, 11))
def test_open_torus_occupancy_is_the_exact_winding_rule(step, offset):
    """compute_occupancy on a torus with holes (the cap path: crossings of mesh and cap minus the cap's winding
    number) equals the exact winding rule on lattice and random points, and its holes make some points'
    winding numbers fractional (so the cap's term matters)."""
    t = _torus()
    tris = _tris(t, np.arange(len(t.faces)) % step != offset)
    s = _scene(tris)
    index = s._distance_index()
    assert not index.closed and index.caps is not None
    p = _points(np.asarray(t.vertices), 14, 2000, seed=step)
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, _exact_inside(index, p))
    w = index.winding_numbers(p, np.inf, want_err=False)[0]
    assert np.any(np.abs(w - np.round(w)) > 0.05)


def test_instances_of_an_open_mesh_share_its_cap():
    """The open torus placed twice (one mirrored) beside a sphere: one cap shape placed by both instances, and the
    exact winding rule's answers."""
    t = _torus()
    s = RaycastingScene()
    f = np.asarray(t.faces)[np.arange(len(t.faces)) % 11 != 3]
    g = s.add_triangles(np.asarray(t.vertices), f)
    m = np.eye(4)
    m[:3, :3] = np.diag([-1.0, 1.0, 1.0])
    m[:3, 3] = [0.6, 0.2, 0.1]
    s.add_instance(g, m)
    s.add_sphere([0.0, 0.0, 0.9], 0.4)
    index = s._distance_index()
    caps = index.caps
    assert len(caps.tree.shapes) == 1 and len(caps.tree.instances) == 2
    p = _points(np.array([[-1.5, -1.5, -0.6], [2.1, 1.7, 1.4]]), 14, 3000)
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, _exact_inside(index, p))


def test_the_scene_counts_its_caps_memory_once_built():
    """The caps' index is built by the first inside test on an open mesh, and the scene's memory (its repr) counts
    it from then on: caps_nbytes is 0 before, and the caps' own tree, placements and moments after."""
    t = _torus()
    s = _scene(_tris(t, np.arange(len(t.faces)) % 7 != 2))
    s.compute_occupancy(np.zeros((1, 3), np.float32) + 5.0)  # outside, far: the scene and its index are built
    index = s._distance_index()
    index._caps = False  # as before any inside test that needed them
    assert index.caps_nbytes == 0
    caps = index.caps
    assert index.caps_nbytes == caps.tree.nbytes + caps.nbytes + caps.moments_nbytes > caps.tree.nbytes > 0


def test_large_caps_keep_the_winding_rule():
    """A soup of disjoint triangles: its cap would be three times its size, so the winding rule decides."""
    rng = np.random.default_rng(2)
    tris = rng.uniform(-1, 1, (40, 9))
    s = _scene(tris)
    index = s._distance_index()
    assert index.caps is None
    p = rng.uniform(-1.2, 1.2, (500, 3))
    rule = np.abs(index.winding_numbers(p, 1.5, want_err=False)[0]) > 0.5
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, rule)


@needs_meshes
def test_bunny_occupancy_is_the_exact_winding_rule():
    mesh = trimesh.load(MESHES / "bun_zipper.ply")
    s = RaycastingScene()
    s.add_triangles(np.asarray(mesh.vertices), np.asarray(mesh.faces))
    index = s._distance_index()
    assert not index.closed and len(index.caps.tree.packed.normals) == 223  # the base's holes, fanned
    p = _points(np.asarray(mesh.vertices), 20, 4000)
    np.testing.assert_array_equal(s.compute_occupancy(p) > 0.5, _exact_inside(index, p))
