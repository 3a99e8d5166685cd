"""Packets of the inside test's rays (kernels/points/crossing_packets.py): each ray meets exactly the crossings the
one-ray walk (kernels/points/crossings.signed_crossings) meets, so the counts, the unsure flags and the caps' bounds
are the same to the bit, and the inside answers those of the exact winding rule."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from durer import RaycastingScene
from durer.accel.distance import cell_order
from durer.kernels.bvh.chunks import packet_rows, packet_setup
from durer.kernels.bvh.layout import PACKET
from durer.kernels.points.crossing_packets import misses_box, packet_crossings
from durer.kernels.points.crossings import signed_crossings


def _torus(holes: int = 0) -> trimesh.Trimesh:
    t = trimesh.creation.torus(1.0, 0.35, major_sections=48, minor_sections=24)
    if holes:
        keep = np.ones(len(t.faces), bool)
        keep[::holes] = False
        t = trimesh.Trimesh(t.vertices, t.faces[keep], process=False)
    return t


def _dense(lo, hi, n: int, seed: int) -> np.ndarray:
    """n random points in the box lo..hi grown 10% a side, in Morton order: neighbours make coherent packets."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    lo, hi = lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)
    return cell_order(np.random.default_rng(seed).uniform(lo, hi, (n, 3)))[0]


def _same_as_one_ray(scene: RaycastingScene, points: np.ndarray) -> None:
    """The kernel with every coherent chunk as a packet (spread inf) against every ray alone (spread 0)."""
    index = scene._distance_index()
    caps = None if index.closed else index.caps
    wp, up, bp = index._ray_windings(points, caps, spread=np.inf)
    w1, u1, b1 = index._ray_windings(points, caps, spread=0.0)
    np.testing.assert_array_equal(up, u1)
    sure = ~u1
    assert sure.mean() > 0.99
    np.testing.assert_array_equal(wp[sure], w1[sure])
    np.testing.assert_array_equal(bp[sure], b1[sure])
    exact = np.abs(index.winding_numbers(points, np.inf, want_err=False)[0]) > 0.5
    np.testing.assert_array_equal(scene.compute_occupancy(points) > 0.5, exact)


def test_a_packet_counts_what_each_ray_counts_alone():
    """One coherent packet of 16 neighbouring points through the torus's tree: the signed crossings of each of
    its rays equal signed_crossings' for that ray alone, and rays from inside (count 1) and outside (0) are seen."""
    t = _torus()
    s = RaycastingScene()
    s.add_triangles(np.asarray(t.vertices), np.asarray(t.faces))
    b = s._distance_index().tree.packed.blas
    rng = np.random.default_rng(5)
    seen = set()
    for _ in range(40):
        base = rng.uniform([-1.4, -1.4, -0.4], [1.4, 1.4, 0.4])
        o = base + rng.uniform(-0.02, 0.02, (PACKET, 3))
        d = np.array([0.3, -0.4, 0.9]) + rng.uniform(-0.01, 0.01, (PACKET, 3))
        rr = packet_rows()
        ok, nrx, nry, nrz, kx, ky, kz = packet_setup(o, d, np.full(PACKET, -1e-9), np.full(PACKET, np.inf),
                                                     np.arange(PACKET), PACKET, rr, np.inf)
        assert ok
        signed, bad = np.zeros(PACKET), np.zeros(PACKET, np.bool_)
        stack = np.empty(4 * 64, np.int32)
        packet_crossings(b.bounds, b.child, 0, b.leaf_prim, b.leaf_tri, nrx, nry, nrz, kx, ky, kz, rr, 1e-9,
                         stack, np.empty(4), np.empty(4, np.int64), signed, bad)
        for k in range(PACKET):
            dl = np.linalg.norm(d[k])
            one, one_bad = signed_crossings(b.bounds, b.child, 0, b.leaf_prim, b.leaf_tri, *o[k], *d[k], 1e-9 * dl,
                                            stack)
            # t_min -1e-9 here, -t_eps / |d| there: equal to rounding, and no ray starts that near the surface
            assert bad[k] == one_bad
            if not one_bad:
                assert signed[k] == one
                seen.add(one)
    assert {0.0, 1.0} <= seen  # inside the outward-wound torus a ray leaves once: +1


def test_closed_torus_packets_equal_single_rays():
    t = _torus()
    s = RaycastingScene()
    s.add_triangles(np.asarray(t.vertices), np.asarray(t.faces))
    _same_as_one_ray(s, _dense(t.bounds[0], t.bounds[1], 30000, 1))


def test_holed_torus_with_caps_packets_equal_single_rays():
    t = _torus(holes=53)
    s = RaycastingScene()
    s.add_triangles(np.asarray(t.vertices), np.asarray(t.faces))
    assert not s._distance_index().closed and s._distance_index().caps is not None
    _same_as_one_ray(s, _dense(t.bounds[0], t.bounds[1], 30000, 2))


