"""The packet all-hits walk (kernels/bvh/packet_all.py) behind count_intersections and list_intersections: camera
rays in coherent packets get exactly the one-ray walk's hits (t, u, v to the bit), closed forms on a cube."""

from __future__ import annotations

import numpy as np
from conftest import pinhole_rays
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from durer import RaycastingScene
from durer.kernels.bvh.chunks import _NROW, load_chunk
from durer.kernels.bvh.layout import PACKET, packet_spread_limit

RES = 48

CUBE_V = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
CUBE_F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                   [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


def _coherent_share(scene: RaycastingScene, o: np.ndarray, d: np.ndarray) -> float:
    """The share of chunks of PACKET consecutive rays that take the packet walk."""
    top = scene._tree().packed.top
    spread = packet_spread_limit(top.bounds, top.child)
    rr, idx = np.empty(_NROW * PACKET), np.empty(PACKET, np.int64)
    lo, hi = np.zeros(len(o)), np.full(len(o), np.inf)
    chunks = len(o) // PACKET
    return sum(load_chunk(c, o, d, lo, hi, 0, idx, rr, spread)[1] for c in range(chunks)) / chunks


def _one_by_one(scene: RaycastingScene, o: np.ndarray, d: np.ndarray):
    """Counts and lists of each ray traced alone (a batch of one ray never makes a packet)."""
    counts = np.array([scene.count_intersections(o[i:i + 1], d[i:i + 1])[0] for i in range(len(o))])
    lists = [scene.list_intersections(o[i:i + 1], d[i:i + 1]) for i in range(len(o))]
    return counts, {k: np.concatenate([x[k] for x in lists]) for k in ("t_hit", "geometry_ids", "primitive_ids",
                                                                        "primitive_uvs")}


def test_cube_counts_are_two_through_it_and_zero_beside_it_also_along_its_edges():
    """Orthographic rays along -z on a grid through the cube's faces, edges and vertices (x, y in [-1.5, 1.5]
    step 1/32, so rows at exactly +-1 run along its edges): 2 crossings strictly inside the square, also through
    the diagonals every face is split along, 0 outside; on the square's boundary the watertight test's tie-break
    gives 0 or 2, never 1."""
    s = RaycastingScene()
    s.add_triangles(CUBE_V, CUBE_F)
    xs = np.arange(-1.5, 1.5001, 1 / 32)
    x, y = np.meshgrid(xs, xs)
    o = np.stack([x.ravel(), y.ravel(), np.full(x.size, 5.0)], -1)
    d = np.broadcast_to([0.0, 0.0, -1.0], o.shape).copy()
    counts = s.count_intersections(o, d)
    inside = (np.abs(o[:, 0]) < 1) & (np.abs(o[:, 1]) < 1)
    outside = (np.abs(o[:, 0]) > 1) | (np.abs(o[:, 1]) > 1)
    assert (counts[inside] == 2).all() and (counts[outside] == 0).all()
    assert np.isin(counts[~inside & ~outside], [0, 2]).all()
    lists = s.list_intersections(o, d)
    np.testing.assert_allclose(lists["t_hit"], np.tile([4.0, 6.0], int(counts.sum()) // 2))
    assert _coherent_share(s, o, d) > 0.5


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.booleans(), st.booleans())
@example(530156, False, False)
def test_packets_give_the_one_ray_walks_hits(seed, ortho, placed):
    """A random triangle soup (placed twice, one copy mirrored, beside a sphere, when `placed`), camera rays in
    image order: counts and lists equal those of each ray traced alone, to the bit, and many chunks are packets."""
    rng = np.random.default_rng(seed)
    n = 300
    v = rng.uniform(-2, 2, (n, 3, 3))
    v[:, 1:] = v[:, :1] + rng.normal(scale=0.5, size=(n, 2, 3))
    s = RaycastingScene()
    g = s.add_triangles(v.reshape(-1, 3), np.arange(3 * n).reshape(-1, 3))
    if placed:
        m = np.eye(4)
        m[:3, :3] = np.diag([-1.0, 1.0, 1.0]) @ np.linalg.qr(rng.normal(size=(3, 3)))[0]
        m[:3, 3] = rng.uniform(-1, 1, 3)
        s.add_instance(g, m)
        s.add_sphere(rng.uniform(-1, 1, 3), float(rng.uniform(0.3, 1.0)))
    o, d = pinhole_rays(rng, RES, ortho, ortho_span=1.5)
    assert _coherent_share(s, o, d) > 0.2  # a pinhole whose view straddles a sign change of a direction: ~0.48
    counts, lists = _one_by_one(s, o, d)
    np.testing.assert_array_equal(s.count_intersections(o, d), counts)
    batch = s.list_intersections(o, d)
    for k, x in lists.items():
        np.testing.assert_array_equal(batch[k], x)
    assert counts.sum() > 0
