"""kernels/bvh/leaf4.py: the 4-lane watertight test gives the scalar test's answers to the bit, ties to the scalar."""

from __future__ import annotations

import numba as nb
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from durer.kernels.bvh.leaf4 import count_hits4, triangles4
from durer.kernels.bvh.single import ray_setup
from durer.kernels.intersect import watertight_triangle


@nb.njit(cache=False)
def _lanes(leaf_tri, first, n, o, d, t_min, t_max):
    """triangles4 on slots first..first+n-1 as arrays (t, u, v (4,), tie mask) and the scalar test slot by slot."""
    _, _, _, _, _, _, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(o[0], o[1], o[2], d[0], d[1], d[2])
    r = triangles4(leaf_tri, np.int64(first), (np.uint64(kx), np.uint64(ky), np.uint64(kz)), okx, oky, okz, sx, sy,
                   sz, t_min, t_max, np.int64(n))
    vec = np.array([r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11]]).reshape(3, 4)
    scalar = np.full((3, 4), np.inf)
    for lane in range(n):
        t, u, v = watertight_triangle(leaf_tri, (first + lane) * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min,
                                      t_max)
        scalar[0, lane], scalar[1, lane], scalar[2, lane] = t, u, v
    return vec, r[12], scalar


@nb.njit(cache=False)
def _counts(leaf_tri, first, end, o, d, t_min, t_max):
    """count_hits4 over slots first..end and the scalar test's count."""
    _, _, _, _, _, _, kx, ky, kz, sx, sy, sz, okx, oky, okz = ray_setup(o[0], o[1], o[2], d[0], d[1], d[2])
    n = 0
    for j in range(first, end):
        t, _, _ = watertight_triangle(leaf_tri, j * 9, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max)
        n += np.int64(t < np.inf)
    return count_hits4(leaf_tri, first, end, kx, ky, kz, okx, oky, okz, sx, sy, sz, t_min, t_max), n


def _check(tri: np.ndarray, o: np.ndarray, d: np.ndarray, t_min: float = 0.0, t_max: float = np.inf) -> None:
    """Every lane of every 4-slot window of `tri` (k, 3, 3): not flagged -> the scalar (t, u, v) to the bit (u, v
    where hit); flagged -> the scalar test decides; beyond n -> a miss, unflagged. And the counts equal."""
    flat = np.ascontiguousarray(tri).reshape(-1)
    k = len(tri)
    for first in range(k):
        n = min(4, k - first)
        vec, tie, scalar = _lanes(flat, first, n, o, d, t_min, t_max)
        for lane in range(4):
            if lane >= n:
                assert vec[0, lane] == np.inf and not (tie >> lane) & 1
            elif not (tie >> lane) & 1:
                assert vec[0, lane] == scalar[0, lane] or (np.isinf(vec[0, lane]) and np.isinf(scalar[0, lane]))
                if scalar[0, lane] < np.inf:
                    assert vec[1:, lane].tobytes() == scalar[1:, lane].tobytes()
    got, want = _counts(flat, 0, k, o, d, t_min, t_max)
    assert got == want


def test_a_fan_around_the_ray_is_crossed_once_and_an_edge_on_triangle_is_missed():
    """A ray through the shared vertex of a fan of 6 triangles (two vector passes) crosses it once, through the
    edge two of them share once; a triangle in a plane holding the ray is missed (edge_tie's rule)."""
    ang = np.linspace(0, 2 * np.pi, 7)[:6]
    ring = np.column_stack([np.cos(ang), np.sin(ang), np.zeros(6)])
    fan = np.array([[np.zeros(3), ring[i], ring[(i + 1) % 6]] for i in range(6)])
    o, d = np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0])
    for leaf in (fan, fan.astype(np.float32)):
        flat = np.ascontiguousarray(leaf).reshape(-1)
        assert _counts(flat, 0, 6, o, d, 0.0, np.inf) == (1, 1)
        spoke = ring[1] / 2  # on the spoke shared by triangles 0 and 1: crossed once
        assert _counts(flat, 0, 6, spoke - d, d, 0.0, np.inf) == (1, 1)
        rim = (ring[0] + ring[1]) / 2  # on the fan's outer edge: whatever the scalar tie-break says
        got, want = _counts(flat, 0, 6, rim - d, d, 0.0, np.inf)
        assert got == want
        _check(leaf, o, d)
    edge_on = np.array([[[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]])  # the plane x = 0 holds the ray
    assert _counts(edge_on.reshape(-1), 0, 1, o, d, 0.0, np.inf) == (0, 0)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.integers(1, 7), st.sampled_from(["free", "vertex", "edge", "axis", "plane"]),
       st.booleans())
def test_lanes_equal_the_scalar_test_on_random_grazing_and_degenerate_triangles(seed, k, aim, narrow):
    """Random leaves of 1-7 triangles (some degenerate: a repeated vertex, three collinear vertices), float32 or
    float64, against rays aimed anywhere, at a vertex, at an edge's midpoint, along an axis, or lying in a
    triangle's plane: every unflagged lane is the scalar test's (t, u, v) to the bit, and the count is the
    scalar one."""
    rng = np.random.default_rng(seed)
    tri = rng.uniform(-1, 1, (k, 3, 3))
    kind = rng.integers(0, 4, k)
    tri[kind == 1, 2] = tri[kind == 1, 0]                                        # a repeated vertex
    tri[kind == 2, 2] = 2 * tri[kind == 2, 1] - tri[kind == 2, 0]                # collinear
    tri[kind == 3] = np.round(tri[kind == 3] * 4) / 4                            # on a coarse grid (exact ties)
    if narrow:
        tri = tri.astype(np.float32).astype(np.float64)
    o = rng.uniform(-3, 3, 3)
    j = rng.integers(0, k)
    if aim == "vertex":
        d = tri[j, rng.integers(0, 3)] - o
    elif aim == "edge":
        d = (tri[j, 0] + tri[j, 1]) / 2 - o
    elif aim == "axis":
        o = np.round(o * 4) / 4
        d = np.zeros(3)
        d[rng.integers(0, 3)] = rng.choice([-1.0, 1.0])
    elif aim == "plane":  # from vertex 0 towards a point on the edge 1 -> 2: in the triangle's plane
        o = tri[j, 0] - (tri[j, 1] - tri[j, 0])
        d = (tri[j, 1] + tri[j, 2]) / 2 - o
    else:
        d = rng.normal(size=3)
    if not np.any(d):
        d = np.array([0.0, 0.0, 1.0])
    leaf = tri.astype(np.float32) if narrow else tri
    _check(leaf, o, d)
    _check(leaf, o, d, t_min=0.5, t_max=1.5)


def test_rays_in_a_triangles_plane_miss_it_as_in_the_scalar_test():
    """Rays lying in a triangle's plane (up to rounding: through a point of one edge towards a point of another) give
    edge functions that are rounding leftovers, which share a sign for some of them; the scalar test misses them by
    intersect.edge_on's bound on the determinant, and so must every lane (the lanes equal the scalar test's)."""
    rng = np.random.default_rng(7)
    for _ in range(3000):
        tri = rng.uniform(-1, 1, (4, 3, 3))
        a, b = rng.random(2)
        p = tri[0, 0] + a * (tri[0, 1] - tri[0, 0])
        q = tri[0, 1] + b * (tri[0, 2] - tri[0, 1])
        o = p - rng.uniform(0.5, 2) * (q - p)
        _check(tri, o, q - o)
