"""BVHAccelerator against BruteForce (random scenes) and against Embree (the bunny); thread independence."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from conftest import MESHES, pinhole_rays
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from durer.accel.brute import BruteForce
from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.scene.graph import Group, Scene, Transform
from durer.scene.shapes import Plane, Sphere, Triangle, TriangleMesh

BUNNY = MESHES / "bun_zipper.ply"


def _random_scene(rng: np.random.Generator, n_tri: int, n_sph: int, n_plane: int) -> Scene:
    objs: list = []
    if n_tri:
        v = rng.uniform(-3, 3, (n_tri, 3, 3))
        v[:, 1:] = v[:, :1] + rng.normal(scale=0.6, size=(n_tri, 2, 3))
        objs.append(TriangleMesh(v.reshape(-1, 3), np.arange(3 * n_tri).reshape(-1, 3)))
        objs.append(Triangle(*rng.uniform(-3, 3, (3, 3))))
    for _ in range(n_sph):
        s = Sphere(rng.uniform(-3, 3, 3), float(rng.uniform(0.1, 1.0)))
        if rng.random() < 0.5:  # an ellipsoid: non-uniform scale and a rotation
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            m = np.eye(4)
            m[:3, :3] = q @ np.diag(rng.uniform(0.3, 2.0, 3))
            m[:3, 3] = rng.uniform(-1, 1, 3)
            objs.append(Transform(m, s))
        else:
            objs.append(s)
    for _ in range(n_plane):
        objs.append(Plane(rng.normal(size=3), float(rng.uniform(-5, 5))))
    return Scene(camera=None, group=Group(objs))


def _random_rays(rng: np.random.Generator, n: int):
    o = rng.uniform(-6, 6, (n, 3))
    d = rng.uniform(-3, 3, (n, 3)) - o
    return o, d


def _assert_same(h, ref):
    np.testing.assert_array_equal(h.kind, ref.kind)
    np.testing.assert_allclose(h.t, ref.t, rtol=1e-12)
    same_prim = h.prim == ref.prim
    # a different primitive is only allowed on an exact tie in t
    assert np.all(same_prim | (h.t == ref.t))
    m = same_prim & (h.kind == 1)
    np.testing.assert_allclose(h.u[m], ref.u[m], atol=1e-12)
    np.testing.assert_allclose(h.v[m], ref.v[m], atol=1e-12)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(0, 300), n_sph=st.integers(0, 12),
       n_plane=st.integers(0, 2), ortho=st.booleans())
def test_bvh_equals_brute_force_on_random_scenes(seed, n_tri, n_sph, n_plane, ortho):
    rng = np.random.default_rng(seed)
    cs = compile_scene(_random_scene(rng, n_tri, n_sph, n_plane))
    bvh, brute = BVHAccelerator(cs), BruteForce(cs)
    o, d = _random_rays(rng, 500)
    t_min = -np.inf if ortho else 1e-4
    _assert_same(bvh.closest_hit(o, d, t_min=t_min), brute.closest_hit(o, d, t_min=t_min))
    t_max = rng.uniform(0.0, 2.0, len(o))
    np.testing.assert_array_equal(bvh.any_hit(o, d, t_min, t_max), brute.any_hit(o, d, t_min, t_max))


def _pinhole_rays(rng: np.random.Generator, res: int, ortho: bool):
    """res x res camera rays in image order (conftest.pinhole_rays: orthographic ones 4 wide on each side)."""
    return pinhole_rays(rng, res, ortho)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 400), n_sph=st.integers(0, 6),
       n_plane=st.integers(0, 1), ortho=st.booleans())
def test_bvh_equals_brute_force_on_coherent_rays(seed, n_tri, n_sph, n_plane, ortho):
    """Camera rays go through the packet traversal: same t (to the bit), kinds and hits as brute force."""
    rng = np.random.default_rng(seed)
    cs = compile_scene(_random_scene(rng, n_tri, n_sph, n_plane))
    bvh, brute = BVHAccelerator(cs), BruteForce(cs)
    o, d = _pinhole_rays(rng, 48, ortho)
    t_min = -np.inf if ortho else 1e-4
    h, ref = bvh.closest_hit(o, d, t_min=t_min), brute.closest_hit(o, d, t_min=t_min)
    _assert_same(h, ref)
    np.testing.assert_array_equal(h.t, ref.t)
    t_max = rng.uniform(0.0, 12.0, len(o))
    np.testing.assert_array_equal(bvh.any_hit(o, d, t_min, t_max), brute.any_hit(o, d, t_min, t_max))


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), n_tri=st.integers(1, 400), n_sph=st.integers(0, 6), ortho=st.booleans())
def test_tile_order_changes_nothing_but_speed(seed, n_tri, n_sph, ortho):
    """Rays said to form an image (width > 0) are traced in 4 x 4 tiles; every output stays where it was."""
    rng = np.random.default_rng(seed)
    cs = compile_scene(_random_scene(rng, n_tri, n_sph, 0))
    bvh, brute = BVHAccelerator(cs), BruteForce(cs)
    o, d = _pinhole_rays(rng, 48, ortho)
    t_min = -np.inf if ortho else 1e-4
    h, ref = bvh.closest_hit(o, d, t_min=t_min, width=48), brute.closest_hit(o, d, t_min=t_min)
    _assert_same(h, ref)
    np.testing.assert_array_equal(h.t, ref.t)
    t_max = rng.uniform(0.0, 12.0, len(o))
    np.testing.assert_array_equal(bvh.any_hit(o, d, t_min, t_max, width=48), brute.any_hit(o, d, t_min, t_max))


def test_width_that_does_not_tile_the_rays_is_ignored():
    from durer.kernels.bvh.trace import image_width

    assert image_width((8, 12)) == 12 and image_width((2, 8, 12)) == 12
    assert image_width((6, 12)) == 0 and image_width((8, 10)) == 0 and image_width((64,)) == 0
    cs = compile_scene(Scene(camera=None, group=Group([Sphere(np.array([0, 0, 5.0]), 1.0)])))
    o, d = np.zeros((10, 3)), np.tile([0.0, 0.0, 1.0], (10, 1))
    for width in (0, 4, 5, -4):  # 10 rays are no whole rows of 4 x 4 tiles: traced in their own order
        assert (BVHAccelerator(cs).closest_hit(o, d, width=width).t == 4.0).all()


def test_empty_scene_and_single_primitive():
    o, d = np.zeros((3, 3)), np.array([[0, 0, 1.0], [0, 1.0, 0], [1.0, 0, 0]])
    h = BVHAccelerator(compile_scene(Scene(camera=None, group=Group([])))).closest_hit(o, d)
    assert not h.hit.any() and np.isinf(h.t).all() and (h.prim == -1).all()
    cs = compile_scene(Scene(camera=None, group=Group([Sphere(np.array([0, 0, 5.0]), 1.0)])))
    h = BVHAccelerator(cs).closest_hit(o, d)
    assert h.kind.tolist() == [2, 0, 0] and h.t[0] == pytest.approx(4.0)


def test_axis_parallel_rays_through_box_faces():
    """Zero direction components with origins exactly on a slab plane must not be culled (no 0 * inf NaN)."""
    tri = TriangleMesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]]))
    cs = compile_scene(Scene(camera=None, group=Group([tri])))
    o = np.array([[0.0, 0.25, 1.0], [0.25, 0.0, 1.0], [0.0, 0.0, 1.0]])
    d = np.array([[0.0, 0.0, -1.0]] * 3)
    _assert_same(BVHAccelerator(cs).closest_hit(o, d), BruteForce(cs).closest_hit(o, d))


def test_packets_of_axis_parallel_rays_on_box_faces():
    """Packets (4 x 4 tiles) whose rays have zero direction components and origins exactly on the planes of
    the tree's boxes: the packet's interval bounds must not cull what a single ray would hit."""
    rng = np.random.default_rng(5)
    grid = np.round(rng.uniform(0, 4, (300, 3, 3)) * 4) / 4  # vertices on a quarter grid: shared box planes
    mesh = TriangleMesh(grid.reshape(-1, 3), np.arange(900).reshape(-1, 3))
    cs = compile_scene(Scene(camera=None, group=Group([mesh])))
    s = np.arange(16) / 4.0  # origins on the same quarter grid
    x, y = np.meshgrid(s, s)
    for axis in range(3):
        o = np.zeros((16, 16, 3))
        o[..., (axis + 1) % 3], o[..., (axis + 2) % 3] = x, y
        o[..., axis] = -1.0
        d = np.zeros((16, 16, 3))
        d[..., axis] = 1.0
        o, d = o.reshape(-1, 3), d.reshape(-1, 3)
        h, ref = BVHAccelerator(cs).closest_hit(o, d, width=16), BruteForce(cs).closest_hit(o, d)
        assert ref.hit.mean() > 0.2
        _assert_same(h, ref)
        np.testing.assert_array_equal(BVHAccelerator(cs).any_hit(o, d, width=16), ref.hit)


def test_same_results_on_one_and_two_threads():
    rng = np.random.default_rng(3)
    cs = compile_scene(_random_scene(rng, 2000, 20, 1))
    bvh = BVHAccelerator(cs)
    for o, d, width in (_random_rays(rng, 20_000) + (0,),          # one ray at a time
                        _pinhole_rays(rng, 128, False) + (128,)):  # packets, 4 x 4 tiles
        before = numba.get_num_threads()
        try:
            numba.set_num_threads(1)
            h1, a1 = bvh.closest_hit(o, d, width=width), bvh.any_hit(o, d, width=width)
            numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
            h2, a2 = bvh.closest_hit(o, d, width=width), bvh.any_hit(o, d, width=width)
        finally:
            numba.set_num_threads(before)
        assert (h1.kind == 1).mean() > 0.05  # triangles are hit, not only the plane
        for name in ("t", "kind", "prim", "u", "v"):
            np.testing.assert_array_equal(getattr(h1, name), getattr(h2, name))
        np.testing.assert_array_equal(a1, a2)


@pytest.fixture(scope="module")
def bunny():
    if not BUNNY.exists():
        pytest.skip(f"Stanford bunny not found at {BUNNY} (the shared data directory ../shared is absent)")
    import trimesh

    return trimesh.load(BUNNY, process=False)


def _rays_at(mesh, n: int, rng):
    """Rays from a sphere around the mesh towards random points of its bounding box: most hit, many graze."""
    lo, hi = mesh.bounds
    c, r = (lo + hi) / 2, np.linalg.norm(hi - lo)
    o = rng.normal(size=(n, 3))
    o = c + r * o / np.linalg.norm(o, axis=1, keepdims=True)
    return o, rng.uniform(lo, hi, (n, 3)) - o


def test_bvh_equals_brute_force_on_bunny(bunny):
    cs = compile_scene(Scene(camera=None, group=Group([TriangleMesh(bunny.vertices, bunny.faces)])))
    o, d = _rays_at(bunny, 1000, np.random.default_rng(5))
    _assert_same(BVHAccelerator(cs).closest_hit(o, d), BruteForce(cs).closest_hit(o, d))


def test_agrees_with_embree_on_a_million_rays(bunny):
    """Issue 3: same hit/miss on >= 99.99% of a million rays and t within 1e-4 relative (Embree is float32)."""
    embree = pytest.importorskip("embreex.rtcore_scene", reason="embreex not installed (pip install durer[embree])")
    from embreex.mesh_construction import TriangleMesh as EmbreeMesh

    o, d = _rays_at(bunny, 1_000_000, np.random.default_rng(11))
    cs = compile_scene(Scene(camera=None, group=Group([TriangleMesh(bunny.vertices, bunny.faces)])))
    h = BVHAccelerator(cs).closest_hit(o, d)
    scene = embree.EmbreeScene()
    EmbreeMesh(scene, bunny.vertices[bunny.faces].astype(np.float32))
    e = scene.run(o.astype(np.float32), d.astype(np.float32), output=1)
    e_hit = e["geomID"] >= 0
    assert 0.3 < e_hit.mean() < 0.95
    assert (e_hit == h.hit).mean() >= 0.9999
    both = e_hit & h.hit
    np.testing.assert_allclose(h.t[both], e["tfar"][both], rtol=1e-4)


def _instanced_scene(mesh: TriangleMesh, copies: int, separate: bool = False) -> Scene:
    """`mesh` placed `copies` times (the second mirrored in x, the others rotated, scaled and moved), with
    materials 0/1 alternating, each a TriangleMesh of the same file, as the course parser makes them (stored once);
    separate=True gives every placement its own arrays and no file (flattened, as before instancing)."""
    rng = np.random.default_rng(7)
    objs: list = [Sphere((0, 0, -4), 1.5, material=1), Triangle((-5, -5, -6), (5, -5, -6), (0, 5, -6), material=0)]
    for i in range(copies):
        m = np.eye(4)
        if i == 1:
            m[0, 0] = -1.0  # a mirror
        elif i:
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            m[:3, :3] = q * rng.uniform(0.5, 1.5)
        m[:3, 3] = rng.uniform(-2, 2, 3)
        obj = TriangleMesh(mesh.vertices.copy(), mesh.faces.copy(), material=i % 2) if separate else \
            TriangleMesh(mesh.vertices, mesh.faces, material=i % 2, source="mesh.obj")
        objs.append(Transform(m, obj))
    return Scene(camera=None, group=Group(objs))


def _small_mesh(rng) -> TriangleMesh:
    v = rng.uniform(-1, 1, (60, 3))
    f = rng.integers(0, 60, (80, 3))
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    return TriangleMesh(v, f)


def test_a_mesh_placed_twice_is_stored_once_and_hits_as_flattened():
    """Issue 3, item 1: the renderer's BVH keeps a mesh used more than once as one stored mesh + instances
    (one mirrored here) and answers with the same Hits (virtual triangle ids) as the flattened scene."""
    from durer.accel.hits import geometric_normals, hit_materials

    rng = np.random.default_rng(3)
    mesh = _small_mesh(rng)
    inst = compile_scene(_instanced_scene(mesh, 3))
    flat = compile_scene(_instanced_scene(mesh, 3, separate=True))
    assert len(inst.mesh_triangles) == 1 and len(inst.instance_mesh) == 3 and len(flat.instance_mesh) == 0
    assert inst.counts == flat.counts
    np.testing.assert_array_equal(inst.flat.triangles, flat.triangles)  # same virtual numbering, same vertices
    np.testing.assert_array_equal(inst.triangle(np.arange(inst.n_triangles)), flat.triangles)
    np.testing.assert_array_equal(inst.triangle_materials(np.arange(inst.n_triangles)), flat.triangle_material)
    o, d = _random_rays(rng, 4000)
    for t_min in (1e-4, -np.inf):
        h = BVHAccelerator(inst).closest_hit(o, d, t_min=t_min)
        ref = BVHAccelerator(flat).closest_hit(o, d, t_min=t_min)
        _assert_same(h, ref)
        _assert_same(BruteForce(inst).closest_hit(o, d, t_min=t_min), ref)
        assert (h.kind == 1).sum() > 500 and (h.prim >= inst.instance_offset[1]).sum() > 100  # the mirror is hit
        p = o + h.t[:, None] * d
        np.testing.assert_allclose(geometric_normals(inst, h, p), geometric_normals(flat, ref, p), atol=1e-9)
        np.testing.assert_array_equal(hit_materials(inst, h), hit_materials(flat, ref))
    t_max = rng.uniform(0.0, 2.0, len(o))
    np.testing.assert_array_equal(BVHAccelerator(inst).any_hit(o, d, 1e-4, t_max),
                                  BVHAccelerator(flat).any_hit(o, d, 1e-4, t_max))


def test_a_mesh_placed_again_costs_little_memory():
    rng = np.random.default_rng(5)
    v = rng.uniform(-1, 1, (3000, 3))
    mesh = TriangleMesh(v, np.arange(3000).reshape(-1, 3))
    size = {}
    for copies in (2, 10):
        cs = compile_scene(_instanced_scene(mesh, copies))
        size[copies] = cs.nbytes + BVHAccelerator(cs).nbytes
    mesh_bytes = mesh.vertices.nbytes
    assert size[10] - size[2] < 0.1 * mesh_bytes  # eight more placements: a few hundred bytes each


def test_instanced_render_matches_flattened_render():
    import durer
    from durer import DirectionalLight, OrthographicCamera, PhongMaterial

    rng = np.random.default_rng(11)
    mesh = _small_mesh(rng)
    results = []
    for separate in (False, True):
        s = _instanced_scene(mesh, 3, separate=separate)
        scene = Scene(camera=OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=8),
                      group=s.group, materials=[PhongMaterial(diffuse_color=(1, 0, 0)),
                                                PhongMaterial(diffuse_color=(0, 1, 0))],
                      lights=[DirectionalLight(direction=(0.3, -0.2, -1), color=(0.8, 0.8, 0.8))],
                      background_color=(0, 0, 1))
        results.append(durer.render(scene, 64, 64, shadows=True))
    a, b = results
    np.testing.assert_array_equal(a.color, b.color)
    np.testing.assert_allclose(a.depth, b.depth, rtol=1e-6)
    np.testing.assert_allclose(a.normals, b.normals, atol=1e-6)


def test_packets_only_for_rays_that_are_close():
    """16 rays make a packet only when, besides sharing direction signs and axis order, their directions lie
    within PACKET_CONE of the first one's and their origins within the spread limit: rays of one octant that fan
    out 40 degrees, or parallel rays from origins far apart, go one by one (a packet's interval bounds would
    sweep most of the tree for them: 175x slower measured on 65k incoherent rays sorted by origin)."""
    from durer.kernels.bvh.chunks import _NROW, packet_setup
    from durer.kernels.bvh.layout import PACKET

    idx = np.arange(PACKET)
    rr = np.empty(_NROW * PACKET)
    lo, hi = np.zeros(PACKET), np.full(PACKET, np.inf)
    o = np.zeros((PACKET, 3))
    s = np.linspace(0.0, 0.1, PACKET)
    close = np.stack([s, 0.5 * s + 0.01, np.ones(PACKET)], 1)          # within 7 degrees
    fan = np.stack([np.linspace(0.01, 0.85, PACKET), np.full(PACKET, 0.02), np.ones(PACKET)], 1)  # 40 degrees
    spread = o.copy()
    spread[:, 0] = np.linspace(0.0, 2.0, PACKET)
    assert packet_setup(o, close, lo, hi, idx, PACKET, rr, 1.0)[0]
    assert not packet_setup(o, fan, lo, hi, idx, PACKET, rr, 1.0)[0]
    assert not packet_setup(spread, close, lo, hi, idx, PACKET, rr, 1.0)[0]
    assert packet_setup(spread, close, lo, hi, idx, PACKET, rr, 2.5)[0]


def test_packet_extremes_are_the_extremes_of_each_rays_own_reciprocals():
    """packet_setup takes the reciprocal directions' extremes as 1 / (extreme direction) (6 divisions a packet):
    they must be, to the bit, the extremes of every ray's own 1 / d (a zero component as 1e-300, as the one-ray
    slab test takes it), and the origins' and t_min's extremes those of the rays."""
    from durer.kernels.bvh.chunks import _EXT, _EXT_INV, _EXT_TMIN, _NROW, packet_setup
    from durer.kernels.bvh.layout import PACKET

    rng = np.random.default_rng(12)
    idx = rng.permutation(PACKET)
    d = np.stack([rng.uniform(0.0, 0.05, PACKET), rng.uniform(-0.3, -0.2, PACKET), rng.uniform(0.9, 1.1, PACKET)], 1)
    d[5, 0] = 0.0
    o = rng.uniform(-0.1, 0.1, (PACKET, 3))
    lo, hi = rng.uniform(0.0, 0.5, PACKET), np.full(PACKET, np.inf)
    rr = np.empty(_NROW * PACKET)
    coherent, nrx, nry, nrz = packet_setup(o, d, lo, hi, idx, PACKET, rr, 1.0)[:4]
    assert coherent and (nrx, nry, nrz) == (0, 16, 8)
    ext = rr[_EXT:_EXT + PACKET]
    inv = 1.0 / np.where(d != 0.0, d, 1e-300)
    for axis in range(3):
        assert (ext[2 * axis], ext[2 * axis + 1]) == (o[:, axis].min(), o[:, axis].max())
        assert ext[_EXT_INV + 2 * axis] == inv[:, axis].min() and ext[_EXT_INV + 2 * axis + 1] == inv[:, axis].max()
    assert ext[_EXT_INV + 1] == 1.0 / 1e-300 and ext[_EXT_TMIN] == lo.min()


def test_incoherent_rays_sorted_by_octant_and_origin_equal_brute_force():
    """Random rays grouped by direction octant and sorted by origin (a reordered incoherent batch: 16 neighbours
    share signs but not directions) give brute force's hits, closest and any."""
    rng = np.random.default_rng(11)
    cs = compile_scene(_random_scene(rng, 300, 4, 1))
    o, d = _random_rays(rng, 4096)
    order = np.lexsort((o[:, 0], np.argmax(np.abs(d), 1), (d < 0) @ [1, 2, 4]))
    o, d = np.ascontiguousarray(o[order]), np.ascontiguousarray(d[order])
    bvh, brute = BVHAccelerator(cs), BruteForce(cs)
    _assert_same(bvh.closest_hit(o, d), brute.closest_hit(o, d))
    t_max = rng.uniform(0.0, 8.0, len(o))
    np.testing.assert_array_equal(bvh.any_hit(o, d, 0.0, t_max), brute.any_hit(o, d, 0.0, t_max))
