"""Transform composition (the course's order), normals by the inverse transpose, flattening of the tree."""

from __future__ import annotations

import numpy as np
import pytest

from durer import Group, Plane, Scene, Sphere, Transform, Triangle, TriangleMesh
from durer.accel.compile import compile_scene, sphere_bounds
from durer.scene import transforms as tf
from durer.scene.cameras import OrthographicCamera

CAM = OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=1)


def test_rotations_are_right_handed_in_degrees():
    np.testing.assert_allclose(tf.transform_points(tf.z_rotate(90), [[1, 0, 0]]), [[0, 1, 0]], atol=1e-15)
    np.testing.assert_allclose(tf.transform_points(tf.x_rotate(90), [[0, 1, 0]]), [[0, 0, 1]], atol=1e-15)
    np.testing.assert_allclose(tf.transform_points(tf.y_rotate(90), [[0, 0, 1]]), [[1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(tf.rotate((1, 1, 1), 120)[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-12)


def test_composition_last_listed_acts_first():
    m = tf.compose(tf.translate((5, 0, 0)), tf.scale(2))
    np.testing.assert_allclose(tf.transform_points(m, [[1, 0, 0]]), [[7, 0, 0]])  # scale, then translate
    m = tf.compose(tf.scale(2), tf.translate((5, 0, 0)))
    np.testing.assert_allclose(tf.transform_points(m, [[1, 0, 0]]), [[12, 0, 0]])


def test_normals_by_inverse_transpose():
    m = tf.scale((1, 2, 1))
    n = tf.transform_normals(m, [[1, 1, 0]])
    np.testing.assert_allclose(n, [[2 / np.sqrt(5), 1 / np.sqrt(5), 0]])


def test_nested_transforms_flatten_into_world_space():
    tri = Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0), material=0)
    scene = Scene(camera=CAM, group=Group([Transform(tf.translate((1, 2, 3)), Transform(tf.scale(2), tri))]))
    cs = compile_scene(scene)
    np.testing.assert_allclose(cs.triangles[0], [[1, 2, 3], [3, 2, 3], [1, 4, 3]])


def test_mirror_transform_keeps_the_inverse_transpose_normal():
    tri = Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0))
    cs = compile_scene(Scene(camera=CAM, group=Group([Transform(tf.scale((-1, 1, 1)), tri)])))
    v = cs.triangles[0]
    n = np.cross(v[1] - v[0], v[2] - v[0])
    expected = tf.transform_normals(tf.scale((-1, 1, 1)), [[0, 0, 1]])[0]
    np.testing.assert_allclose(n / np.linalg.norm(n), expected)


def test_transformed_plane_stays_a_plane():
    plane = Plane((0, 1, 0), 1.0)
    cs = compile_scene(Scene(camera=CAM, group=Group([Transform(tf.compose(tf.translate((0, 2, 0)),
                                                                           tf.z_rotate(90)), plane)])))
    # y = 1 rotated by 90 degrees about z is x = -1, then moved up (no effect on x = -1)
    np.testing.assert_allclose(cs.plane_normal[0], [-1, 0, 0], atol=1e-12)
    assert cs.plane_offset[0] == pytest.approx(1.0)


def test_mesh_faces_and_materials_flatten():
    mesh = TriangleMesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]]), [[0, 1, 2], [0, 1, 3]], material=1)
    cs = compile_scene(Scene(camera=CAM, group=Group([mesh, Sphere((0, 0, 0), 1, material=0)])))
    assert cs.counts == (2, 1, 0)
    assert cs.triangle_material.tolist() == [1, 1]


def test_sphere_bounds_of_a_transformed_sphere():
    m = tf.compose(tf.translate((1, 0, 0)), tf.scale((2, 1, 1)))
    cs = compile_scene(Scene(camera=CAM, group=Group([Transform(m, Sphere((0, 0, 0), 1))])))
    lo, hi = sphere_bounds(cs)
    np.testing.assert_allclose(lo, [[-1, -1, -1]])
    np.testing.assert_allclose(hi, [[3, 1, 1]])


def test_mesh_face_index_out_of_range_is_a_value_error():
    with pytest.raises(ValueError, match="out of range"):
        TriangleMesh(np.zeros((3, 3)), [[0, 1, 3]])


# --- texture coordinates (issue 13) ------------------------------------------------------------------------------
def _textured_quad_scene(grid=None):
    import durer

    texels = np.array([[[1, 0, 0], [0, 1, 0]], [[0, 0, 1], [1, 1, 1]]], np.float32)
    quad = durer.TriangleMesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]],
                              uvs=[[0, 0], [1, 0], [1, 1], [0, 1]])
    mirror = np.diag([-1.0, 1.0, 1.0, 1.0])  # x -> -x: the quad appears left of the origin, mirrored
    scene = durer.Scene(camera=durer.OrthographicCamera((0, 0.5, 5), (0, 0, -1), (0, 1, 0), 2.0),
                        group=durer.Group([durer.Transform(np.eye(4), quad), durer.Transform(mirror, quad)]),
                        materials=[durer.PBRMaterial.from_pbr((1, 1, 1), 0.0, 1.0, texture=texels)])
    return scene, texels


def test_uvs_follow_instances_and_mirrors():
    import durer

    scene, texels = _textured_quad_scene()
    cs = compile_scene(scene)
    assert len(cs.instance_mesh) == 2 and cs.has_uv  # one quad stored once, placed twice
    scene.lights = None
    for kwargs in ({}, {"grid": (2, 2, 2)}):  # the two-level BVH, and the grid over the flattened triangles
        r = durer.render(scene, 4, 2, **kwargs)
        # right half: the quad as is (texel columns left to right); left half: mirrored (right to left)
        assert np.allclose(r.color[0, 2], texels[0, 0]) and np.allclose(r.color[0, 3], texels[0, 1])
        assert np.allclose(r.color[1, 1], texels[1, 0]) and np.allclose(r.color[1, 0], texels[1, 1])


