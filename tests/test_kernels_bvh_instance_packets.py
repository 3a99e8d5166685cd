"""Issue 9, item 4: camera-ray tiles through meshes placed more than once take packets, with the one-ray answers."""

from __future__ import annotations

import os

import numpy as np
from conftest import pinhole_rays
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from durer import RaycastingScene
from durer.accel.bvh import Shape, TwoLevelBVH
from durer.kernels.bvh.chunks import _NROW, chunk_rays, packet_setup
from durer.kernels.bvh.instance_packets import any_hit_instances, closest_hit_instances
from durer.kernels.bvh.layout import PACKET, packet_spread_limit
from durer.kernels.threads import run_blocks

RES = 48


def _placement(rng: np.random.Generator, mirror: bool) -> np.ndarray:
    """A random rotation, scale (uniform or not) and move; mirrored in x when asked."""
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    m = np.eye(4)
    m[:3, :3] = q @ np.diag(rng.uniform(0.5, 1.5, 3) if rng.random() < 0.5 else np.full(3, rng.uniform(0.5, 1.5)))
    if mirror:
        m[:3, :3] = m[:3, :3] @ np.diag([-1.0, 1.0, 1.0])
    m[:3, 3] = rng.uniform(-2.5, 2.5, 3)
    return m


def _scene(rng: np.random.Generator, n_tri: int, copies: int, sphere: bool) -> TwoLevelBVH:
    """A random mesh placed `copies` times (one mirrored), and a sphere placed twice when asked: every shape is
    shared, so the two-level kernels trace it."""
    v = rng.uniform(-1, 1, (n_tri, 3, 3))
    v[:, 1:] = v[:, :1] + rng.normal(scale=0.3, size=(n_tri, 2, 3))
    shapes = [Shape.mesh(v)]
    placed = [(0, _placement(rng, k == 1)) for k in range(copies)]
    if sphere:
        shapes.append(Shape.sphere(rng.uniform(-0.5, 0.5, 3), float(rng.uniform(0.3, 1.0))))
        placed += [(1, _placement(rng, False)) for _ in range(2)]
    return TwoLevelBVH(shapes, placed)


def _camera(rng: np.random.Generator, ortho: bool) -> tuple[np.ndarray, np.ndarray]:
    """RES x RES camera rays in image order from a random eye towards the origin (orthographic: parallel)."""
    return pinhole_rays(rng, RES, ortho, ortho_span=3.0)


def _closest(tree: TwoLevelBVH, o, d, lo, hi, width: int):
    n = len(o)
    out = (np.empty(n), np.empty(n, np.int32), np.empty(n, np.int8), np.empty(n, np.int32), np.empty(n),
           np.empty(n))
    run_blocks(closest_hit_instances, n, o, d, lo, hi, *tree.packed.args, width, *out)
    return out


def _any(tree: TwoLevelBVH, o, d, lo, hi, width: int) -> np.ndarray:
    out = np.zeros(len(o), np.bool_)
    run_blocks(any_hit_instances, len(o), o, d, lo, hi, *tree.packed.args, width, out)
    return out


def _one_by_one(fn, tree, o, d, lo, hi):
    """The kernel's answers for each ray traced alone (a chunk of one ray never makes a packet): the one-ray
    two-level walk."""
    parts = [fn(tree, o[i:i + 1], d[i:i + 1], lo[i:i + 1], hi[i:i + 1], 0) for i in range(len(o))]
    if isinstance(parts[0], tuple):
        return tuple(np.concatenate([p[j] for p in parts]) for j in range(len(parts[0])))
    return np.concatenate(parts)


def _coherent_tiles(tree: TwoLevelBVH, o, d, lo, hi) -> float:
    """The share of the image's 4 x 4 tiles that go through the top-level tree as packets."""
    rr, idx = np.empty(_NROW * PACKET), np.empty(PACKET, np.int64)
    spread = packet_spread_limit(tree.packed.top.bounds, tree.packed.top.child)
    tiles = len(o) // PACKET
    coherent = 0
    for c in range(tiles):
        m = chunk_rays(c, len(o), RES, idx)
        coherent += bool(packet_setup(o, d, lo, hi, idx, m, rr, spread)[0])
    return coherent / tiles


@settings(max_examples=int(os.environ.get('HYP_N', 12)), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(20, 300), copies=st.integers(2, 5), sphere=st.booleans(),
       ortho=st.booleans())
def test_instance_packets_give_the_one_ray_answers_to_the_bit(seed, n_tri, copies, sphere, ortho):
    """Camera tiles through randomly placed (rotated, scaled, mirrored) instances: t, instance, kind, primitive
    and u, v of the packet path equal those of each ray traced alone, to the bit; any-hit alike."""
    rng = np.random.default_rng(seed)
    tree = _scene(rng, n_tri, copies, sphere)
    o, d = _camera(rng, ortho)
    lo = np.full(len(o), -np.inf if ortho else 1e-4)
    hi = np.where(rng.random(len(o)) < 0.3, rng.uniform(5.0, 12.0, len(o)), np.inf)
    assert _coherent_tiles(tree, o, d, lo, hi) > 0.25  # the packet path is what is being tested
    got = _closest(tree, o, d, lo, hi, RES)
    assume((got[2] != 0).sum() > 10)  # hits to compare (a scene of 20 small triangles can show fewer: seed 11659)
    ref = _one_by_one(_closest, tree, o, d, lo, hi)
    for name, a, b in zip(("t", "instance", "kind", "prim", "u", "v"), got, ref, strict=True):
        np.testing.assert_array_equal(a, b, err_msg=name)
    short = rng.uniform(0.0, 12.0, len(o))
    np.testing.assert_array_equal(_any(tree, o, d, lo, short, RES), _one_by_one(_any, tree, o, d, lo, short))
    # consecutive rays (width 0: chunks of 16 along the rows) take packets too, with the same answers
    for a, b in zip(_closest(tree, o, d, lo, hi, 0), ref, strict=True):
        np.testing.assert_array_equal(a, b)


def test_cast_rays_of_an_image_through_instances_equal_the_rays_one_by_one():
    """RaycastingScene: a mesh placed three times (add_instance, one mirrored) cast as an (H, W, 6) image of
    camera rays (4 x 4 tile packets) gives every output of the same rays shuffled (one ray at a time), to the bit."""
    rng = np.random.default_rng(12)
    v = rng.uniform(-1, 1, (400, 3))
    f = rng.integers(0, 400, (600, 3))
    scene = RaycastingScene()
    first = scene.add_triangles(v, f, transform=_placement(rng, False))
    scene.add_instance(first, _placement(rng, True))
    scene.add_instance(first, _placement(rng, False))
    rays = RaycastingScene.create_rays_pinhole(45, [0.0, 0.0, 0.0], [0.5, 7.0, 6.0], [0, 0, 1], 64, 48)
    flat = rays.reshape(-1, 6)
    perm = rng.permutation(len(flat))
    a = scene.cast_rays(rays)
    b = scene.cast_rays(flat[perm])
    assert 0.1 < np.isfinite(a["t_hit"]).mean() < 0.95
    for key in ("t_hit", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"):
        back = np.empty_like(b[key])
        back[perm] = b[key]
        np.testing.assert_array_equal(a[key].reshape(back.shape), back, err_msg=key)
    occ = np.empty(len(flat), np.bool_)
    occ[perm] = scene.test_occlusions(flat[perm], t_max=8.0)
    np.testing.assert_array_equal(scene.test_occlusions(rays, t_max=8.0).reshape(-1), occ)
