"""durer.RaycastingScene: Open3D-style batch queries, instancing, and every ValueError path."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import durer
from durer.query import RaycastingScene


@pytest.fixture(scope="module")
def sphere_mesh():
    return trimesh.creation.icosphere(subdivisions=3)


@pytest.fixture(scope="module")
def scene(sphere_mesh):
    s = RaycastingScene()
    s.add_triangles(sphere_mesh.vertices, sphere_mesh.faces)
    s.add_sphere([4.0, 0.0, 0.0], 0.5)
    return s


def _affine(rng) -> np.ndarray:
    m = np.eye(4)
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    m[:3, :3] = q @ np.diag(rng.uniform(0.5, 2.0, 3))
    m[:3, 3] = rng.uniform(-3, 3, 3)
    return m


def test_exported_from_package():
    assert durer.RaycastingScene is RaycastingScene


def test_cast_rays_fields_and_values(scene):
    o = np.array([[0.0, 0.0, 5.0], [4.0, 0.0, 5.0], [0.0, 10.0, 5.0]])
    d = np.array([[0.0, 0.0, -1.0]] * 3)
    r = scene.cast_rays(o, d)
    assert set(r) == {"t_hit", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"}
    assert r["t_hit"][0] == pytest.approx(4.0, abs=0.01) and r["t_hit"][1] == pytest.approx(4.5)
    assert r["t_hit"][2] == np.inf
    assert r["geometry_ids"].tolist() == [0, 1, RaycastingScene.INVALID_ID] and r["geometry_ids"].dtype == np.uint32
    assert r["primitive_ids"][2] == 2**32 - 1 and r["primitive_ids"][1] == 0
    np.testing.assert_allclose(r["primitive_normals"][1], [0, 0, 1])
    assert r["primitive_normals"][0] @ [0, 0, 1] > 0.99  # outward (icosphere winding is counter-clockwise)
    np.testing.assert_array_equal(r["primitive_normals"][2], 0)
    uv = r["primitive_uvs"][0]
    assert 0 <= uv[0] <= 1 and 0 <= uv[1] <= 1 and uv.sum() <= 1


def test_uvs_reconstruct_hit_point(scene, sphere_mesh):
    rng = np.random.default_rng(0)
    o = rng.normal(size=(2000, 3)) * 3
    d = rng.normal(size=(2000, 3)) * 0.1 - o * 0.1
    r = scene.cast_rays(o, d)
    m = r["geometry_ids"] == 0
    tri = sphere_mesh.vertices[sphere_mesh.faces[r["primitive_ids"][m]]]
    u, v = r["primitive_uvs"][m].T
    p = (1 - u - v)[:, None] * tri[:, 0] + u[:, None] * tri[:, 1] + v[:, None] * tri[:, 2]
    np.testing.assert_allclose(p, o[m] + r["t_hit"][m, None] * d[m], atol=1e-9)


def test_leading_shape_six_column_float32_and_noncontiguous(scene):
    rng = np.random.default_rng(1)
    rays = np.zeros((4, 5, 6))
    rays[..., :3] = rng.normal(size=(4, 5, 3)) * 3
    rays[..., 3:] = -rays[..., :3]
    r6 = scene.cast_rays(rays)
    assert r6["t_hit"].shape == (4, 5) and r6["primitive_uvs"].shape == (4, 5, 2)
    assert r6["primitive_normals"].shape == (4, 5, 3)
    r2 = scene.cast_rays(rays[..., :3], rays[..., 3:])  # non-contiguous views
    np.testing.assert_array_equal(r6["t_hit"], r2["t_hit"])
    r32 = scene.cast_rays(rays.astype(np.float32))
    np.testing.assert_array_equal(r32["geometry_ids"], r6["geometry_ids"])
    np.testing.assert_allclose(r32["t_hit"], r6["t_hit"], rtol=1e-5)
    assert scene.test_occlusions(rays).shape == (4, 5)
    assert scene.count_intersections(rays).shape == (4, 5)
    assert scene.cast_rays(np.zeros((0, 6)))["t_hit"].shape == (0,)


def test_t_min_t_max_and_occlusion(scene):
    o, d = np.array([[0.0, 0.0, 5.0]]), np.array([[0.0, 0.0, -1.0]])
    assert scene.test_occlusions(o, d).tolist() == [True]
    assert scene.test_occlusions(o, d, t_max=3.9).tolist() == [False]
    assert scene.cast_rays(o, d, t_min=4.5)["t_hit"][0] == pytest.approx(6.0, abs=0.01)  # the far side
    assert scene.test_occlusions(o, d, t_min=6.5).tolist() == [False]


def test_count_intersections_parity_inside_outside(sphere_mesh):
    bunny_like = trimesh.creation.torus(1.0, 0.4)
    s = RaycastingScene()
    s.add_triangles(bunny_like.vertices, bunny_like.faces)
    rng = np.random.default_rng(2)
    points = rng.uniform(-1.6, 1.6, (20_000, 3))
    dirs = rng.normal(size=points.shape)
    inside = (s.count_intersections(points, dirs) % 2) == 1
    np.testing.assert_array_equal(inside, bunny_like.contains(points))
    assert 0.05 < inside.mean() < 0.5


def test_list_intersections_sorted_and_matches_counts(scene):
    rng = np.random.default_rng(3)
    o = rng.normal(size=(500, 3)) * 4
    d = rng.normal(size=(500, 3)) - o * 0.25
    li = scene.list_intersections(o, d)
    counts = scene.count_intersections(o, d)
    np.testing.assert_array_equal(np.diff(li["ray_splits"]), counts)
    np.testing.assert_array_equal(li["ray_ids"], np.repeat(np.arange(500), counts))
    for i in np.nonzero(counts > 1)[0][:50]:
        t = li["t_hit"][li["ray_splits"][i]:li["ray_splits"][i + 1]]
        assert np.all(np.diff(t) >= 0)
    first = li["ray_splits"][:-1][counts > 0]
    np.testing.assert_allclose(li["t_hit"][first], scene.cast_rays(o, d)["t_hit"][counts > 0])
    assert (counts[scene.cast_rays(o, d)["geometry_ids"] == 1] >= 1).all()


def test_instances_equal_moved_vertices(sphere_mesh):
    """Issue 3: an instanced, transformed mesh answers exactly like a copy with its vertices moved."""
    rng = np.random.default_rng(4)
    mesh = trimesh.creation.box(extents=[1.0, 2.0, 0.5])
    mesh = trimesh.util.concatenate([mesh, sphere_mesh])
    mats = [_affine(rng) for _ in range(3)]
    mats[2][:3, :3] = mats[2][:3, :3] @ np.diag([-1.0, 1.0, 1.0])  # a mirror flips the winding
    inst, moved = RaycastingScene(), RaycastingScene()
    first = inst.add_triangles(mesh.vertices, mesh.faces, transform=mats[0])
    for m in mats[1:]:
        inst.add_instance(first, m)
    for m in mats:
        moved.add_triangles(mesh.vertices @ m[:3, :3].T + m[:3, 3], mesh.faces)
    assert inst.nbytes < moved.nbytes * 0.5  # the mesh is stored once
    o = rng.uniform(-6, 6, (20_000, 3))
    d = rng.uniform(-2, 2, (20_000, 3)) - o
    a, b = inst.cast_rays(o, d), moved.cast_rays(o, d)
    np.testing.assert_array_equal(np.isfinite(a["t_hit"]), np.isfinite(b["t_hit"]))
    hit = np.isfinite(a["t_hit"])
    assert hit.mean() > 0.2
    np.testing.assert_allclose(a["t_hit"][hit], b["t_hit"][hit], rtol=1e-9)
    same = a["primitive_ids"] == b["primitive_ids"]
    assert same.mean() > 0.999
    np.testing.assert_array_equal(a["geometry_ids"], b["geometry_ids"])
    np.testing.assert_allclose(a["primitive_normals"][same], b["primitive_normals"][same], atol=1e-9)
    np.testing.assert_allclose(a["primitive_uvs"][same & hit], b["primitive_uvs"][same & hit], atol=1e-7)
    np.testing.assert_array_equal(inst.count_intersections(o, d), moved.count_intersections(o, d))


def test_one_instance_takes_the_packet_kernels_with_the_same_answers(sphere_mesh):
    """A scene of one (transformed) instance is traced by the one-level packet kernels, a mesh placed twice by
    the two-level ones: where the second placement is out of the way, both give the same hits to the bit."""
    rng = np.random.default_rng(7)
    m = _affine(rng)
    m[:3, :3] = m[:3, :3] @ np.diag([-1.0, 1.0, 1.0])  # mirrored too
    one, two = RaycastingScene(), RaycastingScene()
    one.add_triangles(sphere_mesh.vertices, sphere_mesh.faces, transform=m)
    first = two.add_triangles(sphere_mesh.vertices, sphere_mesh.faces, transform=m)
    far = m.copy()
    far[:3, 3] += 500.0
    two.add_instance(first, far)
    rays = RaycastingScene.create_rays_pinhole(50, m[:3, 3], m[:3, 3] + [0.3, 0.5, 6.0], [0, 1, 0], 64, 48)
    rays = rays.astype(np.float64)  # float64 rays: float64 answers, checked to 1e-9 below
    a, b = one.cast_rays(rays), two.cast_rays(rays)
    assert 0.1 < np.isfinite(a["t_hit"]).mean() < 0.9
    for key in ("t_hit", "geometry_ids", "primitive_ids", "primitive_uvs", "primitive_normals"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    np.testing.assert_array_equal(one.test_occlusions(rays, t_max=6.0), two.test_occlusions(rays, t_max=6.0))
    ball = RaycastingScene()
    ball.add_sphere([0.0, 0.0, 0.0], 1.0, transform=m)
    r = ball.cast_rays(rays)
    hit = np.isfinite(r["t_hit"])
    x = rays[..., :3] + r["t_hit"][..., None] * rays[..., 3:]
    # the hit point lies on the moved sphere, its normal is the ellipsoid's outward normal
    x_obj = (x[hit] - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T
    np.testing.assert_allclose(np.linalg.norm(x_obj, axis=1), 1.0, atol=1e-9)
    n = x_obj @ np.linalg.inv(m[:3, :3])
    np.testing.assert_allclose(r["primitive_normals"][hit], n / np.linalg.norm(n, axis=1, keepdims=True), atol=1e-9)


def test_distinct_shapes_share_one_world_space_tree(sphere_mesh):
    """Meshes and spheres each placed once are traced through one world-space tree (packet kernels); the same
    scene with a shape placed twice takes the two-level kernels. Both answer alike: ids, t, uvs, normals."""
    rng = np.random.default_rng(11)
    box = trimesh.creation.box(extents=[1.0, 2.0, 0.5])
    mats = [_affine(rng) for _ in range(4)]
    mats[1][:3, :3] = mats[1][:3, :3] @ np.diag([1.0, -1.0, 1.0])  # a mirror
    for i, m in enumerate(mats):  # side by side, in view
        m[:3, 3] = [(i - 1.5) * 2.5, 0.3 * i, 0.0]
    flat, nested = RaycastingScene(), RaycastingScene()
    for s in (flat, nested):
        s.add_triangles(sphere_mesh.vertices, sphere_mesh.faces, transform=mats[0])
        s.add_triangles(box.vertices, box.faces, transform=mats[1])
        s.add_sphere([0.5, 0.0, 0.0], 0.7, transform=mats[2])
    flat.add_triangles(box.vertices, box.faces, transform=mats[3])
    nested.add_instance(1, mats[3])  # the box again: shared, so two-level
    assert flat._tree().world is not None and nested._tree().world is None
    rays = RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [1.0, 2.0, 10.0], [0, 1, 0], 96, 64)
    a, b = flat.cast_rays(rays), nested.cast_rays(rays)
    hit = np.isfinite(a["t_hit"])
    assert 0.1 < hit.mean() < 0.95 and len(np.unique(a["geometry_ids"][hit])) == 4
    np.testing.assert_array_equal(hit, np.isfinite(b["t_hit"]))
    np.testing.assert_allclose(a["t_hit"][hit], b["t_hit"][hit], rtol=1e-9)
    same = a["primitive_ids"] == b["primitive_ids"]
    assert same.mean() > 0.999
    np.testing.assert_array_equal(a["geometry_ids"], b["geometry_ids"])
    np.testing.assert_allclose(a["primitive_normals"][same], b["primitive_normals"][same], atol=1e-9)
    np.testing.assert_allclose(a["primitive_uvs"][same & hit], b["primitive_uvs"][same & hit], atol=1e-7)
    np.testing.assert_array_equal(flat.test_occlusions(rays, t_max=12.0), nested.test_occlusions(rays, t_max=12.0))


def test_transformed_sphere_is_an_ellipsoid():
    s = RaycastingScene()
    m = np.diag([2.0, 1.0, 1.0, 1.0])
    s.add_sphere([0.0, 0.0, 0.0], 1.0, transform=m)
    r = s.cast_rays(np.array([[5.0, 0, 0], [0, 5.0, 0]]), np.array([[-1.0, 0, 0], [0, -1.0, 0]]))
    np.testing.assert_allclose(r["t_hit"], [3.0, 4.0])
    np.testing.assert_allclose(r["primitive_normals"], [[1, 0, 0], [0, 1, 0]], atol=1e-12)
    assert s.count_intersections(np.zeros((1, 3)), np.array([[0.0, 0, 1]])).tolist() == [1]


def test_add_mesh_from_trimesh_and_path(tmp_path, sphere_mesh):
    path = tmp_path / "ico.ply"
    sphere_mesh.export(path)
    s = RaycastingScene()
    assert s.add_mesh(sphere_mesh) == 0 and s.add_mesh(path) == 1 and s.add_mesh(str(path)) == 2
    with pytest.raises(FileNotFoundError):
        s.add_mesh(tmp_path / "missing.ply")
    with pytest.raises(ValueError, match="triangle mesh"):
        s.add_mesh(42)


def test_empty_scene_misses():
    s = RaycastingScene()
    r = s.cast_rays(np.zeros((2, 3)), np.ones((2, 3)))
    assert np.isinf(r["t_hit"]).all() and (r["geometry_ids"] == RaycastingScene.INVALID_ID).all()
    assert not s.test_occlusions(np.zeros((2, 6)) + [0, 0, 0, 1, 0, 0]).any()
    assert s.list_intersections(np.zeros((2, 3)), np.ones((2, 3)))["ray_splits"].tolist() == [0, 0, 0]


@pytest.mark.parametrize("call, match", [
    (lambda s: s.add_triangles(np.zeros((3, 2)), [[0, 1, 2]]), "shape"),
    (lambda s: s.add_triangles(np.zeros((3, 3)), [[0, 1]]), "shape"),
    (lambda s: s.add_triangles(np.zeros((3, 3)), [[0, 1, 3]]), "out of range"),
    (lambda s: s.add_triangles(np.zeros((3, 3)), [[0, -1, 2]]), "out of range"),
    (lambda s: s.add_triangles(np.zeros((3, 3)), [[0, 1.5, 2]]), "integer"),
    (lambda s: s.add_triangles([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]), "NaN"),
    (lambda s: s.add_triangles([[0, 0, np.inf], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]]), "infinity"),
    (lambda s: s.add_triangles(np.array([["a"] * 3] * 3), [[0, 1, 2]]), "numeric"),
    (lambda s: s.add_sphere([0, 0], 1.0), "shape"),
    (lambda s: s.add_sphere([0, 0, 0], -1.0), "radius"),
    (lambda s: s.add_sphere([0, 0, 0], np.nan), "radius"),
    (lambda s: s.add_sphere([0, 0, 0], 1.0, transform=np.eye(3)), "4x4"),
    (lambda s: s.add_sphere([0, 0, 0], 1.0, transform=np.zeros((4, 4)) + np.eye(4) * [1, 1, 0, 1]), "singular"),
    (lambda s: s.add_sphere([0, 0, 0], 1.0, transform=np.ones((4, 4))), "affine"),
    (lambda s: s.add_sphere([0, 0, 0], 1.0, transform=np.eye(4) * np.nan), "NaN"),
    (lambda s: s.add_instance(7, np.eye(4)), "no geometry"),
    (lambda s: s.cast_rays(np.zeros((2, 4))), r"\(\.\.\., 6\)"),
    (lambda s: s.cast_rays(np.zeros((2, 3)), np.ones((3, 3))), "same shape"),
    (lambda s: s.cast_rays(np.zeros((2, 2)), np.ones((2, 2))), "shape"),
    (lambda s: s.cast_rays([[0, 0, 0]], [[0, 0, 1]], t_min=np.nan), "t_min"),
    (lambda s: s.cast_rays([[0, 0, 0]], [[0, 0, 1]], t_max=[1.0, 2.0]), "t_max"),
    (lambda s: s.count_intersections(np.zeros((1, 5))), "6"),
    (lambda s: s.cast_rays(np.array([0.0, 0, 5, 0, 0, -1])), "one ray is"),       # a 1-D ray: (1, 6) is one ray
    (lambda s: s.test_occlusions(np.array([0.0, 0, 5, 0, 0, -1])), "one ray is"),
    (lambda s: s.cast_rays([0.0, 0, 5], [0.0, 0, -1]), "at least 2 dimensions"),
    (lambda s: s.add_triangles(np.zeros((3, 3))), "triangle_indices"),
    (lambda s: RaycastingScene(device="CUDA:0"), "CPU"),
])
def test_value_errors(call, match):
    s = RaycastingScene()
    s.add_sphere([0, 0, 0], 1.0)
    with pytest.raises(ValueError, match=match):
        call(s)


def test_create_rays_pinhole_depth_map_of_a_plane():
    """A depth map the way an Open3D user makes one: pinhole rays at a wall 5 units away give t_hit = depth."""
    from durer import RaycastingScene

    rays = RaycastingScene.create_rays_pinhole(fov_deg=90, center=(0, 0, 0), eye=(0, 0, 5), up=(0, 1, 0),
                                               width_px=4, height_px=2)
    assert rays.shape == (2, 4, 6) and rays.dtype == np.float32
    np.testing.assert_array_equal(rays[..., :3], np.broadcast_to([0, 0, 5], (2, 4, 3)))
    # Open3D's layout: focal length 2 px (90 degrees across 4 px), row 0 looks along -up, column 0 towards +x
    # (the camera's left as it looks down -z), camera-space z = 1
    np.testing.assert_array_equal(rays[0, 0, 3:], [0.75, -0.25, -1.0])
    np.testing.assert_array_equal(rays[1, 3, 3:], [-0.75, 0.25, -1.0])
    scene = RaycastingScene()
    scene.add_triangles(np.array([[-10, -10, 0], [10, -10, 0], [0, 10, 0]], float), np.array([[0, 1, 2]]))
    np.testing.assert_allclose(scene.cast_rays(rays)["t_hit"].numpy(), 5.0, rtol=1e-6)  # depth, not distance
    with pytest.raises(ValueError, match="parallel"):
        RaycastingScene.create_rays_pinhole(60, (0, 0, 0), (0, 0, 5), (0, 0, 1), 4, 4)


def test_create_rays_pinhole_from_matrices():
    """The (intrinsic, extrinsic) form: the camera centre is -R^T t, a pixel's direction R^T K^-1 (x+.5, y+.5, 1)."""
    k = np.array([[100.0, 0, 32], [0, 90, 24], [0, 0, 1]])
    e = np.eye(4)
    e[:3, :3] = [[0, 0, 1], [0, 1, 0], [-1, 0, 0]]  # a rotation about y
    e[:3, 3] = [1.0, 2.0, 3.0]
    rays = RaycastingScene.create_rays_pinhole(k, e, 64, 48)
    assert rays.shape == (48, 64, 6) and rays.dtype == np.float32
    np.testing.assert_allclose(rays[0, 0, :3], -e[:3, :3].T @ e[:3, 3], rtol=1e-7)
    x, y = 10, 7
    want = e[:3, :3].T @ np.linalg.solve(k, [x + 0.5, y + 0.5, 1.0])
    np.testing.assert_allclose(rays[y, x, 3:], want, rtol=1e-6)
    same = RaycastingScene.create_rays_pinhole(intrinsic_matrix=k, extrinsic_matrix=e, width_px=64, height_px=48)
    np.testing.assert_array_equal(rays, same)


