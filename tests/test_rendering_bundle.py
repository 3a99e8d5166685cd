"""The compiled scene bundle (rendering/bundle.py) is the one seam between the scene and the render: once a context
is made, the render, explain and a pickled job never read the Scene again, and nothing compiles or builds a table
again. Proved by a tripwire: after make_context the Scene object raises on any attribute access (and cannot be
pickled), and compile and every table builder raise when called; the images must still be durer.render's to the
bit."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import durer
from durer.options import RenderOptions
from durer.rendering import film
from durer.rendering import units as U
from durer.rendering.bundle import compile_bundle
from durer.rendering.context import make_context
from durer.rendering.explain import explain_in
from durer.rendering.integrators import PATH, RAYCAST, WHITTED, integrator_for
from durer.rendering.renderer import resolve
from durer.scene.graph import Group, Scene
from durer.scene.materials import PBRMaterial, PhongMaterial
from durer.scene.textures import Noise
from durer.scene.transforms import scale

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


class _Gone(Scene):
    """A Scene after compile: reading anything of it is a failure of the seam."""

    def __getattribute__(self, name):
        raise AssertionError(f"the render read scene.{name} after compile")


def _boom(*args, **kwargs):
    raise AssertionError("compile or a table builder ran after the context was made")


def _tripwire(scene: Scene, monkeypatch) -> None:
    scene.__class__ = _Gone
    for target in ("durer.accel.compile.compile_scene", "durer.rendering.bundle.compile_scene",
                   "durer.rendering.bundle.compile_bundle", "durer.rendering.context.compile_bundle",
                   "durer.rendering.bsdfs.BSDFTable.from_materials", "durer.rendering.emitters.Emitters.build",
                   "durer.rendering.shading.MaterialTable.from_materials"):
        monkeypatch.setattr(target, _boom)


def _course_scene() -> Scene:
    """Lights, a solid texture, a glowing PBR material, a mirror and glass: every table the course integrators
    and the path tracer read."""
    from durer import DirectionalLight, PerspectiveCamera, Plane, PointLight, Sphere

    materials = [PhongMaterial(diffuse_color=(0.8, 0.3, 0.2), specular_color=(0.5, 0.5, 0.5), exponent=20),
                 PhongMaterial(diffuse_color=(0.1, 0.4, 0.8), reflective_color=(0.5, 0.5, 0.5)),
                 Noise(0, 1, octaves=3, matrix=scale((3.0, 3.0, 3.0))),
                 PhongMaterial(diffuse_color=(0, 0, 0), transparent_color=(0.9, 0.9, 0.9), index_of_refraction=1.3),
                 PBRMaterial(diffuse_color=(0.2, 0.2, 0.2), emission=(0.3, 0.2, 0.1))]
    group = Group([Sphere(center=(-1.1, 0, 0), radius=0.9, material=2), Sphere(center=(1.1, 0, 0), radius=0.9,
                                                                                  material=3),
                   Sphere(center=(0, 1.3, -1), radius=0.5, material=4), Plane(normal=(0, 1, 0), offset=-1,
                                                                               material=1)])
    return Scene(camera=PerspectiveCamera(center=(0, 1, 6), direction=(0, -0.15, -1), up=(0, 1, 0), angle=40),
                 group=group, materials=materials,
                 lights=[DirectionalLight(direction=(-0.3, -1, -0.5), color=(0.7, 0.7, 0.7)),
                         PointLight(position=(2, 3, 3), color=(0.6, 0.6, 0.6))],
                 background_color=(0.1, 0.2, 0.3), ambient_light=(0.1, 0.1, 0.1))


CASES = [  # (scene, keyword arguments): the ray caster, the Whitted tracer and the path tracer
    (_course_scene, dict(integrator="raycast", aovs=True)),
    (_course_scene, dict(shadows=True, bounces=3, samples=4)),
    (_course_scene, dict(integrator="path", samples=4, max_depth=4)),
    (lambda: durer.load(EXAMPLES / "cornell_box.xml"), dict(samples=4)),
]


@pytest.mark.parametrize("make, kwargs", CASES, ids=["raycast", "whitted", "path-course", "path-cornell"])
def test_the_render_never_returns_to_the_scene(make, kwargs, monkeypatch):
    """The units of work (locally and after pickling, as a Dask worker gets them) and explain give durer.render's
    pixels with the Scene unreadable and compile and the table builders gone."""
    width, height = 24, 18
    expected = durer.render(make(), width, height, **kwargs)
    scene = make()
    width, height, options = resolve(scene, width, height, None, **kwargs)
    ctx = make_context(scene, options)
    _tripwire(scene, monkeypatch)
    job = U.job_for(ctx, width, height)
    result = U.finish(job, U.run(job))
    np.testing.assert_array_equal(result.color, expected.color)
    np.testing.assert_array_equal(result.depth, expected.depth)
    remote = pickle.loads(pickle.dumps(job))  # would fail on the Scene if the job could reach it
    tile = U.Tile(0, 0, 8, 8)
    np.testing.assert_array_equal(U.render_unit(remote, tile, range(options.samples)).sums,
                                  U.render_unit(job, tile, range(options.samples)).sums)
    tree = explain_in(ctx, width, height, 12, 9)
    np.testing.assert_allclose(tree.color, expected.color[9, 12], atol=2e-6)


def test_the_bundle_holds_the_scene_wide_settings_and_tables():
    scene = _course_scene()
    b = compile_bundle(scene, RenderOptions())
    np.testing.assert_array_equal(b.background, [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(b.ambient, [0.1, 0.1, 0.1])
    assert len(b.lights) == 2 and not b.radiometric and not b.physical and not b.textured
    assert b.materials[2] is scene.materials[2]  # the solid texture, evaluated at hit points from its object
    np.testing.assert_array_equal(b.phong.emission[4], [0.3, 0.2, 0.1])
    assert not b.phong.emission[:4].any()
    np.testing.assert_array_equal(b.phong.diffuse[1], [0.1, 0.4, 0.8])
    # the course lights (scaled by pi) and the ambient light (a constant environment) are the path tracer's
    assert b.emitters.count == 3 and b.emitters.has_environment
    np.testing.assert_allclose(b.emitters.radiance[1], np.pi * 0.6)
    np.testing.assert_array_equal(b.emitters.environment, [0.1, 0.1, 0.1])
    assert len(b.bsdfs.kind) == len(scene.materials)
    mitsuba = compile_bundle(durer.load(EXAMPLES / "cornell_box.xml"), RenderOptions(integrator="path"))
    assert mitsuba.physical and mitsuba.radiometric and mitsuba.lights == ()  # its light is an area emitter
    assert mitsuba.emitters.count == 1 and not mitsuba.emitters.has_environment


def test_film_samples_follow_the_integrators_registration():
    """Whether film samples come from the integrator's Sobol stream is a trait of its registration."""
    assert PATH.sobol and not RAYCAST.sobol and not WHITTED.sobol
    for integrator in ("auto", "raycast", "whitted", "path"):
        options = RenderOptions(integrator=integrator)
        assert film.uses_sobol(options) is integrator_for(options).sobol
    assert film.uses_sobol(RenderOptions(integrator="path"))
    assert not film.uses_sobol(RenderOptions(shadows=True))
