"""kernels/path/surface.hit_surfaces (the path tracer's hit points, normals and material slots in one pass) against
accel/hits' NumPy definitions, on triangles, a mesh placed twice (instances), a squashed sphere, a disk, a cylinder and a plane."""

from __future__ import annotations

import numpy as np
import pytest

from durer import Cylinder, Disk, Group, Plane, Scene, Sphere, Transform, TriangleMesh
from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.accel.hits import geometric_normals, hit_materials
from durer.kernels.path.surface import hit_surfaces
from durer.scene import transforms as tf
from durer.scene.cameras import OrthographicCamera


def test_hit_surfaces_match_the_numpy_definitions():
    rng = np.random.default_rng(4)
    mesh = TriangleMesh(rng.normal(size=(30, 3)), rng.integers(0, 30, size=(40, 3)), 2)
    group = Group([Plane((0, 1, 0), -2.0, 0),
                   Transform(tf.compose(tf.translate((0.5, 0, 0)), tf.scale((1, 2, 0.5))), Sphere((0, 0, 0), 1, 1)),
                   Transform(tf.translate((-3, 0, 0)), mesh), Transform(tf.rotate((0, 1, 0), 40), mesh),
                   Transform(tf.compose(tf.translate((2, 2, 1)), tf.rotate((1, 0, 0), 30)), Disk(1)),
                   Cylinder((-2, -1, 2), (1, -2, 3), 0.7, 2)])
    cs = compile_scene(Scene(camera=OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 5), group=group))
    assert len(cs.instance_mesh) == 2  # the mesh placed twice is stored once
    o = rng.uniform(-6, 6, size=(4000, 3))
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hits = BVHAccelerator(cs).closest_hit(o, d)
    assert {1, 2, 3} <= set(np.unique(hits.kind)) and (hits.kind == 0).any()  # triangles, spheres, planes, misses
    flat = cs.flat
    p, ng, ns, slot = np.empty((4000, 3)), np.empty((4000, 3)), np.empty((4000, 3)), np.empty(4000, np.int64)
    uvd = np.empty((4000, 8))
    hit_surfaces(o, d, hits.t, hits.kind, hits.prim, flat.triangles.reshape(-1, 3, 3), flat.triangle_material,
                 flat.sphere_world_to_object, flat.sphere_center, flat.sphere_radius, flat.sphere_normal_matrix,
                 flat.sphere_material, flat.plane_normal, flat.plane_material, np.zeros((0, 3, 3)), np.zeros((0, 3, 2)),
                 p, ng, ns, uvd, slot, 0, 4000)
    # no mesh UVs: (u, v) = 0 and Mitsuba's barycentric derivatives (the edges); spheres (phi / 2 pi, theta / pi);
    # planes none
    on_sphere, on_tri = hits.kind == 2, hits.kind == 1
    assert not uvd[~(on_sphere | on_tri)].any() and not uvd[on_tri, :2].any()
    np.testing.assert_allclose(uvd[on_sphere, :2], cs.analytic_uv(hits.prim[on_sphere], p[on_sphere]), atol=1e-12)
    tri = flat.triangles.reshape(-1, 3, 3)[hits.prim[on_tri]]
    np.testing.assert_allclose(uvd[on_tri, 2:5], tri[:, 1] - tri[:, 0], atol=1e-12)
    np.testing.assert_allclose(uvd[on_tri, 5:], tri[:, 2] - tri[:, 0], atol=1e-12)
    expect_p = o + np.where(hits.hit, hits.t, 0.0)[:, None] * d
    np.testing.assert_allclose(p, expect_p, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ng, geometric_normals(cs, hits, expect_p), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(ns, ng)  # no vertex normals: shading = geometric
    np.testing.assert_array_equal(slot, hit_materials(cs, hits))


def test_vertex_normals_are_interpolated_at_the_hit():
    """A mesh with vertex normals shades with their barycentric mix (Mitsuba's shading normal); without, flat."""
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    n = np.array([[0.0, 0, 1], [1, 0, 1], [0, 1, 1]])
    uv = np.array([[0.5, 0.25], [2.5, 0.25], [0.5, 4.25]])  # u = 0.5 + 2 x, v = 0.25 + 4 y
    scene = Scene(camera=OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 5),
                  group=Group([TriangleMesh(v, [[0, 1, 2]], normals=n, uvs=uv)]))
    cs = compile_scene(scene)
    o = np.array([[0.2, 0.3, 1.0], [0.0, 0.0, 1.0]])
    d = np.array([[0.0, 0, -1], [0.0, 0, -1]])
    hits = BVHAccelerator(cs).closest_hit(o, d)
    corners = cs.triangle_normals.reshape(-1, 3, 3)
    corners = corners / np.linalg.norm(corners, axis=2, keepdims=True)
    p, ng, ns, slot, uvd = np.empty((2, 3)), np.empty((2, 3)), np.empty((2, 3)), np.empty(2, np.int64), np.empty((2, 8))
    tri_uv = cs.triangle_uv.reshape(-1, 3, 2)
    args = (o, d, hits.t, hits.kind, hits.prim, cs.triangles.reshape(-1, 3, 3), cs.triangle_material,
            cs.sphere_world_to_object, cs.sphere_center, cs.sphere_radius, cs.sphere_normal_matrix, cs.sphere_material,
            cs.plane_normal, cs.plane_material)
    hit_surfaces(*args, corners, tri_uv, p, ng, ns, uvd, slot, 0, 2)
    # texture coordinates and Mitsuba's dp/du, dp/dv (the inverse of the UV map's slopes)
    np.testing.assert_allclose(uvd[:, :2], [[0.9, 1.45], [0.5, 0.25]], atol=1e-12)
    np.testing.assert_allclose(uvd[:, :2], cs.uv_at(hits.prim, p), atol=1e-12)
    np.testing.assert_allclose(uvd[:, 2:], [[0.5, 0, 0, 0, 0.25, 0]] * 2, atol=1e-12)
    expect = 0.5 * corners[0, 0] + 0.2 * corners[0, 1] + 0.3 * corners[0, 2]
    np.testing.assert_allclose(ns[0], expect / np.linalg.norm(expect), atol=1e-12)
    np.testing.assert_allclose(ns[1], corners[0, 0], atol=1e-12)
    np.testing.assert_allclose(ns[0], cs.normals_at(hits.prim[:1], p[:1])[0], atol=1e-12)
    np.testing.assert_allclose(ng, [[0, 0, 1], [0, 0, 1]], atol=1e-12)  # the geometric normal stays
    hit_surfaces(*args, np.zeros((0, 3, 3)), tri_uv, p, ng, ns, uvd, slot, 0, 2)
    np.testing.assert_allclose(ns, [[0, 0, 1], [0, 0, 1]], atol=1e-12)