def test_flat_image_width_finds_camera_rows():
    """Flat rays in an image's row order are recognised (pinhole and orthographic), anything else is not."""
    from durer.query import flat_image_width

    rays = RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 3], [0, 1, 0], 64, 48).reshape(-1, 6)
    assert flat_image_width(rays[:, :3], rays[:, 3:]) == 64
    wide = RaycastingScene.create_rays_pinhole(100, [0, 0, 0], [0, 0, 3], [0, 1, 0], 40, 8).reshape(-1, 6)
    assert flat_image_width(wide[:, :3], wide[:, 3:]) == 40
    j, i = np.meshgrid(np.arange(32.0), np.arange(16.0))
    ortho_o = np.stack([0.1 * j, -0.1 * i, np.zeros_like(i)], -1).reshape(-1, 3)
    ortho_d = np.tile([0.0, 0.0, -1.0], (len(ortho_o), 1))
    assert flat_image_width(ortho_o, ortho_d) == 32
    odd = RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 3], [0, 1, 0], 30, 20).reshape(-1, 6)
    assert flat_image_width(odd[:, :3], odd[:, 3:]) == 0        # rows not a multiple of 4 long
    short = RaycastingScene.create_rays_pinhole(60, [0, 0, 0], [0, 0, 3], [0, 1, 0], 64, 6).reshape(-1, 6)
    assert flat_image_width(short[:, :3], short[:, 3:]) == 0    # 6 rows: not whole 4-row bands
    rng = np.random.default_rng(3)
    d = rng.normal(size=(4096, 3))
    assert flat_image_width(rng.normal(size=(4096, 3)), d) == 0
    assert flat_image_width(np.zeros((4096, 3)), np.tile([0.0, 0.0, 1.0], (4096, 1))) == 0  # one ray repeated
    shuffled = rng.permutation(len(rays))
    assert flat_image_width(rays[shuffled, :3], rays[shuffled, 3:]) == 0


