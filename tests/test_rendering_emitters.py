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