def test_scenes_without_uvs_carry_no_uv_arrays():
    import durer

    mesh = durer.TriangleMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    cs = compile_scene(durer.Scene(camera=None, group=durer.Group([mesh])))
    assert not cs.has_uv and cs.triangle_uv.shape == (0, 3, 2)
    assert np.array_equal(cs.uv_at([0], np.zeros((1, 3))), np.zeros((1, 2)))


# --- vertex normals (issue 13: smooth shading of model files) ------------------------------------------------------
def test_normals_follow_transforms_instances_and_mirrors():
    rng = np.random.default_rng(3)
    v = rng.normal(size=(5, 3))
    f = np.array([[0, 1, 2], [1, 3, 4], [0, 2, 4]])
    vn = rng.normal(size=(5, 3))
    mesh = TriangleMesh(v, f, normals=vn)
    mats = [tf.compose(tf.translate((1, 2, 3)), tf.scale((2, 0.5, 1))), tf.scale((-1, 1, 3))]  # the second mirrors
    for placed in ([Transform(mats[0], mesh)], [Transform(m, mesh) for m in mats]):  # flat, then two instances
        cs = compile_scene(Scene(camera=CAM, group=Group(placed)))
        assert cs.has_normals and len(cs.instance_mesh) == (len(placed) if len(placed) > 1 else 0)
        for flat in (cs, cs.flat):
            for k, m in enumerate(mats[:len(placed)]):
                for face in range(len(f)):
                    tid = k * len(f) + face
                    for corner in range(3):
                        p = tf.transform_points(m, v[f[face, corner]][None])
                        expected = np.linalg.inv(m[:3, :3]).T @ (vn[f[face, corner]] / np.linalg.norm(vn[f[face, corner]]))
                        got = flat.normals_at([tid], p)[0]
                        np.testing.assert_allclose(got, expected / np.linalg.norm(expected), atol=1e-9)


def test_smooth_normals_shade_in_closed_form():
    import durer

    tilted = np.tile(np.array([1.0, 0.0, 1.0]) / np.sqrt(2), (3, 1))  # every vertex normal 45 degrees off +z
    tri = [[-1, -1, 0], [1, -1, 0], [0, 1, 0]]
    for normals, expected in ((None, 1.0), (tilted, np.sqrt(0.5)), (-tilted, np.sqrt(0.5))):  # flipped: same side
        scene = Scene(camera=OrthographicCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 4.0),
                      group=Group([TriangleMesh(tri, [[0, 1, 2]], normals=normals)]),
                      materials=[durer.PhongMaterial(diffuse_color=(1, 1, 1))],
                      lights=[durer.DirectionalLight((0, 0, -1), (1, 1, 1))])
        r = durer.render(scene, 3, 3)
        np.testing.assert_allclose(r.color[1, 1], expected, atol=1e-12)


def test_a_smooth_normal_facing_away_is_bent_towards_the_viewer():
    from durer.accel.hits import Hits
    from durer.kernels.common import TRIANGLE
    from durer.rendering.raycaster import smooth_normals

    mesh = TriangleMesh([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]], normals=np.tile([1.0, 0, 0.05], (3, 1)))
    cs = compile_scene(Scene(camera=CAM, group=Group([mesh])))
    d = np.array([[0.6, 0.0, -0.8]])  # hits the front (d.g < 0) but runs along the smooth normal (d.n > 0)
    hits = Hits(np.array([1.0]), np.array([TRIANGLE], np.int8), np.array([0], np.int32), np.zeros(1), np.zeros(1))
    n = smooth_normals(cs, hits, np.zeros((1, 3)), d, np.array([[0.0, 0, 1]]))
    assert d[0] @ n[0] < 0 and np.linalg.norm(n[0]) == pytest.approx(1.0)


def test_compile_walks_the_scene_tree_once_and_nothing_after_it_does():
    """Each Group's children are read once, by compile_scene; the accelerators and the bounds then read only the
    CompiledScene (sphere boxes, which spheres are transformed, placed triangles)."""
    from durer.accel.bvh import BVHAccelerator
    from durer.accel.grid import GridAccelerator

    reads: list[int] = []

    class Counting(Group):
        def __getattribute__(self, name):
            if name == "objects":
                reads.append(id(self))
            return super().__getattribute__(name)

    mesh = TriangleMesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]]), np.array([[0, 1, 2]]))
    inner = Counting([Sphere((0, 0, 0), 0.5), mesh])
    scene = Scene(camera=CAM, group=Counting([Transform(tf.translate((2, 0, 0)), inner), Sphere((0, 0, 0), 1.0),
                                              Transform(tf.scale(2), mesh)]))
    cs = compile_scene(scene)
    assert sorted(reads) == sorted([id(scene.group), id(inner)])
    reads.clear()
    BVHAccelerator(cs)
    GridAccelerator(cs, (4, 4, 4))
    lo, hi = cs.bounds()
    assert reads == []
    assert cs.sphere_transformed.tolist() == [True, False]
    np.testing.assert_allclose(cs.sphere_lo, [[1.5, -0.5, -0.5], [-1, -1, -1]])
    np.testing.assert_allclose((lo, hi), ([-1, -1, -1], [3, 2, 1]))