def test_flat_camera_rays_hit_as_the_image_and_as_single_rays(sphere_mesh):
    """Flat camera rays (traced in 4 x 4 tiles once their width is recognised), the same rays as an image, and
    the same rays shuffled (traced one at a time) give the same t to the bit and the same hit/miss."""
    s = RaycastingScene()
    s.add_triangles(sphere_mesh.vertices, sphere_mesh.faces)
    rays = RaycastingScene.create_rays_pinhole(50, [0, 0, 0], [0.3, 0.2, 3], [0, 1, 0], 64, 48)
    image = s.cast_rays(rays)["t_hit"].reshape(-1)
    flat = s.cast_rays(rays[..., :3].reshape(-1, 3), rays[..., 3:].reshape(-1, 3))["t_hit"]
    perm = np.random.default_rng(5).permutation(64 * 48)
    single = np.empty(64 * 48)
    single[perm] = s.cast_rays(rays.reshape(-1, 6)[perm])["t_hit"]
    assert 0.3 < np.isfinite(image).mean() < 0.9
    np.testing.assert_array_equal(flat, image)
    np.testing.assert_array_equal(single, image)
    occluded = s.test_occlusions(rays[..., :3].reshape(-1, 3), rays[..., 3:].reshape(-1, 3))
    np.testing.assert_array_equal(occluded, np.isfinite(image))


