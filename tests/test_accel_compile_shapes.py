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
