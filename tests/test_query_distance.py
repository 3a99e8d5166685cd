"""RaycastingScene point queries (issue 11): closest points, distance, signed distance, occupancy, instances,
threads, Open3D names and every ValueError path."""

from __future__ import annotations

import numba
import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.query import INVALID_ID, RaycastingScene


def brute_closest(tris: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(distance, closest point) of each point over triangles (F, 3, 3), vectorised NumPy: the plane projection
    where it falls inside a triangle, else the nearest point of its three edges (independent of the kernel)."""
    a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
    p = points[:, None, :]

    def seg(x, y):
        e = y - x
        t = np.clip(np.einsum("nfk,fk->nf", p - x, e) / np.maximum(np.einsum("fk,fk->f", e, e), 1e-300), 0, 1)
        return x + t[..., None] * e

    cands = [seg(a, b), seg(b, c), seg(c, a)]
    n = np.cross(b - a, c - a)
    nn = np.einsum("fk,fk->f", n, n)
    q = p - (np.einsum("nfk,fk->nf", p - a, n) / np.maximum(nn, 1e-300))[..., None] * n
    # barycentric inside test of the projection
    v0, v1, v2 = b - a, c - a, q - a
    d00, d01, d11 = (v0 * v0).sum(-1), (v0 * v1).sum(-1), (v1 * v1).sum(-1)
    d20, d21 = (v2 * v0).sum(-1), (v2 * v1).sum(-1)
    den = d00 * d11 - d01 * d01
    v = (d11 * d20 - d01 * d21) / np.where(den > 0, den, 1)
    w = (d00 * d21 - d01 * d20) / np.where(den > 0, den, 1)
    inside = (den > 1e-300) & (v >= 0) & (w >= 0) & (v + w <= 1)
    cands.append(np.where(inside[..., None], q, np.inf))
    allc = np.stack(cands)                                   # (4, N, F, 3)
    d = np.linalg.norm(allc - p[None], axis=-1).reshape(4, len(points), -1)
    k = d.reshape(-1, len(points), d.shape[-1]).transpose(1, 0, 2).reshape(len(points), -1).argmin(axis=1)
    cand, face = np.divmod(k, d.shape[-1])
    best = allc[cand, np.arange(len(points)), face]
    return np.linalg.norm(best - points, axis=1), best


def _scene(mesh, transform=None) -> RaycastingScene:
    s = RaycastingScene()
    s.add_triangles(mesh.vertices, mesh.faces, transform)
    return s


@pytest.fixture(scope="module")
def soup():
    rng = np.random.default_rng(0)
    tris = rng.normal(size=(60, 3, 3))
    tris[:30] = tris[:30] * 0.3 + rng.normal(size=(30, 1, 3))  # some small ones, some large and crossing
    return tris


def test_closest_points_equal_brute_force_on_a_triangle_soup(soup):
    s = RaycastingScene()
    s.add_triangles(soup.reshape(-1, 3), np.arange(len(soup) * 3).reshape(-1, 3))
    pts = np.random.default_rng(1).normal(size=(3000, 3)) * 2
    r = s.compute_closest_points(pts)
    ref_d, ref_q = brute_closest(soup, pts)
    np.testing.assert_allclose(np.linalg.norm(r["points"] - pts, axis=1), ref_d, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(s.compute_distance(pts), ref_d, rtol=1e-12, atol=1e-12)
    # the reported triangle and weights reproduce the point, which is on that triangle
    t = soup[r["primitive_ids"]]
    u, v = r["primitive_uvs"].T
    np.testing.assert_allclose((1 - u - v)[:, None] * t[:, 0] + u[:, None] * t[:, 1] + v[:, None] * t[:, 2],
                               r["points"], atol=1e-12)
    assert (r["geometry_ids"] == 0).all()
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    np.testing.assert_allclose(r["primitive_normals"], n / np.linalg.norm(n, axis=1, keepdims=True), atol=1e-12)


def test_closest_points_equal_trimesh():
    pytest.importorskip("rtree", reason="trimesh.proximity needs rtree")
    pytest.importorskip("scipy", reason="trimesh.proximity needs scipy")
    mesh = trimesh.creation.torus(1.0, 0.3, major_sections=24, minor_sections=12)
    pts = np.random.default_rng(2).uniform(-2, 2, (2000, 3))
    q, dist, _ = trimesh.proximity.closest_point(mesh, pts)
    r = _scene(mesh).compute_closest_points(pts)
    np.testing.assert_allclose(np.linalg.norm(r["points"] - pts, axis=1), dist, atol=1e-9)
    np.testing.assert_allclose(r["points"], q, atol=1e-6)  # ties on shared edges may pick either triangle


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31), st.integers(0, 2))
def test_points_on_vertices_edges_and_faces_have_distance_zero(seed, where):
    rng = np.random.default_rng(seed)
    mesh = trimesh.creation.icosphere(subdivisions=1)
    mesh.vertices += rng.normal(size=mesh.vertices.shape) * 0.05
    tris = mesh.vertices[mesh.faces]
    f = rng.integers(0, len(tris), 50)
    if where == 0:
        pts = tris[f, rng.integers(0, 3, 50)]
    elif where == 1:
        t = rng.uniform(0, 1, (50, 1))
        pts = tris[f, 0] + t * (tris[f, 1] - tris[f, 0])
    else:
        w = rng.dirichlet([1, 1, 1], 50)
        pts = np.einsum("nk,nkd->nd", w, tris[f])
    r = _scene(mesh).compute_closest_points(pts)
    np.testing.assert_allclose(r["points"], pts, atol=1e-14)
    assert np.all(_scene(mesh).compute_distance(pts) <= 1e-14)


def test_leading_shape_float32_and_noncontiguous():
    s = _scene(trimesh.creation.icosphere(subdivisions=2))
    pts = np.random.default_rng(3).normal(size=(4, 5, 6))[..., ::2]  # a non-contiguous (4, 5, 3) view
    r = s.compute_closest_points(pts)
    assert r["points"].shape == (4, 5, 3) and r["primitive_uvs"].shape == (4, 5, 2)
    assert r["geometry_ids"].shape == (4, 5) and r["geometry_ids"].dtype == np.uint32  # Open3D's id type
    assert r["primitive_ids"].dtype == np.uint32 and r["points"].dtype == np.float64
    d32 = s.compute_distance(pts.astype(np.float32))  # float32 points, float32 answers (Open3D's types)
    assert d32.dtype == np.float32 and d32.shape == (4, 5)
    np.testing.assert_allclose(d32, s.compute_distance(pts), rtol=1e-5, atol=1e-6)
    r32 = s.compute_closest_points(pts.astype(np.float32))
    assert r32["points"].dtype == np.float32 and r32["primitive_normals"].dtype == np.float32
    assert s.compute_signed_distance(np.zeros((0, 3))).shape == (0,)
    assert s.compute_occupancy(pts).dtype == np.float64  # float64 points stay float64
    assert s.compute_occupancy(pts.astype(np.float32)).dtype == np.float32


def test_analytic_sphere_and_ellipsoid():
    s = RaycastingScene()
    s.add_sphere([1.0, 2.0, 3.0], 0.5)
    pts = np.random.default_rng(4).normal(size=(500, 3)) + [1, 2, 3]
    exact = np.linalg.norm(pts - [1, 2, 3], axis=1) - 0.5
    np.testing.assert_allclose(s.compute_signed_distance(pts), exact, atol=1e-12)
    np.testing.assert_allclose(s.compute_occupancy(pts), exact < 0)
    r = s.compute_closest_points(pts)
    np.testing.assert_allclose(r["primitive_normals"], (pts - [1, 2, 3]) / (exact + 0.5)[:, None], atol=1e-12)
    assert (r["geometry_ids"] == 0).all() and (r["primitive_ids"] == 0).all()
    # an ellipsoid (non-uniform scale, then a rotation): the closest point is on it and the distance minimal
    m = np.diag([3.0, 1.0, 0.5, 1.0])
    m[:3, :3] = trimesh.transformations.rotation_matrix(0.7, [1, 1, 0])[:3, :3] @ m[:3, :3]
    m[:3, 3] = [0.5, -1, 2]
    e = RaycastingScene()
    e.add_sphere([0, 0, 0], 1.0, transform=m)
    q = e.compute_closest_points(pts)["points"]
    local = (q - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T
    np.testing.assert_allclose(np.linalg.norm(local, axis=1), 1.0, atol=1e-12)
    dense = trimesh.creation.icosphere(subdivisions=6).vertices @ m[:3, :3].T + m[:3, 3]
    sampled = np.min(np.linalg.norm(pts[:100, None] - dense[None], axis=2), axis=1)
    d = e.compute_distance(pts[:100])
    assert np.all(d <= sampled + 1e-12) and np.all(d >= sampled - 0.01)
    inside = np.linalg.norm((pts - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T, axis=1) < 1
    np.testing.assert_array_equal(e.compute_signed_distance(pts) < 0, inside)


def test_signed_distance_of_a_box_is_analytic():
    box = trimesh.creation.box(extents=[2.0, 1.0, 0.5])
    pts = np.random.default_rng(5).uniform(-2, 2, (4000, 3))
    q = np.abs(pts) - [1.0, 0.5, 0.25]
    exact = np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)
    s = _scene(box)
    np.testing.assert_allclose(s.compute_signed_distance(pts), exact, atol=1e-12)
    np.testing.assert_allclose(s.compute_signed_distance(pts, method="parity", nsamples=3), exact, atol=1e-12)
    np.testing.assert_array_equal(s.compute_occupancy(pts), exact < 0)


def test_signed_distance_of_a_torus_within_the_mesh_tolerance():
    R, r = 1.0, 0.35
    mesh = trimesh.creation.torus(R, r, major_sections=128, minor_sections=64)
    pts = np.random.default_rng(6).uniform(-1.6, 1.6, (4000, 3))
    exact = np.hypot(np.hypot(pts[:, 0], pts[:, 1]) - R, pts[:, 2]) - r
    # the polygon's deviation from the true surface: sagitta of the minor and major sections
    tol = r * (1 - np.cos(np.pi / 64)) + (R + r) * (1 - np.cos(np.pi / 128))
    sd = _scene(mesh).compute_signed_distance(pts)
    assert np.abs(sd - exact).max() <= tol
    far = np.abs(exact) > tol
    np.testing.assert_array_equal((sd < 0)[far], (exact < 0)[far])


def test_parity_and_winding_agree_away_from_the_surface_of_closed_meshes():
    meshes = [trimesh.creation.torus(1.0, 0.4), trimesh.creation.capsule(1.0, 0.5),
              trimesh.creation.icosphere(subdivisions=3)]
    pts = np.random.default_rng(7).uniform(-1.6, 1.6, (5000, 3))
    for mesh in meshes:
        s = _scene(mesh)
        d = s.compute_distance(pts)
        away = d > 1e-3
        win = s.compute_occupancy(pts)
        par = s.compute_occupancy(pts, method="parity")
        np.testing.assert_array_equal(win[away], par[away])
        np.testing.assert_array_equal(win[away], mesh.contains(pts[away]))


@pytest.mark.parametrize("kind", ["similarity", "mirror", "non-uniform", "shear"])
def test_instances_equal_moved_vertices(kind):
    rng = np.random.default_rng(8)
    mesh = trimesh.creation.torus(1.0, 0.4, major_sections=16, minor_sections=8)
    m = np.eye(4)
    rot = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
    m[:3, :3] = {"similarity": 1.7 * rot, "mirror": 0.6 * rot @ np.diag([-1.0, 1, 1]),
                 "non-uniform": rot @ np.diag([2.0, 0.5, 1.0]),
                 "shear": rot @ np.array([[1.0, 0.6, 0], [0, 1, 0.3], [0, 0, 1]])}[kind]
    m[:3, 3] = [0.3, -0.2, 1.0]
    inst = RaycastingScene()
    g = inst.add_triangles(mesh.vertices, mesh.faces)
    inst.add_instance(g, m)                       # shared shape: the two-level path
    inst.add_sphere([5.0, 0, 0], 0.5, transform=m)
    moved = RaycastingScene()
    moved.add_triangles(mesh.vertices, mesh.faces)
    moved.add_triangles(mesh.vertices @ m[:3, :3].T + m[:3, 3], mesh.faces)
    moved.add_sphere([5.0, 0, 0], 0.5, transform=m)
    pts = rng.uniform(-4, 6, (3000, 3))
    a, b = inst.compute_closest_points(pts), moved.compute_closest_points(pts)
    np.testing.assert_allclose(np.linalg.norm(a["points"] - pts, axis=1), np.linalg.norm(b["points"] - pts, axis=1),
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(a["geometry_ids"], b["geometry_ids"])
    # ties (points nearest a shared vertex or edge) may name either triangle: each names one the point is on
    world = np.stack([mesh.vertices[mesh.faces], (mesh.vertices @ m[:3, :3].T + m[:3, 3])[mesh.faces]])
    tri = a["geometry_ids"] < 2
    t = world[a["geometry_ids"][tri], a["primitive_ids"][tri]]
    u, v = a["primitive_uvs"][tri].T
    np.testing.assert_allclose((1 - u - v)[:, None] * t[:, 0] + u[:, None] * t[:, 1] + v[:, None] * t[:, 2],
                               a["points"][tri], atol=1e-9)
    same = a["primitive_ids"] == b["primitive_ids"]
    assert same.mean() > 0.5
    np.testing.assert_allclose(a["primitive_normals"][same], b["primitive_normals"][same], atol=1e-9)
    np.testing.assert_allclose(inst.compute_winding_number(pts, beta=np.inf),
                               moved.compute_winding_number(pts, beta=np.inf), atol=1e-9)
    np.testing.assert_array_equal(inst.compute_occupancy(pts), moved.compute_occupancy(pts))


def test_nthreads_and_open3d_names():
    s = _scene(trimesh.creation.icosphere(subdivisions=2))
    pts = np.random.default_rng(9).normal(size=(2000, 3))
    before = numba.get_num_threads()
    one = s.compute_signed_distance(pts, nthreads=1)
    np.testing.assert_array_equal(one, s.compute_signed_distance(pts, nthreads=0))
    np.testing.assert_array_equal(one, s.compute_signed_distance(pts, nthreads=64))  # clamped to the cores
    assert numba.get_num_threads() == before
    rays = np.concatenate([pts * 3, -pts], axis=1)
    np.testing.assert_array_equal(s.test_occlusions(rays, tnear=0.5, tfar=1.5, nthreads=1),
                                  s.test_occlusions(rays, t_min=0.5, t_max=1.5))
    np.testing.assert_array_equal(s.cast_rays(rays, nthreads=1)["t_hit"], s.cast_rays(rays)["t_hit"])
    assert s.count_intersections(rays, nthreads=1).shape == (2000,)
    with pytest.raises(ValueError, match="not both"):
        s.test_occlusions(rays, tnear=0.5, t_min=0.5)
    assert INVALID_ID == RaycastingScene.INVALID_ID == 2**32 - 1  # Open3D's
    empty_hit = s.cast_rays([[10.0, 10, 10, 0, 0, 1]])
    assert empty_hit["geometry_ids"][0] == RaycastingScene.INVALID_ID


def test_open3d_inputs_and_an_empty_scene():
    """nthreads=-1 is automatic (as Open3D takes it); an empty scene answers point queries: nothing is near."""
    s = _scene(trimesh.creation.icosphere(subdivisions=2))
    pts = np.random.default_rng(9).normal(size=(50, 3))
    np.testing.assert_array_equal(s.compute_distance(pts, nthreads=-1), s.compute_distance(pts))
    empty = RaycastingScene()
    assert np.isinf(empty.compute_distance(pts)).all() and np.isinf(empty.compute_signed_distance(pts)).all()
    assert (empty.compute_occupancy(pts) == 0).all() and (empty.compute_winding_number(pts) == 0).all()
    near = empty.compute_closest_points(pts.astype(np.float32))
    assert (near["geometry_ids"] == INVALID_ID).all() and np.isnan(near["points"]).all()
    assert near["points"].dtype == np.float32


def test_repr_says_what_it_holds():
    s = RaycastingScene()
    g = s.add_triangles(np.eye(3), [[0, 1, 2]])
    s.add_instance(g, np.diag([2.0, 2, 2, 1]))
    s.add_sphere([0, 0, 0], 1.0)
    assert repr(s) == ("RaycastingScene(3 geometries: 2 meshes, 1 spheres; 2 triangles (1 stored); "
                       "not built yet)")
    s.compute_distance([[0, 0, 0]])
    assert repr(s).endswith("MiB)") and "3 geometries" in repr(s)


@pytest.mark.parametrize("call, message", [
    (lambda s: s.compute_distance(np.zeros((4, 2))), r"query_points must have shape \(..., 3\)"),
    (lambda s: s.compute_distance([[0, 0, np.nan]]), r"query_points contains NaN or infinity \(point 0\)"),
    (lambda s: s.compute_closest_points([[0, 0, 0], [np.inf, 0, 0]]), r"NaN or infinity \(point 1\)"),
    (lambda s: s.compute_signed_distance(np.array([["a", "b", "c"]])), "numeric array"),
    (lambda s: s.compute_signed_distance(np.zeros((1, 3)), method="rays"), "method must be 'winding' or 'parity'"),
    (lambda s: s.compute_occupancy(np.zeros((1, 3)), method="parity", nsamples=0), "nsamples must be at least 1"),
    (lambda s: s.compute_winding_number(np.zeros((1, 3)), beta=1.0), "beta must be greater than 1"),
    (lambda s: s.compute_winding_number(np.zeros((1, 3)), order=3), "order must be 1 or 2"),
])
def test_value_errors(call, message):
    s = _scene(trimesh.creation.icosphere(subdivisions=1))
    with pytest.raises(ValueError, match=message):
        call(s)