def test_list_intersections_names_the_instance_of_every_hit(sphere_mesh):
    """Two placements of one mesh (the two-level kernels): every listed hit names the instance it was found in,
    and a ray's first listed hit is cast_rays' closest hit, with the same geometry id."""
    s = RaycastingScene()
    a = s.add_triangles(sphere_mesh.vertices, sphere_mesh.faces)
    moved = np.eye(4)
    moved[:3, 3] = (3.0, 0.0, 0.0)
    b = s.add_instance(a, moved)
    o = np.array([[-5.0, 0.1, 0.03], [8.0, -0.1, 0.05], [3.05, 5.0, 0.07]])  # off vertices and edges
    d = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    li = s.list_intersections(o, d)
    assert np.diff(li["ray_splits"]).tolist() == [4, 4, 2]
    per_ray = np.split(li["geometry_ids"], li["ray_splits"][1:-1])
    assert per_ray[0].tolist() == [a, a, b, b] and per_ray[1].tolist() == [b, b, a, a] and per_ray[2].tolist() == [b, b]
    first = li["ray_splits"][:-1]
    np.testing.assert_array_equal(li["geometry_ids"][first], s.cast_rays(o, d)["geometry_ids"])


def test_float32_rays_give_the_float64_results_and_errors(sphere_mesh):
    """float32 rays are converted by the ray check itself: the results of the same values in float64, t, uvs and
    normals rounded to float32 (as Open3D and Embree return them), and the same errors for NaN and zero
    directions."""
    s = RaycastingScene()
    s.add_triangles(sphere_mesh.vertices, sphere_mesh.faces)
    rng = np.random.default_rng(8)
    o = rng.uniform(-3, 3, (500, 3))
    rays = np.concatenate([o, rng.uniform(-1.5, 1.5, (500, 3)) - o], 1).astype(np.float32)  # some hit the sphere
    ref = s.cast_rays(rays.astype(np.float64))
    assert 0.1 < np.isfinite(ref["t_hit"]).mean() < 0.9
    for got in (s.cast_rays(rays), s.cast_rays(rays[:, :3], rays[:, 3:])):
        assert got["primitive_ids"].dtype == np.uint32
        np.testing.assert_array_equal(got["primitive_ids"], ref["primitive_ids"])
        for key in ("t_hit", "primitive_uvs", "primitive_normals"):
            assert got[key].dtype == np.float32 and ref[key].dtype == np.float64
            np.testing.assert_array_equal(got[key], ref[key].astype(np.float32))
    bad = rays.copy()
    bad[7, 4] = np.nan
    bad[9, 3:] = 0.0
    bad[11, 0] = np.inf
    got = s.cast_rays(bad)
    assert np.isinf(got["t_hit"][[7, 9, 11]]).all() and (got["geometry_ids"][[7, 9, 11]] == 2**32 - 1).all()
    assert not s.test_occlusions(bad)[[7, 9, 11]].any() and not s.count_intersections(bad)[[7, 9, 11]].any()
    keep = np.setdiff1d(np.arange(len(rays)), [7, 9, 11])
    np.testing.assert_array_equal(got["t_hit"][keep], ref["t_hit"][keep].astype(np.float32))


