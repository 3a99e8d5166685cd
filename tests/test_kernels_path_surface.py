"""kernels/path/surface.hit_surfaces (the path tracer's hit points, normals and material slots in one pass) against
accel/hits' NumPy definitions, on triangles, a mesh placed twice (instances), a squashed sphere, a disk, a cylinder and a plane."""

from __future__ import annotations

import numpy as np

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
    # no mesh UVs: only the spheres have texture coordinates, Mitsuba's (phi / 2 pi, theta / pi), no derivatives
    on_sphere = hits.kind == 2
    assert not uvd[~on_sphere].any() and not uvd[:, 2:].any()
    np.testing.assert_allclose(uvd[on_sphere, :2], cs.analytic_uv(hits.prim[on_sphere], p[on_sphere]), atol=1e-12)
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