@pytest.mark.slow
@settings(max_examples=8, deadline=None)
@given(angle=st.floats(0.0, 6.2), scale=st.floats(0.3, 3.0), mirror=st.booleans(), seed=st.integers(0, 10**6))
def test_placed_instances_and_a_sphere_packets_equal_single_rays(angle, scale, mirror, seed):
    """Two torus placements (rotated, uniformly scaled, mirrored when drawn) beside a sphere: the packets'
    counts and flags equal the single rays', and the inside answers the exact winding rule's."""
    t = _torus()
    s = RaycastingScene()
    g = s.add_triangles(np.asarray(t.vertices), np.asarray(t.faces))
    c, si = np.cos(angle), np.sin(angle)
    m = np.eye(4)
    m[:3, :3] = scale * np.array([[c, -si, 0.0], [si, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag([-1.0 if mirror else 1.0,
                                                                                            1.0, 1.0])
    m[:3, 3] = [0.5, 0.3, 0.2]
    s.add_instance(g, m)
    s.add_sphere([0.0, 0.0, 0.8], 0.4)
    r = 1.4 * max(scale, 1.0) + 0.6
    _same_as_one_ray(s, _dense([-r, -r, -r], [r, r, r], 8000, seed))


def _lattice_and_random(lo, hi, grow: float, n: int, seed: int) -> np.ndarray:
    """A 16^3 lattice and n random points in the box lo..hi grown by `grow` of its size a side, Morton-sorted."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    lo, hi = lo - grow * (hi - lo), hi + grow * (hi - lo)
    axes = [np.linspace(lo[a], hi[a], 16) for a in range(3)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    rand = np.random.default_rng(seed).uniform(lo, hi, (n, 3))
    return cell_order(np.concatenate([lattice, rand]))[0]


@pytest.mark.parametrize("holes", [0, 53])
def test_points_outside_the_box_count_zero_unwalked(holes):
    """Points outside the scene's box are not walked (ray_windings' box): their count is the 0 the walk finds on
    every sure ray, the caps' bounds are unchanged, and the inside answers equal the exact winding rule's, with
    the torus placed rotated and scaled beside a sphere and the box grown 60% (over half the points outside)."""
    t = _torus(holes)
    s = RaycastingScene()
    g = s.add_triangles(np.asarray(t.vertices), np.asarray(t.faces))
    m = np.eye(4)
    m[:3, :3] = 1.3 * np.array([[0.6, -0.8, 0.0], [0.8, 0.6, 0.0], [0.0, 0.0, 1.0]])
    m[:3, 3] = [0.5, 0.3, 0.2]
    s.add_instance(g, m)
    s.add_sphere([0.0, 0.0, 0.9], 0.4)
    index = s._distance_index()
    caps = None if index.closed else index.caps
    assert (caps is None) == (holes == 0)
    lo, hi = index.tree._inst_lo.min(axis=0), index.tree._inst_hi.max(axis=0)
    points = _lattice_and_random(lo, hi, 0.6, 12000, holes)
    outside = np.any((points < lo) | (points > hi), axis=1)
    assert outside.mean() > 0.5
    w, unsure, bound = index._ray_windings(points, caps)
    w0, unsure0, bound0 = index._ray_windings(points, caps, skip_outside=False)
    assert not unsure[outside].any() and (w[outside] == 0.0).all()
    sure = ~unsure0
    assert sure.mean() > 0.99
    np.testing.assert_array_equal(w[sure], w0[sure])
    np.testing.assert_array_equal(unsure[~outside], unsure0[~outside])
    np.testing.assert_array_equal(bound, bound0)
    exact = np.abs(index.winding_numbers(points, np.inf, want_err=False)[0]) > 0.5
    np.testing.assert_array_equal(s.compute_occupancy(points) > 0.5, exact)


_coord = st.floats(-4.0, 4.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(p=st.tuples(_coord, _coord, _coord), d=st.tuples(_coord, _coord, _coord),
       lo=st.tuples(_coord, _coord, _coord), size=st.tuples(*[st.floats(0.0, 3.0)] * 3),
       zero=st.sampled_from([None, 0, 1, 2]))
def test_misses_box_agrees_with_points_along_the_ray(p, d, lo, size, zero):
    """crossing_packets.misses_box (the caps' skip): a ray said to enter the box has a point of t >= 0 in it (the
    middle of its slab interval); a ray said to miss it has none among 20,001 points up to past the box's far
    corner, nor its origin (axes with d = 0 drawn too)."""
    p, d, lo = np.array(p), np.array(d), np.array(lo)
    if zero is not None:
        d[zero] = 0.0
    hi = lo + np.array(size)
    if not np.any(d):
        d[0] = 1.0
    missed = misses_box(*p, *d, lo, hi)
    tol = 1e-9 * (1.0 + np.abs(p).max() + np.abs(hi).max())
    if not missed:
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = (lo - p) / d, (hi - p) / d
        t0 = np.max(np.where(d != 0.0, np.minimum(ta, tb), -np.inf), initial=0.0)
        t1 = np.min(np.where(d != 0.0, np.maximum(ta, tb), np.inf))
        q = p + d * (0.5 * (t0 + t1) if np.isfinite(t1) else t0)
        assert np.all(q >= lo - tol) and np.all(q <= hi + tol)
    else:
        far = (np.linalg.norm(p) + np.linalg.norm(hi - lo) + np.linalg.norm(lo) + 1.0) / np.linalg.norm(d) * 2.0
        q = p + np.linspace(0.0, far, 20001)[:, None] * d
        assert not np.any(np.all((q > lo + tol) & (q < hi - tol), axis=1))
