"""accel/compile.py on Mitsuba's shapes: the analytic sphere, disk and cylinder and the rectangle and cube meshes
(io/mitsuba_shapes.py) hit where Mitsuba 3 hits them, with its normals and its texture coordinates
(CompiledScene.analytic_uv, uv_at) for the same rays, and their world boxes hold them."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.accel.hits import geometric_normals
from durer.kernels.common import SPHERE, TRIANGLE

SENSOR = {"type": "perspective", "fov": 40}


def _matrix(scale):
    """A rotated, moved and scaled to_world (4x4)."""
    c, s = np.cos(0.35), np.sin(0.35)
    rot = np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])
    move = np.eye(4)
    move[:3, 3] = (0.1, 0.2, 0.3)
    return move @ rot @ np.diag([*scale, 1.0])


SHAPES = [
    ({"type": "sphere", "center": [0.2, -0.1, 0.3], "radius": 0.7}, (1.5, 1.5, 1.5)),
    ({"type": "disk"}, (1.5, 2.5, 1.0)),
    ({"type": "cylinder"}, (1.5, 1.5, 2.0)),
    ({"type": "cylinder", "p0": [0.3, -0.2, 0.1], "p1": [-0.4, 0.5, 1.2], "radius": 0.6}, (1.2, 1.2, 1.2)),
    ({"type": "rectangle"}, (1.5, 2.5, 1.0)),
    ({"type": "cube"}, (1.5, 1.2, 0.8)),
]


@pytest.mark.parametrize("shape,scale", SHAPES, ids=lambda v: v["type"] if isinstance(v, dict) else "")
def test_hits_normals_and_uvs_match_mitsuba(shape, scale):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 gives the reference hits")
    mi.set_variant("scalar_rgb")
    m = _matrix(scale)
    ours = durer.load_dict({"type": "scene", "sensor": SENSOR, "s": {**shape, "to_world": m}})
    theirs = mi.load_dict({"type": "scene", "s": {**shape, "to_world": mi.ScalarTransform4f(m)}})
    rng = np.random.default_rng(7)
    o = rng.normal(size=(400, 3)) * 5
    d = -o + rng.normal(size=(400, 3)) * 0.8
    cs = compile_scene(ours)
    hits = BVHAccelerator(cs).closest_hit(o, d)
    p = o + np.where(hits.hit, hits.t, 0.0)[:, None] * d
    normals = geometric_normals(cs, hits, p)
    found = 0
    for i in range(len(o)):
        si = theirs.ray_intersect(mi.Ray3f(mi.Point3f(o[i]), mi.Vector3f(d[i])))
        if not si.is_valid() or not hits.hit[i]:
            # grazing rays may fall either side of float32's silhouette
            assert si.is_valid() == hits.hit[i] or abs(np.dot(np.array(si.n), d[i])) < 0.05 * np.linalg.norm(d[i])
            continue
        found += 1
        assert hits.t[i] == pytest.approx(si.t, rel=1e-4)
        np.testing.assert_allclose(normals[i], np.array(si.n), atol=1e-4)
        if hits.kind[i] == SPHERE:
            uv = cs.analytic_uv(hits.prim[i:i + 1], p[i:i + 1])[0]
        else:
            assert hits.kind[i] == TRIANGLE
            uv = cs.uv_at(hits.prim[i:i + 1], p[i:i + 1])[0]
        ref = np.array(si.uv)
        if shape["type"] != "disk":  # phi wraps at 2 pi: compare u on the circle
            uv[0], ref[0] = np.cos(2 * np.pi * uv[0]), np.cos(2 * np.pi * ref[0])
        else:
            uv[1], ref[1] = np.cos(2 * np.pi * uv[1]), np.cos(2 * np.pi * ref[1])
        np.testing.assert_allclose(uv, ref, atol=2e-4)
    assert found > 40
    lo, hi = cs.bounds()
    inside = p[hits.hit]
    assert (inside >= lo - 1e-9).all() and (inside <= hi + 1e-9).all()


@pytest.mark.parametrize("kind", ["disk", "cylinder"])
def test_world_boxes_are_tight(kind):
    """The box of a disk or cylinder touches the shape: points sampled on it reach each face within 1%."""
    m = _matrix((1.5, 0.7, 2.0))
    cs = compile_scene(durer.load_dict({"type": "scene", "sensor": SENSOR, "s": {"type": kind, "to_world": m}}))
    lo, hi = cs.bounds()
    phi = np.linspace(0, 2 * np.pi, 4001)
    pts = [np.column_stack([np.cos(phi), np.sin(phi), np.full_like(phi, z), np.ones_like(phi)])
           for z in ((0.0,) if kind == "disk" else (0.0, 1.0))]
    world = (np.concatenate(pts) @ m.T)[:, :3]
    np.testing.assert_allclose(world.min(0), lo, atol=1e-3 * np.ptp(world))
    np.testing.assert_allclose(world.max(0), hi, atol=1e-3 * np.ptp(world))


def test_every_accelerator_finds_the_same_disk_and_cylinder_hits():
    """Brute force, the course's grid and the BVH (single rays and 4 x 4 packets of an image) agree on t, kind and
    primitive for a scene of disks and cylinders, one of each unmoved (world = object space)."""
    from durer.accel.brute import BruteForce
    from durer.accel.grid import GridAccelerator

    lift = [np.eye(4) + np.pad([[0.7 * i - 0.7], [0.3 * i], [0.4 * i]], ((0, 1), (3, 0))) for i in range(3)]
    objects = {f"d{i}": {"type": "disk", "to_world": lift[i] @ _matrix((0.5 + 0.2 * i, 0.4, 1.0))} for i in range(3)}
    objects.update({f"c{i}": {"type": "cylinder", "p0": [i - 1.0, -0.5, 0.2 * i], "p1": [i - 0.8, 0.6, 0.5],
                              "radius": 0.2} for i in range(3)})
    objects.update({"plain_disk": {"type": "disk"}, "plain_tube": {"type": "cylinder", "radius": 0.3}})
    cs = compile_scene(durer.load_dict({"type": "scene", "sensor": SENSOR, **objects}))
    side = 32
    u, v = np.meshgrid(np.linspace(-2, 2, side), np.linspace(-2, 2, side))
    o = np.column_stack([u.ravel(), v.ravel(), np.full(side * side, 6.0)])
    d = np.tile([0.05, -0.03, -1.0], (side * side, 1))
    want = BruteForce(cs).closest_hit(o, d)
    assert (want.kind == SPHERE).sum() > 50
    for accel, width in ((BVHAccelerator(cs), 0), (BVHAccelerator(cs), side), (GridAccelerator(cs, (8, 8, 8)), 0)):
        got = accel.closest_hit(o, d, width=width)
        np.testing.assert_array_equal(got.kind, want.kind)
        np.testing.assert_array_equal(got.prim, want.prim)
        np.testing.assert_allclose(got.t, want.t, rtol=1e-12)
        np.testing.assert_array_equal(accel.any_hit(o, d, width=width), want.hit)
