"""The path tracer: furnace closed forms, max_depth's meaning, MIS weights, determinism across thread counts and
batch sizes, course scenes, and a Mitsuba XML scene against Mitsuba 3's own render when Mitsuba is installed."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from conftest import COURSE, needs_course
from hypothesis import given, settings
from hypothesis import strategies as st

import durer
from durer.accel.bvh import BVHAccelerator
from durer.kernels.path.warps import power_heuristic1
from durer.rendering import integrators as I
from durer.rendering import path as P
from durer.rendering.context import make_context
from durer.rendering.renderer import render_in, resolve
from durer.rendering.sampling import sobol_pair
from durer.scene.bsdfs import Diffuse, Surface

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def furnace(rho: float, radiance: float) -> durer.Scene:
    """A closed diffuse sphere (albedo rho, emitting `radiance` inwards) seen from its centre."""
    cam = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 90)
    return durer.Scene(camera=cam, group=durer.Group([durer.Sphere((0.1, -0.05, 0.0), 1.0, 0)]),
                       materials=[Surface(Diffuse(rho), radiance, flip_normals=True)], lights=[],
                       radiometric_lights=True)


@pytest.mark.parametrize("max_depth,expected", [(1, 1.0), (2, 1.6), (4, 1 + 0.6 + 0.36 + 0.216),
                                                (-1, 1 / (1 - 0.6))])
def test_furnace(max_depth, expected):
    """L (1 + rho + ... + rho^(max_depth - 1)) inside the furnace, L / (1 - rho) unbounded (Russian roulette)."""
    r = durer.render(furnace(0.6, 1.0), 8, 8, integrator="path", samples=16, max_depth=max_depth)
    assert r.color.mean() == pytest.approx(expected, rel=0.01)


def test_max_depth_one_shows_emitters_only_and_hide_emitters_hides_them():
    scene = durer.load(EXAMPLES / "cornell_box.xml")
    r = durer.render(scene, 24, 24, samples=1, max_depth=1)
    lit = r.color.max(axis=2) > 0
    assert 0 < lit.sum() < 24 * 24 * 0.1  # the light only
    np.testing.assert_allclose(r.color[lit].max(0), [18.387, 13.9873, 6.75357], rtol=1e-5)
    hidden = durer.render(scene, 24, 24, samples=1, max_depth=1, hide_emitters=True)
    assert hidden.color.max() == 0


@settings(deadline=None)  # the first example may compile the kernel (cold Numba cache)
@given(st.floats(0, 1e6), st.floats(0, 1e6))
def test_mis_weights_sum_to_one(a, b):
    w = power_heuristic1(a, b) + power_heuristic1(b, a)
    assert w == pytest.approx(1.0) or (a == 0 and b == 0 and w == 0)


def test_sobol_pairs_are_stratified():
    """16 samples of one pixel put one point in each cell of the 4 x 4, 2 x 8 and 8 x 2 grids ((0, 2)-sequence)."""
    p = sobol_pair(np.full(16, 12345, np.uint64), np.arange(16), 3)
    for nx in (4, 2, 8):
        cells = np.floor(p[:, 0] * nx).astype(int) * (16 // nx) + np.floor(p[:, 1] * (16 // nx)).astype(int)
        assert len(np.unique(cells)) == 16


def test_same_image_whatever_threads_and_batch(monkeypatch):
    """The same image to the bit whether one thread traces everything (Numba threads 1: one wavefront at a time),
    one wavefront splits its bounces over every thread (2^16-path wavefronts: this image is one), or up to
    min(workers, threads) units in batches of 37 paths run at once with the threads shared out; another seed gives another
    image."""
    numba = pytest.importorskip("numba")
    scene = durer.load(EXAMPLES / "caustic.xml")
    kw = dict(samples=2, max_depth=6)
    numba.set_num_threads(1)
    one = durer.render(scene, 16, 16, **kw).color
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    many = durer.render(scene, 16, 16, **kw).color
    monkeypatch.setattr(I, "PATH", dataclasses.replace(I.PATH, batch=37, workers=3))
    small = durer.render(scene, 16, 16, **kw).color
    np.testing.assert_array_equal(one, many)
    np.testing.assert_array_equal(one, small)
    assert not np.array_equal(one, durer.render(scene, 16, 16, seed=1, **kw).color)


def test_fused_bounce_gives_the_unfused_image(monkeypatch, tmp_path):
    """The one-kernel bounce (kernels/path/wavefront.py) against the wavefront of accelerator queries and passes it
    replaces: the same image, depth and normals to the bit, over point, directional, constant and area emitters,
    an environment map (alone, and picked beside a point light), glass, rough and smooth BSDFs, spheres and (course
    scene) planes and a background colour."""
    (tmp_path / "mixed.xml").write_text(MIXED)
    np.save(tmp_path / "sky.npy", sky())
    env = ENVMAP.replace("sky.exr", "sky.npy")
    (tmp_path / "env.xml").write_text(env)
    point = '<emitter type="point"><point name="position" x="1" y="3" z="1"/><rgb name="intensity" value="4"/></emitter>'
    (tmp_path / "env_point.xml").write_text(env.replace("</scene>", point + "</scene>"))
    scenes = [durer.load(tmp_path / name) for name in ("mixed.xml", "env.xml", "env_point.xml")]
    scenes.append(durer.load(EXAMPLES / "caustic.xml"))
    course = COURSE / "assignment4" / "scene4_04_reflective_sphere.txt"
    if course.is_file():
        scenes.append(durer.load(course))
    calls = []
    fused_kernel = P.trace_bounce
    monkeypatch.setattr(P, "trace_bounce", lambda *a: calls.append(1) or fused_kernel(*a))
    for scene in scenes:
        kw = dict(integrator="path", samples=2, max_depth=-1, seed=3)
        with monkeypatch.context() as m:
            m.setattr(BVHAccelerator, "kernel_tree", lambda self: None)  # no tree to walk: the unfused wavefront
            before = len(calls)
            unfused = durer.render(scene, 16, 12, **kw)
            assert len(calls) == before
        fused = durer.render(scene, 16, 12, **kw)
        assert len(calls) > before
        for a, b in ((fused.color, unfused.color), (fused.depth, unfused.depth), (fused.normals, unfused.normals)):
            np.testing.assert_array_equal(a, b)


@needs_course
def test_course_scene_under_the_path_tracer():
    """A course scene (Phong materials, a solid texture) renders under the path tracer; with max_depth 2 (direct
    light) it is about as bright as the ray caster's (course lights are scaled by pi for this; the path tracer
    lights back faces and normalises the Phong lobe, so it is not the same image)."""
    scene = durer.load(COURSE / "assignment6" / "scene6_13_checkerboard.txt")
    ray = durer.render(scene, 32, 32).color
    path = durer.render(scene, 32, 32, integrator="path", samples=16, max_depth=2).color
    assert np.isfinite(path).all()
    assert 0.7 < path.mean() / ray.mean() < 1.6


def test_cornell_box_against_mitsuba():
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference image")
    mi.set_variant("scalar_rgb")
    ref = np.array(mi.render(mi.load_file(str(EXAMPLES / "cornell_box.xml"), res=16, spp=1024)))
    ours = durer.render(durer.load(EXAMPLES / "cornell_box.xml"), 16, 16, samples=256).color
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.01)
    # per pixel: the difference is noise (16 x 16 pixels, the light's edge pixels excluded by the median)
    assert np.median(np.abs(ours - ref) / (ref + 0.05)) < 0.05


@needs_course
def test_every_course_scene_renders_under_the_path_tracer():
    """Each course scene (every material, texture, light and camera kind of the course) path-traces to finite,
    non-negative pixels: 6 x 6 pixels, 1 sample, 4 bounces, tiny on purpose."""
    scenes = sorted(COURSE.glob("assignment*/scene*.txt"))
    assert scenes
    for path in scenes:
        if "bunny_mesh_40k" in path.name:  # the same mesh as the 1k/5k scenes, 40x the loading time
            continue
        r = durer.render(durer.load(path), 6, 6, integrator="path", samples=1, max_depth=4)
        assert np.isfinite(r.color).all() and r.color.min() >= 0, path.name


MIXED = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
  <sensor type="perspective"><float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 2, 6" target="0, 0.5, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/>
      <rfilter type="box"/></film></sensor>
  <emitter type="point"><point name="position" x="2" y="4" z="2"/><rgb name="intensity" value="20, 18, 15"/></emitter>
  <emitter type="directional"><vector name="direction" x="-1" y="-2" z="-0.5"/>
    <rgb name="irradiance" value="0.8, 0.8, 1.0"/></emitter>
  <emitter type="constant"><rgb name="radiance" value="0.15, 0.2, 0.3"/></emitter>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="-1" y="0.6" z="0"/><float name="radius" value="0.6"/>
    <bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>
      <rgb name="diffuse_reflectance" value="0.1, 0.3, 0.7"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.7" y="0.5" z="0.5"/><float name="radius" value="0.5"/>
    <bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.15"/></bsdf></shape>
  <shape type="disk"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="90"/>
    <translate y="3" z="-1"/></transform><emitter type="area"><rgb name="radiance" value="6"/></emitter></shape>
  <shape type="cube"><transform name="to_world"><scale value="0.3"/><translate x="0.2" y="0.3" z="-1.5"/>
    </transform><bsdf type="twosided"><bsdf type="plastic"/></bsdf></shape>
</scene>
"""