def _every_query(s: RaycastingScene, rng) -> list[np.ndarray]:
    """The outputs of every ray and point query on rays and points around the unit sphere: camera rays (packets),
    random rays (one at a time), and points for distances and winding numbers."""
    eye = np.array([0.3, 0.2, 4.0])
    j, i = np.meshgrid(np.arange(32), np.arange(32))
    d = np.stack([(j - 15.5) / 40, (15.5 - i) / 40, -np.ones_like(j, dtype=float)], -1).reshape(-1, 3)
    o = rng.uniform(-2, 2, (2000, 3))
    rays = [(np.broadcast_to(eye, d.shape), d), (o, rng.uniform(-1, 1, (2000, 3)) - o)]
    out = []
    for origins, directions in rays:
        out += list(s.cast_rays(origins, directions).values())
        out += [s.test_occlusions(origins, directions), s.count_intersections(origins, directions)]
        out += list(s.list_intersections(origins, directions).values())
    points = rng.uniform(-1.5, 1.5, (1000, 3))
    out += list(s.compute_closest_points(points).values())
    out += [s.compute_distance(points), s.compute_winding_number(points), s.compute_signed_distance(points)]
    return out


def test_float32_leaves_give_the_float64_leaves_answers_to_the_bit(sphere_mesh, monkeypatch):
    """A large mesh whose vertices are all float32 values (a PLY scan, a float32 array) keeps its leaf triangles
    in float32 (half the bytes a traversal reads), and every query answers exactly as with float64 leaves: the
    kernels widen each coordinate as they load it. Vertices that float32 cannot hold, and small meshes, keep
    float64 leaves. (The size threshold is lowered here so that the icosphere narrows.)"""
    import durer.accel.bvh as bvh

    small = bvh.build_tree(np.zeros((3, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)))
    assert small.leaf_tri.dtype == np.float64  # exact, but below NARROW_LEAVES_FROM
    monkeypatch.setattr(bvh, "NARROW_LEAVES_FROM", 1)
    vertices = sphere_mesh.vertices.astype(np.float32).astype(np.float64)
    s = RaycastingScene()
    s.add_triangles(vertices, sphere_mesh.faces)
    s.build()
    assert s._bvh.packed.blas.leaf_tri.dtype == np.float32
    narrow = _every_query(s, np.random.default_rng(3))
    monkeypatch.setattr(bvh, "NARROW_LEAVES_FROM", 10**9)  # every tree keeps float64 leaves
    wide = RaycastingScene()
    wide.add_triangles(vertices, sphere_mesh.faces)
    wide.build()
    assert wide._bvh.packed.blas.leaf_tri.dtype == np.float64
    for got, ref in zip(narrow, _every_query(wide, np.random.default_rng(3)), strict=True):
        np.testing.assert_array_equal(got, ref)
    monkeypatch.setattr(bvh, "NARROW_LEAVES_FROM", 1)
    inexact = bvh.build_tree(np.full((1, 3, 3), 0.1), np.zeros((0, 3)), np.zeros((0, 3)))
    assert inexact.leaf_tri.dtype == np.float64  # 0.1 is no float32 value
    inexact = bvh.Shape.indexed(np.array([[0.1, 0, 0], [0, 1, 0], [0, 0, 1]]), np.array([[0, 1, 2]]))
    assert inexact.tree.leaf_tri.dtype == np.float64  # the same through a mesh's indices
