"""Builds kept between renders (rendering/builds.py): a second render of an unchanged scene compiles nothing and
gives the same image to the bit; a scene changed in any way (arrays in place, values, lists) renders what a fresh
copy of it renders; a new camera is a new view of the kept build; one build per scene, dropped on request or with
the scene."""

from __future__ import annotations

import copy
import dataclasses
import gc

import numpy as np
import pytest

import durer
from durer import Group, PerspectiveCamera, PhongMaterial, Plane, PointLight, Scene, Sphere, Transform, TriangleMesh
from durer.rendering import builds

KW = dict(width=24, height=18, integrator="path", samples=2, max_depth=3, seed=3)


def _scene() -> Scene:
    mesh = TriangleMesh(vertices=[[-1, -1, 0], [1, -1, 0], [-1, 1, 0], [1, 1, 0]], faces=[[0, 1, 2], [1, 3, 2]],
                        material=1)
    return Scene(camera=PerspectiveCamera(center=(0, 0.5, 6), direction=(0, -0.1, -1), up=(0, 1, 0), angle=40),
                 group=Group([Transform(np.eye(4), mesh), Transform(np.diag([0.5, 0.5, 1, 1.0]) @ _shift(2.5), mesh),
                              Sphere(center=(0, 0, 1), radius=0.7), Plane(normal=(0, 1, 0), offset=-1)]),
                 materials=[PhongMaterial(diffuse_color=(0.7, 0.7, 0.7)), PhongMaterial(diffuse_color=(0.8, 0.2, 0.1))],
                 lights=[PointLight(position=(2, 3, 4), color=(1, 1, 1))], background_color=(0.1, 0.1, 0.2))


def _shift(x: float) -> np.ndarray:
    m = np.eye(4)
    m[0, 3] = x
    return m


@pytest.fixture
def compiles(monkeypatch):
    """The number of compile_bundle calls so far (a list of one count)."""
    from durer.rendering import context

    count, real = [0], context.compile_bundle

    def counted(*args, **kwargs):
        count[0] += 1
        return real(*args, **kwargs)
    monkeypatch.setattr(context, "compile_bundle", counted)
    yield count
    builds.drop()


def _render(scene: Scene, **kw) -> np.ndarray:
    return durer.render(scene, **{**KW, **kw}).color


def test_an_unchanged_scene_is_compiled_once(compiles):
    s = _scene()
    first = _render(s)
    again = _render(s)
    assert compiles[0] == 1
    np.testing.assert_array_equal(first, again)
    assert builds.kept_count() >= 1


EDITS = {  # each changes what the image shows; none of them goes through a setter a version counter could see
    "vertices in place": lambda s: s.group.objects[0].object.vertices.__setitem__((slice(None), 1), [-1, -1, 2, 2]),
    "colour in place": lambda s: s.materials[1].diffuse_color.__setitem__(slice(None), [0.1, 0.8, 0.2]),
    "matrix in place": lambda s: s.group.objects[1].matrix.__setitem__((1, 3), 1.0),
    "a value": lambda s: setattr(s.group.objects[2], "radius", 1.1),
    "a list": lambda s: s.group.objects.append(Sphere(center=(-1.5, 1, 0), radius=0.4, material=1)),
    "a light": lambda s: s.lights[0].color.__setitem__(slice(None), [3, 0.5, 0.5]),
    "unshared": lambda s: setattr(s.group.objects[1], "object", copy.deepcopy(s.group.objects[0].object)),
}


@pytest.mark.parametrize("edit", EDITS.values(), ids=EDITS.keys())
def test_a_changed_scene_renders_what_a_fresh_copy_renders(edit, compiles):
    s = _scene()
    before = _render(s)
    edit(s)
    after = _render(s)
    fresh = _render(copy.deepcopy(s))
    np.testing.assert_array_equal(after, fresh)
    # the "unshared" edit leaves the image alone (equal copies render alike) but is a new structure: rebuilt
    assert np.array_equal(after, before) == (edit is EDITS["unshared"])
    assert compiles[0] == 3  # before, after, the fresh copy


def test_a_new_camera_is_a_view_of_the_kept_build(compiles):
    s = _scene()
    _render(s)
    s.camera = PerspectiveCamera(center=(1, 1, 5), direction=(-0.2, -0.2, -1), up=(0, 1, 0), angle=35)
    moved = _render(s)
    assert compiles[0] == 1
    np.testing.assert_array_equal(moved, _render(copy.deepcopy(s)))


def test_one_build_per_scene_dropped_on_request_or_with_the_scene(compiles):
    builds.drop()
    s, t = _scene(), _scene()
    _render(s)
    _render(s, integrator="raycast")  # another accelerator: replaces the kept build
    assert builds.kept_count() == 1 and compiles[0] == 2
    _render(t)
    assert builds.kept_count() == 2
    durer.drop_build(s)
    assert builds.kept_count() == 1
    _render(s, integrator="raycast")
    assert compiles[0] == 4
    del t
    gc.collect()
    assert builds.kept_count() == 1
    durer.drop_build()
    assert builds.kept_count() == 0


def test_counted_renders_and_unreadable_scenes_are_built_every_time(compiles):
    s = _scene()
    _render(s, integrator="raycast", stats=True)
    _render(s, integrator="raycast", stats=True)
    assert compiles[0] == 2
    s.group.objects[2].note = lambda: None  # the fingerprint cannot read it: unknown, so never kept
    a, b = _render(s), _render(s)
    assert compiles[0] == 4
    np.testing.assert_array_equal(a, b)


class _ReadOptions:
    """RenderOptions that records which of its fields are read."""

    def __init__(self, options):
        self._options, self.read = options, set()

    def __getattr__(self, name):
        self.read.add(name)
        return getattr(self._options, name)


@pytest.mark.parametrize("kw", [dict(integrator="path"), dict(integrator="whitted"),
                                dict(integrator="path", course_edges=True), dict(integrator="path", accel="brute")])
def test_a_build_reads_only_the_options_of_its_key(kw):
    """A kept build is reused for any render whose build_key is equal, so the build must not depend on any other
    option (a new option read while building must join the key: context.BUILD_OPTIONS), and each option it reads
    changes the key, except the two whose renders make_context never keeps (stats, grid)."""
    from durer.options import RenderOptions
    from durer.rendering import context

    options = RenderOptions(samples=2, max_depth=3, seed=3, **kw)
    spy = _ReadOptions(options)
    context._build(_scene(), spy)
    assert spy.read and spy.read <= set(context.BUILD_OPTIONS)
    other = {"course_edges": not options.course_edges, "accel": "bvh" if options.accel == "brute" else "brute",
             "integrator": "whitted" if options.integrator == "path" else "path"}
    for name, value in other.items():
        assert context.build_key(dataclasses.replace(options, **{name: value})) != context.build_key(options), name
    assert set(context.BUILD_OPTIONS) - set(other) == {"stats", "grid"}
