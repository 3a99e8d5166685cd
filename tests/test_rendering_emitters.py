"""Emitters of the path tracer: light sampling integrates to the closed-form solid angles and irradiances, and the
pdf of a sampled point equals what pdf_hit reports for it (the two halves of MIS agree)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import durer
from durer.accel.compile import compile_scene
from durer.rendering.bsdfs import BSDFTable
from durer.rendering.emitters import Emitters
from durer.scene.bsdfs import Diffuse, Surface
from durer.scene.lights import ConstantEnvironment

N = 200000


def _emitters(objects, materials, lights=(), environment=None) -> Emitters:
    cam = durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 40)
    scene = durer.Scene(camera=cam, group=durer.Group(list(objects)), materials=list(materials),
                        lights=list(lights), environment=environment, radiometric_lights=True)
    return Emitters.build(scene, compile_scene(scene), BSDFTable.from_materials(scene.materials))


def _sample(em, p):
    rng = np.random.default_rng(0)
    ps = np.tile(p, (N, 1))
    return ps, em.sample(ps, rng.random(N), rng.random((N, 2)))


def test_sphere_light_integrates_to_its_solid_angle_and_pdfs_agree():
    r, c = 0.5, np.array([0.0, 0.0, -2.0])
    em = _emitters([durer.Sphere(c, r, 0)], [Surface(Diffuse(), 3.0)])
    p = np.zeros(3)
    ps, (d, dist, w, pdf) = _sample(em, p)
    cos_max = math.sqrt(1 - (r / 2.0) ** 2)
    assert w[:, 0].mean() == pytest.approx(3.0 * 2 * math.pi * (1 - cos_max), rel=1e-9)  # cone: exact per sample
    y = ps + dist[:, None] * d
    np.testing.assert_allclose(np.linalg.norm(y - c, axis=1), r, rtol=1e-9)
    np.testing.assert_allclose(em.pdf_hit(np.zeros(N, int), ps, y, (y - c) / r), pdf, rtol=1e-9)


def test_rectangle_light_integrates_to_its_solid_angle_and_pdfs_agree():
    a, h = 0.5, 1.5  # a square of half-side a, facing down, h above the point
    v = np.array([[-a, h, -a], [a, h, -a], [a, h, a], [-a, h, a]])
    mesh = durer.TriangleMesh(v, [[0, 1, 2], [0, 2, 3]], 0)  # normal -y, towards the point
    em = _emitters([mesh], [Surface(Diffuse(), 2.0)])
    ps, (d, dist, w, pdf) = _sample(em, np.zeros(3))
    omega = 4 * math.asin(a * a / (a * a + h * h))
    assert w[:, 0].mean() == pytest.approx(2.0 * omega, rel=0.01)
    y = ps + dist[:, None] * d
    np.testing.assert_allclose(y[:, 1], h, rtol=1e-9)
    normal = np.tile([0.0, -1.0, 0.0], (N, 1))
    np.testing.assert_allclose(em.pdf_hit(np.zeros(N, int), ps, y, normal), pdf, rtol=1e-9)
    # one-sided: from above, the light is dark
    _, (_, _, w_back, _) = _sample(em, np.array([0.0, 3.0, 0.0]))
    assert w_back.max() == 0


def test_point_directional_and_environment_lights():
    point = durer.PointLight((0, 3, 0), (9, 9, 9), (0, 0, 1))
    sun = durer.DirectionalLight((0, -1, 0), (2, 2, 2))
    em = _emitters([], [Surface(Diffuse())], [point, sun], ConstantEnvironment(0.5))
    assert em.count == 3
    ps, (d, dist, w, pdf) = _sample(em, np.zeros(3))
    pick = [np.isinf(pdf) & (dist < np.inf), np.isinf(pdf) & np.isinf(dist), np.isfinite(pdf)]
    assert [k.mean() for k in pick] == pytest.approx([1 / 3] * 3, abs=0.01)  # picked uniformly
    np.testing.assert_allclose(w[pick[0]], 3 * 9 / 9)    # I / d^2, times the 3 emitters of the pick
    np.testing.assert_allclose(w[pick[1]], 3 * 2)        # irradiance
    assert w[pick[2]][:, 0].mean() == pytest.approx(3 * 0.5 * 4 * math.pi)  # environment: L * 4 pi
    np.testing.assert_allclose(d[pick[1]], [[0, 1, 0]] * pick[1].sum())


def test_course_lights_are_scaled_by_pi_and_ambient_becomes_the_environment():
    cam = durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 40)
    scene = durer.Scene(camera=cam, group=durer.Group([]), lights=[durer.DirectionalLight((0, -1, 0), (1, 1, 1))],
                        ambient_light=(0.2, 0.2, 0.2))
    em = Emitters.build(scene, compile_scene(scene), BSDFTable.from_materials(scene.materials))
    np.testing.assert_allclose(em.radiance[0], math.pi)
    np.testing.assert_allclose(em.environment, 0.2)


def _sky(h=16, w=32):
    v = (np.arange(h)[:, None] + 0.5) / h
    u = (np.arange(w)[None, :] + 0.5) / w
    img = np.zeros((h, w, 3))
    img[..., 0], img[..., 1], img[..., 2] = 0.3 + 0.5 * u, 0.4 * (1 - v), 0.8 * (1 - v) + 0.1
    img[3:5, 20:22] = [40.0, 35.0, 30.0]  # a small sun
    return img


def test_environment_map_sampling_is_a_density_and_matches_its_pdf():
    from durer.rendering.envmap import EnvMapLight
    from durer.scene.lights import EnvironmentMap
    from durer.scene.transforms import rotate

    light = EnvMapLight(EnvironmentMap(_sky(), 2.0, rotate((0, 1, 0), 30)))
    rng = np.random.default_rng(5)
    d = rng.normal(size=(N, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)  # uniform on the sphere
    # integrates to one: pdf * sin(theta) is constant on each cell of the 32 x 15 texel grid (texel centres at
    # u = (i + 1/2) / 32), so the midpoint rule on 4 x 4 points per cell is exact up to rounding
    th = (np.arange(15 * 4) + 0.5) / (15 * 4) * np.pi
    ph = ((np.arange(32 * 4) + 0.5) / 4 + 0.5) / 32 * 2 * np.pi
    tt, pp = np.meshgrid(th, ph, indexing="ij")
    local = np.column_stack([(np.sin(tt) * np.sin(pp)).ravel(), np.cos(tt).ravel(), -(np.sin(tt) * np.cos(pp)).ravel()])
    grid = local @ rotate((0, 1, 0), 30)[:3, :3].T
    total = (light.pdf(grid) * np.sin(tt).ravel()).sum() * (np.pi / 60) * (2 * np.pi / 128)
    assert total == pytest.approx(1.0, rel=1e-9)
    s, pdf = light.sample(rng.random((N, 2)))
    # the sampler's pdf is taken at its texel coordinates, pdf() maps the direction back (acos rounds near the poles)
    np.testing.assert_allclose(light.pdf(s), pdf, rtol=1e-7)
    # importance sampling and uniform sampling estimate the same irradiance-like integral of L over the sphere
    by_pdf = (light.eval(s) / pdf[:, None]).mean(axis=0)
    uniform = (light.eval(d) * 4 * np.pi).mean(axis=0)
    np.testing.assert_allclose(by_pdf, uniform, rtol=0.03)
    assert (light.eval(s) / pdf[:, None]).std(axis=0)[0] < (light.eval(d) * 4 * np.pi).std(axis=0)[0] / 3


def test_disk_light_integrates_to_its_solid_angle_and_pdfs_agree():
    """A unit disk 2 above the point, facing it (Mitsuba's disk faces +z: turned over by a mirror in z):
    solid angle 2 pi (1 - h / sqrt(h^2 + r^2)); sampled points lie on it, and pdf_hit gives their pdfs."""
    h = 2.0
    disk = durer.Transform(np.diag([1.0, 1.0, -1.0, 1.0]) @ _moved((0, 0, -h)), durer.Disk(0))
    em = _emitters([disk], [Surface(Diffuse(), 2.0)])
    ps, (d, dist, w, pdf) = _sample(em, np.zeros(3))
    assert w[:, 0].mean() == pytest.approx(2.0 * 2 * math.pi * (1 - h / math.hypot(h, 1.0)), rel=0.01)
    y = ps + dist[:, None] * d
    np.testing.assert_allclose(y[:, 2], h, rtol=1e-9)
    assert np.hypot(y[:, 0], y[:, 1]).max() <= 1 + 1e-9
    normal = np.tile([0.0, 0.0, -1.0], (N, 1))
    np.testing.assert_allclose(em.pdf_hit(np.zeros(N, int), ps, y, normal), pdf, rtol=1e-9)


def test_cylinder_light_seen_from_its_axis_integrates_to_its_solid_angle():
    """From the centre of a tube of radius a and length 2 l (a flattened cross-section, so the area changes along
    the rim), the inner wall's solid angle is 4 pi l / sqrt(l^2 + a^2); the tube emits inwards (flip_normals)."""
    a, b, l = 1.0, 0.5, 1.5
    tube = durer.Transform(_moved((0, 0, -l)) @ np.diag([a, b, 2 * l, 1.0]), durer.Cylinder(material=0))
    em = _emitters([tube], [Surface(Diffuse(), 1.0, flip_normals=True)])
    ps, (d, dist, w, pdf) = _sample(em, np.zeros(3))
    # the solid angle of the elliptic tube: integrate the cone boundaries over the azimuth numerically
    phi = np.linspace(0, 2 * np.pi, 200001)
    rho = 1.0 / np.sqrt((np.cos(phi) / a) ** 2 + (np.sin(phi) / b) ** 2)
    omega = np.trapezoid(2 * l / np.hypot(l, rho), phi)
    assert w[:, 0].mean() == pytest.approx(omega, rel=0.01)
    y = ps + dist[:, None] * d
    np.testing.assert_allclose((y[:, 0] / a) ** 2 + (y[:, 1] / b) ** 2, 1.0, rtol=1e-9)
    normal = -np.column_stack([y[:, 0] / a ** 2, y[:, 1] / b ** 2, np.zeros(N)])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    np.testing.assert_allclose(em.pdf_hit(np.zeros(N, int), ps, y, normal), pdf, rtol=1e-7)


def _moved(t) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = t
    return m


@pytest.mark.parametrize("falloff", ["angle", "gltf"])
def test_spot_light_sends_intensity_times_its_falloff(falloff):
    spot = durer.SpotLight((0, 0, 0), (0, 0, 1), (5, 5, 5), 15, 20, (0, 0, 1), falloff)
    em = _emitters([], [Surface(Diffuse())], [spot])
    angles = np.radians([0, 10, 15.5, 17, 19, 19.9, 21, 90])
    p = 2.0 * np.column_stack([np.sin(angles), np.zeros(len(angles)), np.cos(angles)])
    _, dist, w, pdf = em.sample(p, np.zeros(len(p)), np.zeros((len(p), 2)))
    assert np.isinf(pdf).all()
    np.testing.assert_allclose(dist, 2.0)
    expect = 5 / 4 * spot.cone_factor(-p / 2.0)
    np.testing.assert_allclose(w[:, 0], expect, rtol=1e-9, atol=1e-300)
    if falloff == "angle":  # Mitsuba 3.9's spot (measured): linear in the angle from beam_width to cutoff_angle
        np.testing.assert_allclose(expect, 5 / 4 * np.array([1, 1, 0.9, 0.6, 0.2, 0.02, 0, 0]), atol=1e-9)


def _render_both(scene: dict, spp: int):
    """The same dict scene rendered by durer and by Mitsuba 3 (scalar_rgb) at equal samples."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference")
    mi.set_variant("scalar_rgb")
    ours = np.asarray(durer.render(durer.load_dict(scene), samples=spp).color)[..., :3]

    def mitsuba_dict(d):
        return {k: mi.ScalarTransform4f(v) if k == "to_world" else (mitsuba_dict(v) if isinstance(v, dict) else v)
                for k, v in d.items()}

    ref = np.array(mi.render(mi.load_dict(mitsuba_dict(scene)), spp=spp, seed=3))[..., :3]
    return ours, ref


def _look(origin, target, up) -> np.ndarray:
    """Mitsuba's look_at as a 4x4 array."""
    from durer.io.mitsuba_values import look_at

    return look_at(np.asarray(origin, float), np.asarray(target, float), np.asarray(up, float))


def _base(**shapes) -> dict:
    return {"type": "scene", "integrator": {"type": "direct"},
            "sensor": {"type": "perspective", "fov": 50, "to_world": _look((0, 0, 0), (0, 0, 1), (0, 1, 0)),
                       "film": {"type": "hdrfilm", "width": 32, "height": 32, "rfilter": {"type": "box"}}},
            "plane": {"type": "rectangle", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": 0.8}},
                      "to_world": np.array([[-3.0, 0, 0, 0], [0, 3, 0, 0], [0, 0, -1, 1.0], [0, 0, 0, 1]])},
            **shapes}


def test_spot_light_on_a_plane_matches_mitsuba():
    """Mitsuba's spot (cutoff 20, beam 15 degrees) lighting a diffuse plane 1 away: the same pixels."""
    spot = {"type": "spot", "intensity": {"type": "rgb", "value": 5.0}, "cutoff_angle": 20, "beam_width": 15,
            "to_world": _look((0, 0, 0), (0.1, 0, 1), (0, 1, 0))}
    ours, ref = _render_both(_base(light=spot), 16)
    assert ref.mean() > 0.05
    assert ours.mean() == pytest.approx(ref.mean(), rel=0.01)
    beam = (ref > 0.9 * np.percentile(ref, 90)).all(axis=2)  # inside the beam, and pixels whose neighbours are:
    beam[1:-1, 1:-1] &= beam[:-2, 1:-1] & beam[2:, 1:-1] & beam[1:-1, :-2] & beam[1:-1, 2:]  # the falloff is apart
    assert beam.sum() > 50
    np.testing.assert_allclose(ours[beam], ref[beam], rtol=0.01)
    ring = (ref > 0.05).all(axis=2) & ~beam  # the falloff: each pixel as Mitsuba's, up to which points the samples hit
    assert np.abs(ours[ring] - ref[ring]).mean() < 0.03 * ref.max()


def test_disk_and_cylinder_lights_match_mitsuba():
    """Area emitters on an exact disk and an open cylinder light a plane as in Mitsuba (mean within 2%)."""
    disk = {"type": "disk", "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [4.0, 2.0, 1.0]}},
            "to_world": _look((0.5, 0.4, 0.6), (0.5, 0.4, 1.0), (0, 1, 0)) @ np.diag([0.2, 0.3, 1, 1])}
    tube = {"type": "cylinder", "radius": 0.1, "p0": [-0.6, -0.3, 0.7], "p1": [-0.2, 0.5, 0.8],
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [1.0, 2.0, 4.0]}}}
    ours, ref = _render_both(_base(disk=disk, tube=tube), 64)
    assert ref.mean() > 0.02
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.02)


