"""The Python API: build a scene with the parser's classes, render it, get arrays back."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer import DirectionalLight, Group, OrthographicCamera, PerspectiveCamera, PhongMaterial, Plane, Scene, Sphere


def simple_scene(**kw):
    return Scene(
        camera=OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=4),
        group=Group([Sphere((0, 0, 0), 1, material=0)]),
        materials=[PhongMaterial(diffuse_color=(1, 0, 0))],
        background_color=(0, 0, 1),
        **kw,
    )


def test_render_result_arrays():
    r = durer.render(simple_scene(), 8, 6)
    assert r.color.shape == (6, 8, 3) and r.color.dtype == np.float32
    assert r.depth.shape == (6, 8) and r.depth.dtype == np.float32
    assert r.normals.shape == (6, 8, 3) and r.normals.dtype == np.float32
    assert r.color[3, 4].tolist() == [1, 0, 0]        # flat colour: the scene has no lights
    assert r.color[0, 0].tolist() == [0, 0, 1]        # background
    assert r.depth[0, 0] == np.inf and np.isfinite(r.depth[3, 4])
    assert r.normals[0, 0].tolist() == [0, 0, 0]


def test_lambert_and_ambient_closed_form():
    scene = simple_scene(lights=[DirectionalLight(direction=(0, 0, -1), color=(0.5, 0.5, 0.5))],
                         ambient_light=(0.2, 0.2, 0.2))
    r = durer.render(scene, 100, 100)
    centre = r.color[49:51, 49:51].mean(axis=(0, 1))
    # at the sphere's front N.L is ~1: 0.2 * kd + 0.5 * kd
    np.testing.assert_allclose(centre, [0.7, 0, 0], atol=2e-3)
    n = r.normals[50, 50]
    assert n[2] == pytest.approx(1.0, abs=1e-3)


def test_perspective_depth_is_distance():
    scene = Scene(camera=PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=90),
                  group=Group([Plane((0, 0, 1), -5)]), lights=[], materials=[PhongMaterial()])
    r = durer.render(scene, 3, 3)
    # the corner ray is (1, 1, -1)/sqrt(3) through the pixel centre at 2/3 of the half-extent: t = 5 |d| / |dz|
    d = np.array([2 / 3, 2 / 3, -1])
    assert r.depth[0, 0] == pytest.approx(5 * np.linalg.norm(d), rel=1e-5)
    assert r.depth[1, 1] == pytest.approx(5.0)


def test_back_faces_black_unless_shade_back():
    scene = simple_scene(lights=[DirectionalLight(direction=(0, 0, -1), color=(1, 1, 1))], ambient_light=(0.5, 0.5, 0.5))
    scene.camera = PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=60)
    front = durer.render(scene, 4, 4)
    assert front.color.max() == 0  # inside the sphere: only back faces
    both = durer.render(scene, 4, 4, shade_back=True)
    assert both.color[..., 0].min() > 0.5


def test_save_helpers(tmp_path):
    r = durer.render(simple_scene(), 8, 8)
    r.save(tmp_path / "c.png")
    r.save_depth(tmp_path / "d.png", 9, 10)
    r.save_depth(tmp_path / "d.npy")
    r.save_normals(tmp_path / "n.pfm")
    assert np.load(tmp_path / "d.npy")[4, 4] == pytest.approx(r.depth[4, 4])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.png", "d.npy", "d.png", "n.pfm"]


@pytest.mark.parametrize("w, h", [(0, 10), (10, -1), (2.5, 3)])
def test_bad_size(w, h):
    with pytest.raises(ValueError, match="image size"):
        durer.render(simple_scene(), w, h)


def test_unknown_option():
    with pytest.raises(TypeError, match="unknown render option"):
        durer.render(simple_scene(), 4, 4, bounce=2)


@pytest.mark.parametrize("make", [
    lambda: Sphere((np.nan, 0, 0), 1),
    lambda: Sphere((0, 0, 0), np.inf),
    lambda: Plane((0, 1, 0), np.nan),
    lambda: durer.Triangle((0, 0, 0), (1, np.inf, 0), (0, 1, 0)),
    lambda: durer.TriangleMesh(np.array([[0, 0, 0], [1, 0, 0], [0, np.nan, 0]]), [[0, 1, 2]]),
    lambda: OrthographicCamera(center=(np.nan, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=1),
    lambda: PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, np.nan), up=(0, 1, 0), angle=30),
    lambda: DirectionalLight(direction=(0, np.nan, -1)),
    lambda: durer.PointLight(position=(0, 0, 0), attenuation=(0, 0, 0)),
    lambda: durer.Transform(np.full((4, 4), np.nan), Sphere((0, 0, 0), 1)),
])
def test_nan_and_infinity_in_scene_objects_are_value_errors(make):
    with pytest.raises(ValueError):
        make()


class _FakeTerminal:
    """A stderr stand-in that says it is a terminal and records what is written."""

    def __init__(self, tty: bool):
        self.tty = tty
        self.text = ""

    def isatty(self):
        return self.tty

    def write(self, s):
        self.text += s

    def flush(self):
        pass


@pytest.mark.parametrize("tty, quiet, shown", [(True, False, True), (True, True, False), (False, False, False)])
def test_progress_bar_only_on_a_terminal_and_never_when_quiet(monkeypatch, tty, quiet, shown):
    import importlib

    progress_module = importlib.import_module("durer.rendering.progress")
    fake = _FakeTerminal(tty)
    monkeypatch.setattr(progress_module.sys, "stderr", fake)
    bar = progress_module.progress(100, quiet)
    assert bar.disable is not shown
    if shown:
        assert bar.delay == pytest.approx(1.0)  # appears only for renders longer than about a second
    bar.update(100)
    bar.close()
    if not shown:
        assert fake.text == ""


def test_accel_brute_is_the_lecture_loop_with_the_same_results():
    """durer.render(..., accel="brute") takes accel/brute.BruteForce, and agrees with the BVH to the bit."""
    from durer.accel.brute import BruteForce
    from durer.options import RenderOptions
    from durer.rendering.renderer import make_context

    scene = simple_scene(lights=[DirectionalLight(direction=(-1, -1, -1), color=(1, 1, 1))])
    scene.group.objects.append(Plane((0, 1, 0), -1, material=0))
    assert isinstance(make_context(scene, RenderOptions(accel="brute")).accel, BruteForce)
    a = durer.render(scene, 20, 14, accel="brute", shadows=True, bounces=2)
    b = durer.render(scene, 20, 14, shadows=True, bounces=2)
    np.testing.assert_array_equal(a.color, b.color)
    np.testing.assert_array_equal(a.depth, b.depth)
    with pytest.raises(ValueError, match="unknown accelerator"):
        durer.render(scene, 4, 4, accel="octree")
    with pytest.raises(ValueError, match="not both"):
        durer.render(scene, 4, 4, accel="brute", grid=(2, 2, 2))


# --- issue 13: the first hour -----------------------------------------------------------------------------------
def test_size_is_checked_before_allocating():
    with pytest.raises(ValueError, match=r"a 100000 x 100000 image with 1 sample\(s\) per pixel would need about "
                                         r"\d+\.\d TB of memory; this machine has"):
        durer.render(simple_scene(), 100000, 100000)


def test_render_result_in_a_notebook():
    import io

    from PIL import Image

    from durer.io.images import encode_srgb

    r = durer.render(simple_scene(lights=[DirectionalLight((0, 0, -1), (0.5, 0.5, 0.5))]), 8, 6)
    text = repr(r)
    assert "\n" not in text and text.startswith("<RenderResult 8x6: ") and len(text) < 120
    srgb = r.to_srgb8()
    assert srgb.dtype == np.uint8 and srgb.shape == (6, 8, 3)
    assert np.array_equal(srgb, encode_srgb(r.color))
    c = float(r.color[3, 4, 0])
    assert 0.3 < c < 0.5 and srgb[3, 4, 0] == round(255 * (1.055 * c ** (1 / 2.4) - 0.055))  # the sRGB curve
    png = r._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert np.array_equal(np.asarray(Image.open(io.BytesIO(png))), srgb)


def test_a_scene_without_lights_is_flat_colour_whatever_the_tracer_flags():
    """No Lights block (assignment 1): shadows and bounces have no lights to work with, so the image is the ray
    caster's flat colour (it used to end in a TypeError inside the shadow rays)."""
    scene = simple_scene()
    plain = durer.render(scene, 12, 12)
    traced = durer.render(scene, 12, 12, shadows=True, bounces=3)
    np.testing.assert_array_equal(traced.color, plain.color)
    assert traced.color[6, 6].tolist() == [1.0, 0.0, 0.0] and traced.color[0, 0].tolist() == [0.0, 0.0, 1.0]


def test_batches_are_whole_bands_of_tile_rows_for_one_ray_per_pixel():
    """One ray per pixel, row by row: each batch is whole 4-row bands of the unit's pixels (so the BVH can trace
    4 x 4 tiles); otherwise the integrator's batch."""
    from durer.rendering.integrators import CHUNK, RAYCAST
    from durer.rendering.units import Tile, _batch

    assert _batch(RAYCAST, 200 * 200, Tile(0, 0, 200, 200)) == 8000            # 10 bands of 4 rows of 200
    assert _batch(RAYCAST, 4096 * 64, Tile(0, 0, 64, 4096)) == 4 * 4096       # a band wider than CHUNK
    assert _batch(RAYCAST, 4 * 200 * 200, Tile(0, 0, 200, 200)) == CHUNK      # several samples per pixel
    assert _batch(RAYCAST, 202 * 200, Tile(0, 0, 200, 202)) == CHUNK          # rows not a multiple of 4 long
    assert _batch(RAYCAST, 200 * 198, Tile(0, 0, 198, 200)) == CHUNK          # not whole bands
