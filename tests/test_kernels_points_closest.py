"""kernels/points/closest.py: Ericson's point-triangle test and Eberly's point-ellipsoid bisection against independent
NumPy references, including points exactly on vertices, edges and faces."""

from __future__ import annotations

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from durer.kernels.points.closest import closest_on_ellipsoid, closest_on_triangle

coord = st.floats(-10, 10, allow_nan=False, allow_infinity=False)
vec = st.tuples(coord, coord, coord).map(np.array)


def reference_triangle(p, a, b, c) -> float:
    """Distance from p to triangle abc: the plane projection when it falls inside, else the nearest edge point."""
    def segment(x, y):
        e = y - x
        t = 0.0 if e @ e == 0 else np.clip((p - x) @ e / (e @ e), 0, 1)
        return np.linalg.norm(x + t * e - p)

    best = min(segment(a, b), segment(b, c), segment(c, a))
    n = np.cross(b - a, c - a)
    if n @ n > 1e-12 * max(1.0, np.abs(np.array([a, b, c])).max()) ** 4:
        q = p - (p - a) @ n / (n @ n) * n
        m = np.array([b - a, c - a]).T
        v, w = np.linalg.lstsq(m, q - a, rcond=None)[0]
        if v >= 0 and w >= 0 and v + w <= 1:
            best = min(best, np.linalg.norm(q - p))
    return best


def _closest(p, a, b, c):
    qx, qy, qz, v, w = closest_on_triangle(*p, *a, *b, *c)
    return np.array([qx, qy, qz]), v, w


@settings(max_examples=300, deadline=None)
@given(vec, vec, vec, vec)
def test_triangle_distance_equals_reference(p, a, b, c):
    q, v, w = _closest(p, a, b, c)
    assert v >= 0 and w >= 0 and v + w <= 1 + 1e-12
    np.testing.assert_allclose(q, a + v * (b - a) + w * (c - a), atol=1e-9)
    scale = max(1.0, np.abs(np.array([p, a, b, c])).max())
    assert abs(np.linalg.norm(q - p) - reference_triangle(p, a, b, c)) <= 1e-9 * scale


@settings(max_examples=200, deadline=None)
@given(vec, vec, vec, st.floats(0, 1), st.floats(0, 1), st.integers(0, 2))
def test_points_on_vertices_edges_and_faces_are_their_own_closest_point(a, b, c, s, t, where):
    if np.linalg.norm(np.cross(b - a, c - a)) < 1e-3:
        return  # nearly degenerate: covered by the reference test
    if where == 0:
        p = [a, b, c][int(s * 2.999)]
    elif where == 1:
        p = [a, b, c][int(s * 2.999)] + t * ([b, c, a][int(s * 2.999)] - [a, b, c][int(s * 2.999)])
    else:
        u, w = (s, t) if s + t <= 1 else (1 - s, 1 - t)
        p = a + u * (b - a) + w * (c - a)
    q, _, _ = _closest(p, a, b, c)
    assert np.linalg.norm(q - p) <= 1e-12 * max(1.0, np.abs(np.array([a, b, c])).max()) * 10


def test_vertex_edge_and_face_regions_give_their_weights():
    a, b, c = np.zeros(3), np.array([1.0, 0, 0]), np.array([0.0, 1, 0])
    assert _closest(np.array([-1.0, -1, 3]), a, b, c)[1:] == (0.0, 0.0)
    assert _closest(np.array([2.0, -0.5, 1]), a, b, c)[1:] == (1.0, 0.0)
    assert _closest(np.array([-0.5, 2.0, 1]), a, b, c)[1:] == (0.0, 1.0)
    q, v, w = _closest(np.array([0.5, -2.0, 1]), a, b, c)
    assert (v, w) == (0.5, 0.0) and np.allclose(q, [0.5, 0, 0])
    q, v, w = _closest(np.array([1.0, 1.0, -1]), a, b, c)
    assert np.allclose((v, w), (0.5, 0.5)) and np.allclose(q, [0.5, 0.5, 0])
    q, v, w = _closest(np.array([0.25, 0.25, 7]), a, b, c)
    assert np.allclose((v, w), (0.25, 0.25)) and np.allclose(q, [0.25, 0.25, 0])


def test_degenerate_triangles_fall_back_to_edges():
    a, b = np.zeros(3), np.array([2.0, 0, 0])
    q, v, w = _closest(np.array([1.0, 1.0, 0]), a, b, b.copy())   # two vertices coincide
    assert np.allclose(q, [1, 0, 0]) and np.isfinite([v, w]).all()
    q, _, _ = _closest(np.array([3.0, 1.0, 0]), a, a.copy(), a.copy())  # a point
    assert np.allclose(q, 0)
    q, _, _ = _closest(np.array([0.5, 1.0, 0]), a, b, np.array([1.0, 0, 0]))  # collinear
    assert np.allclose(q, [0.5, 0, 0])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.2, 5.0), min_size=3, max_size=3), st.tuples(st.floats(0, 8), st.floats(0, 8), st.floats(0, 8)))
@example([1.0, 2.0, 2.0], (0.0, 1.0, 5e-324))   # a coordinate below the root's resolution (found by hypothesis)
@example([1.0, 2.0, 3.0], (0.5, 1e-300, 1e-300))
@example([1.0, 2.0, 2.0], (0.0, 1.0, 1e-15))   # deep inside, next to a plane: the root's s + 1 cancels
@example([1.0, 1.0, 1.0], (0.0, 2.8e-232, 2.8e-232))  # a sphere, the point next to its centre
@example([2.0, 1.0, 1.0], (0.5, 1e-12, 1e-12))  # a spheroid, the point near its axis, well inside
@example([1.0, 0.2, 0.2], (0.0, 2.2250738585e-313, 2.2250738585e-313))  # subnormal coordinates on a circle
def test_ellipsoid_point_is_on_the_surface_and_optimal(axes, y):
    e = np.sort(np.array(axes))[::-1]
    y = np.array(y)
    x = np.array(closest_on_ellipsoid(*e, *y))
    assert abs((x / e) @ (x / e) - 1.0) < 1e-9
    # optimality: no point of a dense sampling of the octant's surface is closer (up to the sampling's spacing)
    th, ph = np.meshgrid(np.linspace(0, np.pi / 2, 200), np.linspace(0, np.pi / 2, 200))
    s = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3) * e
    sampled = np.linalg.norm(s - y, axis=1).min()
    d = np.linalg.norm(x - y)
    assert d <= sampled + 1e-12
    assert d >= sampled - 0.05 * e[0]  # the sampling's spacing bounds how much closer the exact point can be
    # the normal condition: y - x is parallel to the gradient x / e^2 (unless y is on the surface)
    g = x / e**2
    r = y - x
    if np.linalg.norm(r) > 1e-6:
        assert np.linalg.norm(np.cross(r, g)) <= 1e-6 * np.linalg.norm(r) * np.linalg.norm(g)
