"""query_normals: cast_rays(primitive_normals="interpolated") mixes a mesh's vertex normals at the hit (Mitsuba's
shading normal, checked against Mitsuba's si.sh_frame.n), the default stays Open3D's face normal, and meshes
without vertex normals keep it."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from durer.query import RaycastingScene

TRI = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
TRI_NORMALS = np.array([[0.0, 0, 1], [1, 0, 1], [0, 1, 1]])


def test_one_triangle_closed_form():
    """At barycentric weights (b1, b2) = (0.2, 0.3) the normal is unit(0.5 n0 + 0.2 n1 + 0.3 n2) of the corners
    taken to world space by the inverse transpose of the geometry's matrix and made unit; the face normal is the
    default."""
    scene = RaycastingScene()
    m = np.diag([2.0, 1.0, 1.0, 1.0])
    scene.add_triangles(TRI, [[0, 1, 2]], m, vertex_normals=TRI_NORMALS)
    rays = np.array([[0.4, 0.3, 1.0, 0, 0, -1], [5, 5, 1, 0, 0, -1]])
    face = scene.cast_rays(rays)["primitive_normals"].numpy()
    out = scene.cast_rays(rays, primitive_normals="interpolated")
    np.testing.assert_allclose(out["primitive_uvs"].numpy()[0], [0.2, 0.3])
    world = TRI_NORMALS / np.array([2.0, 1.0, 1.0])  # each corner by the inverse transpose, then made unit
    world /= np.linalg.norm(world, axis=1, keepdims=True)
    n = 0.5 * world[0] + 0.2 * world[1] + 0.3 * world[2]
    np.testing.assert_allclose(out["primitive_normals"].numpy()[0], n / np.linalg.norm(n), atol=1e-12)
    np.testing.assert_allclose(face[0], [0, 0, 1])
    assert np.isnan(out["primitive_normals"].numpy()[1]).all() == np.isnan(face[1]).all()  # a miss: as before
    with pytest.raises(ValueError, match="primitive_normals must be 'face'"):
        scene.cast_rays(rays, primitive_normals="shading")
    with pytest.raises(ValueError, match=r"vertex_normals must have shape \(3, 3\)"):
        RaycastingScene().add_triangles(TRI, [[0, 1, 2]], vertex_normals=TRI_NORMALS[:2])
    again = pickle.loads(pickle.dumps(scene)).cast_rays(rays, primitive_normals="interpolated")
    np.testing.assert_array_equal(again["primitive_normals"].numpy(), out["primitive_normals"].numpy())


def test_mesh_files_and_meshes_without_normals(tmp_path):
    """A PLY with vertex normals through add_mesh (trimesh reads them) interpolates; the same mesh without normals
    and float32 rays keep the face normal; float32 rays give the float64 answer rounded."""
    trimesh = pytest.importorskip("trimesh")
    ball = trimesh.creation.icosphere(subdivisions=2)
    trimesh.Trimesh(ball.vertices, ball.faces, vertex_normals=ball.vertices, process=False).export(tmp_path / "n.ply")
    scene = RaycastingScene()
    scene.add_mesh(str(tmp_path / "n.ply"))
    scene.add_triangles(ball.vertices + [3, 0, 0], ball.faces)
    rng = np.random.default_rng(2)
    o = np.column_stack([rng.uniform(-0.7, 3.7, 400), rng.uniform(-0.7, 0.7, 400), np.full(400, 5.0)])
    rays = np.column_stack([o, np.tile([0.0, 0, -1], (400, 1))])
    out = scene.cast_rays(rays, primitive_normals="interpolated")
    face = scene.cast_rays(rays)["primitive_normals"].numpy()
    g, n = out["geometry_ids"].numpy(), out["primitive_normals"].numpy()
    p = o + out["t_hit"].numpy()[:, None] * rays[:, 3:]
    on_ball = g == 0
    assert on_ball.sum() > 50 and (g == 1).sum() > 50
    # the vertex normals of a sphere's vertices are radial: their mix is close to the radial direction at p
    radial = p[on_ball] / np.linalg.norm(p[on_ball], axis=1, keepdims=True)
    assert np.abs(n[on_ball] - radial).max() < 0.02 < np.abs(face[on_ball] - radial).max()
    np.testing.assert_array_equal(n[g == 1], face[g == 1])
    out32 = scene.cast_rays(rays.astype(np.float32), primitive_normals="interpolated")
    assert out32["primitive_normals"].numpy().dtype == np.float32
    np.testing.assert_allclose(out32["primitive_normals"].numpy()[on_ball], n[on_ball], atol=1e-5)


def test_interpolated_normals_are_mitsubas_shading_normals(tmp_path):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 defines the shading normal being matched")
    trimesh = pytest.importorskip("trimesh")
    mi.set_variant("scalar_rgb")
    ball = trimesh.creation.uv_sphere(radius=1.0, count=[10, 14])
    rng = np.random.default_rng(3)
    normals = ball.vertex_normals + rng.normal(0, 0.2, ball.vertices.shape)  # not radial: the mix shows
    trimesh.Trimesh(ball.vertices, ball.faces, vertex_normals=normals, process=False).export(tmp_path / "b.ply")
    to_world = mi.ScalarTransform4f().translate([0.2, 0.1, 0]).rotate([0.6, 0.8, 0], 25).scale([1.5, 1.0, 0.7])
    theirs = mi.load_dict({"type": "scene", "b": {"type": "ply", "filename": str(tmp_path / "b.ply"),
                                                  "to_world": to_world}})
    scene = RaycastingScene()
    scene.add_mesh(str(tmp_path / "b.ply"), np.array(to_world.matrix))
    o = np.column_stack([rng.uniform(-1, 1, 300), rng.uniform(-1, 1, 300), np.full(300, 5.0)])
    d = np.tile([0.0, 0, -1], (300, 1))
    out = scene.cast_rays(o, d, primitive_normals="interpolated")
    hit = np.isfinite(out["t_hit"].numpy())
    assert hit.sum() > 100
    for i in np.flatnonzero(hit):
        si = theirs.ray_intersect(mi.Ray3f(o[i], d[i]))
        assert si.prim_index == out["primitive_ids"].numpy()[i]
        np.testing.assert_allclose(out["primitive_normals"].numpy()[i], np.array(si.sh_frame.n), atol=2e-5)