def test_every_emitter_and_bsdf_against_mitsuba(tmp_path):
    """Point, directional, constant and area (disk) emitters over diffuse, plastic, rough plastic and rough gold:
    durer's image mean and pixels agree with Mitsuba's."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference image")
    mi.set_variant("scalar_rgb")
    p = tmp_path / "mixed.xml"
    p.write_text(MIXED)
    ref = np.array(mi.render(mi.load_file(str(p)), spp=2048))
    ours = durer.render(durer.load(p), samples=256).color
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.015)
    assert np.median(np.abs(ours - ref) / (ref + 0.05)) < 0.04


ENVMAP = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="5"/></integrator>
  <sensor type="perspective"><float name="fov" value="60"/>
    <transform name="to_world"><lookat origin="0, 1.5, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/>
      <rfilter type="box"/></film></sensor>
  <emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="1.5"/>
    <transform name="to_world"><rotate y="1" angle="30"/></transform></emitter>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="0.7" z="0"/><float name="radius" value="0.7"/>
    <bsdf type="roughconductor"><string name="material" value="Cu"/><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.3"/></bsdf></shape>
</scene>
"""


def sky(h: int = 32, w: int = 64) -> np.ndarray:
    """An HDR sky (float32 (h, w, 3)) with a small sun."""
    v, u = (np.arange(h)[:, None] + 0.5) / h, (np.arange(w)[None, :] + 0.5) / w
    img = np.zeros((h, w, 3), np.float32)
    img[..., 0], img[..., 1], img[..., 2] = 0.3 + 0.5 * u, 0.4 * (1 - v), 0.8 * (1 - v) + 0.1
    img[5:8, 40:44] = [40, 35, 30]
    return img