def test_spot_texture_coordinates_are_mitsubas_projection():
    """SpotLight.texture_uv (the lookup a projected texture will use) against Mitsuba's spot: a checkerboard
    texture there lights exactly the points whose durer coordinates fall in its color0 cells."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 gives the reference")
    mi.set_variant("scalar_rgb")
    m = _look((0.3, 0.2, -0.5), (0.5, 0.1, 1.0), (0, 1, 0))
    spot = durer.load_dict({"type": "scene", "sensor": {"type": "perspective"},
                            "light": {"type": "spot", "cutoff_angle": 20, "to_world": m}}).lights[0]
    checker = {"type": "checkerboard", "color0": {"type": "rgb", "value": [1, 0, 0]},
               "color1": {"type": "rgb", "value": [0, 0, 1]}, "to_uv": mi.ScalarTransform4f().scale([7, 5, 1])}
    theirs = mi.load_dict({"type": "scene", "e": {"type": "spot", "cutoff_angle": 20, "beam_width": 19.99,
                                                  "to_world": mi.ScalarTransform4f(m), "texture": checker}})
    emitter = theirs.emitters()[0]
    rng = np.random.default_rng(0)
    local = np.column_stack([rng.uniform(-0.3, 0.3, 300), rng.uniform(-0.3, 0.3, 300), np.ones(300)])
    points = (local * rng.uniform(1, 3, (300, 1))) @ m[:3, :3].T + m[:3, 3]
    uv = spot.texture_uv(points) * [7, 5]
    red = (uv[:, 0] % 1 > 0.5) == (uv[:, 1] % 1 > 0.5)
    seen = 0
    for p, want in zip(points, red, strict=True):
        it = mi.Interaction3f()
        it.p = mi.Point3f(p)
        w = np.array(emitter.sample_direction(it, mi.Point2f(0.5, 0.5))[1])
        if w.max() > 0:
            seen += 1
            assert (w[0] > 0) == want and (w[2] > 0) != want
    assert seen > 200


def _spot_with_bitmap(tmp_path):
    """A small sRGB PNG, and a spot dict (cutoff 20, beam 15 degrees, tilted) projecting it."""
    from PIL import Image

    img = np.random.default_rng(5).integers(0, 256, (6, 8, 3), dtype=np.uint8)
    Image.fromarray(img).save(tmp_path / "slide.png")
    return {"type": "spot", "cutoff_angle": 20.0, "beam_width": 15.0,
            "intensity": {"type": "rgb", "value": [5.0, 4.0, 3.0]},
            "texture": {"type": "bitmap", "filename": str(tmp_path / "slide.png")},
            "to_world": _look((0.3, 0.2, -0.5), (0.5, 0.1, 1.0), (0.2, 1, 0))}


def test_spot_texture_multiplies_the_intensity_as_mitsubas(tmp_path):
    """A spot projecting a bitmap: durer's light sample from each point carries Mitsuba's sample_direction
    weight (intensity x falloff x texture at the projected uv / d^2), and the ray caster's shading the same."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 gives the reference")
    mi.set_variant("scalar_rgb")
    from durer.rendering.shading import light_directions

    spot_dict = _spot_with_bitmap(tmp_path)
    spot = durer.load_dict({"type": "scene", "sensor": {"type": "perspective"}, "light": spot_dict}).lights[0]
    assert spot.texture is not None
    theirs = mi.load_dict({**spot_dict, "to_world": mi.ScalarTransform4f(spot_dict["to_world"])})
    m = spot_dict["to_world"]
    rng = np.random.default_rng(1)
    local = np.column_stack([rng.uniform(-0.4, 0.4, 400), rng.uniform(-0.4, 0.4, 400), np.ones(400)])
    points = (local * rng.uniform(1, 3, (400, 1))) @ m[:3, :3].T + m[:3, 3]
    em = _emitters([], [Surface(Diffuse())], [spot])
    _, _, w, _ = em.sample(points, np.zeros(len(points)), np.zeros((len(points), 2)))
    ref = np.zeros_like(w)
    for i, p in enumerate(points):
        it = mi.Interaction3f()
        it.p = mi.Point3f(p)
        ref[i] = np.array(theirs.sample_direction(it, mi.Point2f(0.5, 0.5))[1])
    lit = ref.max(axis=1) > 0
    assert lit.sum() > 200 and (~lit).sum() > 20
    assert len(np.unique(np.round(ref[lit] / np.maximum(ref[lit].max(1, keepdims=True), 1e-9), 3), axis=0)) > 20
    np.testing.assert_allclose(w, ref, rtol=2e-4, atol=1e-6)
    _, colour, _ = light_directions(spot, points)
    np.testing.assert_allclose(colour, w, rtol=1e-9, atol=1e-12)


def test_textured_spot_on_a_plane_matches_mitsuba(tmp_path):
    """The textured spot lighting a diffuse plane: Mitsuba's image, pixel by pixel up to the pixels' sampling."""
    spot = {**_spot_with_bitmap(tmp_path), "to_world": _look((0, 0, 0), (0.1, 0, 1), (0, 1, 0))}
    ours, ref = _render_both(_base(light=spot), 16)
    assert ref.mean() > 0.05
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.02)
    assert np.abs(ours - ref).mean() < 0.05 * ref.mean()
