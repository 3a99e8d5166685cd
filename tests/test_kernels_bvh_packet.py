"""The packet walk's node test (kernels/bvh/packet.py): the vector form (packet_node4, packet_entry4) against the
scalar one (packet_node) at every node of random trees, to the bit, for packets that graze boxes, run parallel to
an axis and sit at the edge of an image's tiles; and the walk against the one-ray walk."""

from __future__ import annotations

import numba as nb
import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from durer.accel.brute import BruteForce
from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.kernels.bvh.chunks import _NROW, packet_setup
from durer.kernels.bvh.layout import PACKET, WIDTH
from durer.kernels.bvh.packet import packet_extents, packet_node, packet_node4
from durer.kernels.bvh.single import child_codes
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh


@nb.njit(cache=True)
def _both_tests(bounds, child, rr, nrx, nry, nrz, far):
    """packet_node and packet_node4 at every node: (n_in of each, keys and lanes of each) per node."""
    ext = packet_extents(rr, nrx, nry, nrz)
    n = child.shape[0]
    n_a, n_b = np.empty(n, np.int64), np.empty(n, np.int64)
    key_a, key_b = np.full((n, WIDTH), np.nan), np.full((n, WIDTH), np.nan)
    ord_a, ord_b = np.full((n, WIDTH), -1), np.full((n, WIDTH), -1)
    key, order = np.empty(WIDTH), np.empty(WIDTH, np.int64)
    for node in range(n):
        m = packet_node(bounds, child, node, nrx, nry, nrz, ext, far, key, order)
        n_a[node] = m
        key_a[node, :m], ord_a[node, :m] = key[:m], order[:m]
        m = packet_node4(bounds, child_codes(child, node), node, nrx, nry, nrz, ext, far, key, order)
        n_b[node] = m
        key_b[node, :m], ord_b[node, :m] = key[:m], order[:m]
    return n_a, n_b, key_a, key_b, ord_a, ord_b


def _mesh_scene(rng: np.random.Generator, n_tri: int, grid: bool) -> Scene:
    """Random triangles, or (grid) axis-aligned ones on integer planes, whose boxes have faces that axis-parallel
    rays graze."""
    if grid:
        base = rng.integers(-3, 3, (n_tri, 1, 3)).astype(float)
        v = base + np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    else:
        v = rng.uniform(-3, 3, (n_tri, 1, 3)) + rng.normal(scale=0.5, size=(n_tri, 3, 3))
    return Scene(camera=None, group=Group([TriangleMesh(v.reshape(-1, 3), np.arange(3 * n_tri).reshape(-1, 3))]))


def _packet(rng: np.random.Generator, kind: str):
    """16 coherent rays: a 4 x 4 pinhole tile, parallel rays along an axis from a grid of integer origins (on box
    faces), or a tile with a zero direction component (reciprocal 1e300)."""
    if kind == "pinhole":
        eye = rng.uniform(-8, 8, 3)
        look = rng.uniform(-2, 2, 3) - eye
        look /= np.linalg.norm(look)
        side = np.cross(look, [0.3, 1.0, 0.1])
        side /= np.linalg.norm(side)
        up = np.cross(side, look)
        j, i = np.meshgrid(np.arange(4), np.arange(4))
        s = rng.uniform(1e-4, 0.05)
        d = look + s * ((j.reshape(-1, 1) - 1.5) * side + (i.reshape(-1, 1) - 1.5) * up)
        return np.broadcast_to(eye, d.shape).copy(), d
    axis = int(rng.integers(3))
    sign = 1.0 if rng.random() < 0.5 else -1.0
    d = np.zeros((PACKET, 3))
    d[:, axis] = sign
    if kind == "tilted":
        d[:, (axis + 1) % 3] = rng.uniform(0.01, 0.2)
    o = np.zeros((PACKET, 3))
    a, b = (axis + 1) % 3, (axis + 2) % 3
    g = np.arange(PACKET)
    o[:, a] = rng.integers(-3, 2) + (g % 4) * 0.5
    o[:, b] = rng.integers(-3, 2) + (g // 4) * 0.5
    o[:, axis] = -6.0 * sign
    return o, d


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 300), grid=st.booleans(),
       kind=st.sampled_from(["pinhole", "axis", "tilted"]), far=st.sampled_from([np.inf, 3.0, 7.5]))
def test_vector_node_test_equals_the_scalar_one(seed, n_tri, grid, kind, far):
    """Same entered lanes, in the same order, with the same entry bounds to the bit, at every node."""
    rng = np.random.default_rng(seed)
    tree = BVHAccelerator(compile_scene(_mesh_scene(rng, n_tri, grid)))._args().args
    bounds, child = tree[0], tree[1]
    o, d = _packet(rng, kind)
    rr = np.empty(_NROW * PACKET)
    lo, hi = np.zeros(PACKET), np.full(PACKET, np.inf)
    coherent, nrx, nry, nrz = packet_setup(o, d, lo, hi, np.arange(PACKET), PACKET, rr, 1e9)[:4]
    assume(coherent)  # a pinhole tile across an octant's or an axis order's border goes one ray at a time
    n_a, n_b, key_a, key_b, ord_a, ord_b = _both_tests(bounds, child, rr, nrx, nry, nrz, far)
    np.testing.assert_array_equal(n_a, n_b)
    np.testing.assert_array_equal(ord_a, ord_b)
    np.testing.assert_array_equal(key_a, key_b)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 400), grid=st.booleans())
def test_packet_walk_equals_brute_force_up_to_the_image_edge(seed, n_tri, grid):
    """A 20 x 20 image of camera rays traced as 4 x 4 packets (width 20; the last tiles end at the image's edge):
    the same t to the bit, kinds and primitives as brute force."""
    rng = np.random.default_rng(seed)
    cs = compile_scene(_mesh_scene(rng, n_tri, grid))
    bvh = BVHAccelerator(cs)
    eye = np.array([0.3, 0.2, 9.0]) + rng.uniform(-1, 1, 3)
    j, i = np.meshgrid(np.arange(20), np.arange(20))
    d = np.stack([(j.ravel() - 9.5) * 0.03, (i.ravel() - 9.5) * 0.03, -np.ones(400)], 1)
    o = np.broadcast_to(eye, d.shape).copy()
    h = bvh.closest_hit(o, d, width=20)
    ref = BruteForce(cs).closest_hit(o, d)
    np.testing.assert_array_equal(h.t, ref.t)
    np.testing.assert_array_equal(h.kind, ref.kind)
    assert np.all((h.prim == ref.prim) | (h.t == ref.t))