def test_environment_map_against_mitsuba(tmp_path):
    """An HDR sky with a small sun (EXR), rotated: the sky seen directly matches Mitsuba's lookups pixel for pixel,
    and the lit image's mean is within 0.5%."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference image")
    exr = pytest.importorskip("OpenEXR", reason="the environment map is an EXR file")
    mi.set_variant("scalar_rgb")
    with exr.File({"compression": exr.ZIP_COMPRESSION, "type": exr.scanlineimage}, {"RGB": sky()}) as f:
        f.write(str(tmp_path / "sky.exr"))
    (tmp_path / "env.xml").write_text(ENVMAP)
    ref = np.array(mi.render(mi.load_file(str(tmp_path / "env.xml")), spp=1024))
    ours = durer.render(durer.load(tmp_path / "env.xml"), samples=128).color
    np.testing.assert_allclose(ours[:3, 1:], ref[:3, 1:], rtol=2e-3)  # the sky rows (column 0 straddles the seam)
    np.testing.assert_allclose(ours.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.005)


def test_path_tracer_reaches_any_accelerator_through_the_protocol():
    """The path tracer asks the accelerator for a tree to walk (kernel_tree) and otherwise queries it: brute force
    and the counting wrapper (-stats) give the BVH's image to the bit, and the counters see every path's rays."""
    scene = durer.load(EXAMPLES / "cornell_box.xml")
    kw = dict(samples=2, max_depth=3)
    bvh = durer.render(scene, 12, 10, **kw)
    brute = durer.render(scene, 12, 10, accel="brute", **kw)
    counted = durer.render(scene, 12, 10, stats=True, **kw)
    np.testing.assert_array_equal(bvh.color, brute.color)
    np.testing.assert_array_equal(bvh.color, counted.color)
    assert counted.stats.nonshadow_rays >= 12 * 10 * 2 and counted.stats.shadow_rays > 0


def test_instanced_meshes_take_the_fused_bounce(monkeypatch, tmp_path):
    """A mesh placed twice is stored once (two instances, traced two-level by queries); a path render traces it
    flattened into one tree (context.make_context) through the fused bounce, and gives the image, depth and
    normals of the two-level accelerator's unfused wavefront to the bit."""
    (tmp_path / "tet.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    tet = ('<shape type="obj"><string name="filename" value="tet.obj"/><transform name="to_world"><scale value="0.6"/>'
           '<translate x="{x}" y="0.1" z="-1"/></transform><bsdf type="diffuse"/></shape>')
    (tmp_path / "two.xml").write_text(MIXED.replace("</scene>", tet.format(x=-0.6) + tet.format(x=0.9) + "</scene>"))
    scene = durer.load(tmp_path / "two.xml")
    width, height, options = resolve(scene, 16, 12, integrator="path", samples=2, max_depth=-1, seed=3)
    flat = make_context(scene, options)
    assert len(flat.bundle.geometry.instance_mesh) >= 2 and flat.accel.kernel_tree() is not None
    two_level = dataclasses.replace(flat, accel=BVHAccelerator(flat.bundle.geometry), prepared={})
    assert two_level.accel.kernel_tree() is None
    calls = []
    fused_kernel = P.trace_bounce
    monkeypatch.setattr(P, "trace_bounce", lambda *a: calls.append(1) or fused_kernel(*a))
    unfused = render_in(two_level, width, height)
    assert not calls
    fused = render_in(flat, width, height)
    assert calls
    for a, b in ((fused.color, unfused.color), (fused.depth, unfused.depth), (fused.normals, unfused.normals)):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("emits", [False, True], ids=["point-lights-only", "an-area-light"])