def test_tangent_frame_is_mitsubas_shading_frame(tmp_path):
    """surface.uv_at's dp/du + warps.tangent_frame3 give Mitsuba's sh_frame.s (which orients anisotropic BSDFs) on a
    smooth mesh with UVs, one without UVs (Mitsuba's UVs are then barycentric) and a rotated, scaled sphere."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 defines the shading frame being matched")
    trimesh = pytest.importorskip("trimesh")
    import durer
    from durer.kernels.path.warps import tangent_frame3

    mi.set_variant("scalar_rgb")
    ball = trimesh.creation.uv_sphere(radius=1.0, count=[12, 16])
    v = ball.vertices
    uv = np.column_stack([np.arctan2(v[:, 1], v[:, 0]) / (2 * np.pi) + 0.5, v[:, 2] * 0.5 + 0.5])
    trimesh.Trimesh(v, ball.faces, vertex_normals=ball.vertex_normals, process=False,
                    visual=trimesh.visual.TextureVisuals(uv=uv)).export(tmp_path / "uv.ply")
    trimesh.Trimesh(v + [3, 0, 0], ball.faces, vertex_normals=ball.vertex_normals,
                    process=False).export(tmp_path / "plain.ply")
    to_world = mi.ScalarTransform4f().translate([0, 3, 0]).rotate([0.6, 0.8, 0], 30).scale(1.5)
    look = mi.ScalarTransform4f().look_at([0, 0, 8], [0, 0, 0], [0, 1, 0])

    def scene(matrix):
        return {"type": "scene", "sensor": {"type": "perspective", "to_world": matrix(look)},
                "a": {"type": "ply", "filename": str(tmp_path / "uv.ply")},
                "b": {"type": "ply", "filename": str(tmp_path / "plain.ply")},
                "c": {"type": "sphere", "to_world": matrix(to_world)}}

    theirs = mi.load_dict(scene(lambda m: m))
    cs = compile_scene(durer.load_dict(scene(lambda m: np.array(m.matrix))))
    flat = cs.flat
    rng = np.random.default_rng(5)
    n = 1500
    o = np.column_stack([rng.uniform(-2, 5, n), rng.uniform(-2, 5, n), np.full(n, 8.0)])
    d = np.column_stack([rng.normal(0, 0.05, (n, 2)), -np.ones(n)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    hits = BVHAccelerator(cs).closest_hit(o, d)
    corners = cs.triangle_normals.reshape(-1, 3, 3)
    corners = corners / np.linalg.norm(corners, axis=2, keepdims=True)
    p, ng, ns, slot, uvd = (np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.int64),
                            np.empty((n, 8)))
    tris = flat.triangles.reshape(-1, 3, 3)
    hit_surfaces(o, d, hits.t, hits.kind, hits.prim, tris, flat.triangle_material, flat.sphere_world_to_object,
                 flat.sphere_center, flat.sphere_radius, flat.sphere_normal_matrix, flat.sphere_material,
                 flat.plane_normal, flat.plane_material, corners, flat.triangle_uv.reshape(-1, 3, 2), p, ng, ns, uvd,
                 slot, 0, n)
    du = uvd[:, 2:5]
    seen = {}
    for i in np.flatnonzero(hits.hit):
        si = theirs.ray_intersect(mi.Ray3f(o[i], d[i]))
        if not si.is_valid() or abs(si.t - hits.t[i]) > 1e-4 * hits.t[i]:
            continue  # grazing rays where float32 and float64 disagree on what was hit
        s, t = tangent_frame3(*ns[i], *du[i], *ng[i])
        np.testing.assert_allclose(s, np.array(si.sh_frame.s), atol=2e-5)
        np.testing.assert_allclose(t, np.array(si.sh_frame.t), atol=2e-5)
        seen[si.shape.id()] = seen.get(si.shape.id(), 0) + 1
    assert set(seen) == {"a", "b", "c"} and min(seen.values()) > 50, seen
