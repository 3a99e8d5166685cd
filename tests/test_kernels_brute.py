"""Closed-form ray-sphere, ray-plane and ray-triangle cases through the brute-force closest-hit kernel,
and property tests: the hit point lies on the surface, and the closest hit is not farther than any other."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from durer import Group, Plane, Scene, Sphere, Transform, Triangle
from durer.accel.brute import BruteForce
from durer.accel.compile import PLANE, SPHERE, TRIANGLE, compile_scene
from durer.accel.hits import geometric_normals
from durer.scene import transforms as tf
from durer.scene.cameras import OrthographicCamera

CAM = OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=1)


def accel(*objects):
    return BruteForce(compile_scene(Scene(camera=CAM, group=Group(list(objects)))))


def cast(a, origin, direction, t_min=0.0, t_max=np.inf):
    return a.closest_hit(np.array([origin], float), np.array([direction], float), t_min, t_max)


UNIT_SPHERE = Sphere((0, 0, 0), 1.0)


def test_sphere_hit_from_outside():
    h = cast(accel(UNIT_SPHERE), (0, 0, 5), (0, 0, -1))
    assert h.kind[0] == SPHERE and h.t[0] == pytest.approx(4.0)


def test_sphere_miss():
    h = cast(accel(UNIT_SPHERE), (0, 2, 5), (0, 0, -1))
    assert h.kind[0] == 0 and h.t[0] == np.inf and h.prim[0] == -1


def test_sphere_tangent_ray_touches_once():
    h = cast(accel(UNIT_SPHERE), (0, 1, 5), (0, 0, -1))
    assert h.kind[0] == SPHERE and h.t[0] == pytest.approx(5.0)


def test_sphere_behind_the_origin_is_not_hit_with_t_min_zero():
    h = cast(accel(UNIT_SPHERE), (0, 0, 5), (0, 0, 1))
    assert h.kind[0] == 0


def test_sphere_behind_the_origin_is_hit_by_orthographic_rays():
    h = cast(accel(UNIT_SPHERE), (0, 0, 5), (0, 0, 1), t_min=-np.inf)
    assert h.t[0] == pytest.approx(-6.0)  # the nearer root, far behind the origin


def test_inside_the_sphere_hits_the_far_side():
    h = cast(accel(UNIT_SPHERE), (0, 0, 0.5), (0, 0, -1))
    assert h.t[0] == pytest.approx(1.5)


def test_unnormalised_direction_scales_t():
    h = cast(accel(UNIT_SPHERE), (0, 0, 5), (0, 0, -2))
    assert h.t[0] == pytest.approx(2.0)


def test_plane_hit_parallel_and_behind():
    a = accel(Plane((0, 2, 0), -2.0))  # y = -1 once the normal is normalised
    h = cast(a, (0, 3, 0), (0, -1, 0))
    assert h.kind[0] == PLANE and h.t[0] == pytest.approx(4.0)
    assert cast(a, (0, 3, 0), (1, 0, 0)).kind[0] == 0   # parallel
    assert cast(a, (0, 3, 0), (0, 1, 0)).kind[0] == 0   # behind


TRI = Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0))


def test_triangle_hit_barycentrics_and_normal():
    a = accel(TRI)
    h = cast(a, (0.25, 0.5, 1), (0, 0, -1))
    assert h.kind[0] == TRIANGLE and h.t[0] == pytest.approx(1.0)
    assert (h.u[0], h.v[0]) == pytest.approx((0.25, 0.5))
    n = geometric_normals(a.cs, h, np.array([[0.25, 0.5, 0.0]]))
    np.testing.assert_allclose(n[0], [0, 0, 1])  # counter-clockwise seen from +z


@pytest.mark.parametrize("origin", [(0.6, 0.6, 1), (-0.1, 0.5, 1), (0.5, -0.1, 1)])
def test_triangle_misses_outside(origin):
    assert cast(accel(TRI), origin, (0, 0, -1)).kind[0] == 0


def test_closest_of_several_and_t_max():
    a = accel(Sphere((0, 0, 0), 1), Sphere((0, 0, -5), 1), Plane((0, 0, 1), -10))
    h = cast(a, (0, 0, 5), (0, 0, -1))
    assert h.kind[0] == SPHERE and h.prim[0] == 0 and h.t[0] == pytest.approx(4)
    h = cast(a, (0, 0, 5), (0, 0, -1), t_min=7)
    assert h.prim[0] == 1 and h.t[0] == pytest.approx(9)
    assert cast(a, (0, 0, 5), (0, 0, -1), t_max=3.9).kind[0] == 0
    assert a.any_hit(np.array([[0, 0, 5.0]]), np.array([[0, 0, -1.0]]), 0.0, 3.9).tolist() == [False]
    assert a.any_hit(np.array([[0, 0, 5.0]]), np.array([[0, 0, -1.0]]), 0.0, 4.1).tolist() == [True]


def test_transformed_sphere_keeps_t_in_world_units_and_normals_by_inverse_transpose():
    squashed = Transform(tf.scale((1, 0.5, 1)), Sphere((0, 0, 0), 1))
    a = accel(squashed)
    h = cast(a, (0, 5, 0), (0, -1, 0))
    assert h.t[0] == pytest.approx(4.5)  # top of the ellipsoid is at y = 0.5
    # on the ellipsoid x^2 + (2y)^2 = 1 at 45 degrees in object space, the normal is (x, 4y) normalised
    p = np.array([[np.sqrt(0.5), np.sqrt(0.5) / 2, 0]])
    h = cast(a, p[0] + (0, 0, 5), (0, 0, -1))
    n = geometric_normals(a.cs, h, p)
    expected = np.array([np.sqrt(0.5), 4 * np.sqrt(0.5) / 2, 0])
    np.testing.assert_allclose(n[0], expected / np.linalg.norm(expected), atol=1e-6)


coords = st.floats(-3, 3, allow_nan=False)


@st.composite
def rays(draw):
    o = np.array([draw(coords), draw(coords), draw(coords)]) + (0, 0, 8)
    target = np.array([draw(st.floats(-1.5, 1.5)), draw(st.floats(-1.5, 1.5)), draw(st.floats(-1.5, 1.5))])
    d = target - o
    return o, d


@settings(max_examples=200, deadline=None)
@given(rays(), st.floats(0.2, 2.0), st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1))
def test_hit_point_lies_on_the_sphere(ray, r, cx, cy, cz):
    o, d = ray
    c = np.array([cx, cy, cz])
    h = cast(accel(Sphere(c, r)), o, d)
    if h.kind[0]:
        p = o + h.t[0] * d
        assert np.linalg.norm(p - c) == pytest.approx(r, rel=1e-9, abs=1e-9)
        assert h.t[0] > 0


@settings(max_examples=200, deadline=None)
@given(rays(), st.lists(st.tuples(coords, coords, coords), min_size=3, max_size=3))
def test_hit_point_lies_on_the_triangle_plane(ray, verts):
    o, d = ray
    v = np.array(verts)
    n = np.cross(v[1] - v[0], v[2] - v[0])
    if np.linalg.norm(n) < 1e-3:
        return
    h = cast(accel(Triangle(*v)), o, d)
    if h.kind[0]:
        p = o + h.t[0] * d
        assert abs(np.dot(p - v[0], n / np.linalg.norm(n))) < 1e-8 * (1 + np.abs(p).max())
        np.testing.assert_allclose(p, v[0] + h.u[0] * (v[1] - v[0]) + h.v[0] * (v[2] - v[0]), atol=1e-8)


@settings(max_examples=100, deadline=None)
@given(rays(), st.lists(st.tuples(coords, coords, coords, st.floats(0.1, 1.5)), min_size=1, max_size=6))
def test_closest_hit_is_not_farther_than_any_other_hit(ray, spheres):
    o, d = ray
    objs = [Sphere(s[:3], s[3]) for s in spheres]
    best = cast(accel(*objs), o, d).t[0]
    for s in objs:
        t = cast(accel(s), o, d).t[0]
        assert best <= t
    if np.isfinite(best):
        assert any(cast(accel(s), o, d).t[0] == best for s in objs)