def test_the_last_bounce_is_skipped_only_where_nothing_emits(emits, monkeypatch):
    """Only delta lights: the last bounce of a bounded path collects no emission, so the fused loop stops a trace
    earlier with the same image to the bit; with an area light it traces every bounce."""
    cam = durer.PerspectiveCamera((0, 0.5, 4), (0, -0.1, -1), (0, 1, 0), 45)
    mats = [Surface(Diffuse(0.7)), Surface(Diffuse(0.5), 3.0 if emits else 0.0)]
    scene = durer.Scene(camera=cam, group=durer.Group([durer.Sphere((0, 0, 0), 0.8, 0), durer.Sphere((0, 2, 0), 0.5, 1),
                                                       durer.Plane((0, 1, 0), -0.8, 0)]),
                        materials=mats, lights=[durer.PointLight((1, 2, 2), (4, 4, 4))], radiometric_lights=True)
    kw = dict(integrator="path", samples=4, max_depth=3, seed=5)
    calls, real = [], P.run_pieces
    monkeypatch.setattr(P, "run_pieces", lambda f, *a, **k: (calls.append(f), real(f, *a, **k))[1])
    skipped = durer.render(scene, 16, 12, **kw).color
    fused = calls.count(P.trace_bounce)
    init = P.PathTracer.__init__

    def never_skip(self, ctx):
        init(self, ctx)
        self._dark = False
    monkeypatch.setattr(P.PathTracer, "__init__", never_skip)
    calls.clear()
    full = durer.render(scene, 16, 12, **kw).color
    np.testing.assert_array_equal(skipped, full)
    assert calls.count(P.trace_bounce) == fused + (0 if emits else 1)
    assert full.max() > 0
