"""preview/navigation.py: orbit, pan and zoom keep the camera valid and move it as a drag should."""

from __future__ import annotations

import numpy as np
import pytest

from durer import OrthographicCamera, PerspectiveCamera
from durer.preview.navigation import home_view, orbit, pan, pixel_size, zoom

BOUNDS = (np.array([-1.0, -1.0, -1.0]), np.array([1.0, 1.0, 1.0]))


def _view(kind="perspective"):
    if kind == "perspective":
        cam = PerspectiveCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), angle=30)
    else:
        cam = OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=4)
    return home_view(cam, BOUNDS)


def test_home_target_is_level_with_the_scene_middle():
    np.testing.assert_allclose(_view().target, [0, 0, 0])


@pytest.mark.parametrize("yaw, pitch", [(0.3, 0.0), (-1.2, 0.4), (2.0, -0.7), (0.0, 1.0)])
def test_orbit_keeps_distance_and_looks_at_the_target(yaw, pitch):
    view = orbit(_view(), yaw, pitch, np.array([0.0, 1.0, 0.0]))
    cam = view.camera
    assert np.linalg.norm(cam.center - view.target) == pytest.approx(10.0)
    np.testing.assert_allclose(cam.direction, (view.target - cam.center) / 10.0, atol=1e-12)
    assert cam.up[1] > 0  # no roll past the vertical


def test_a_quarter_yaw_moves_the_camera_to_the_side():
    cam = orbit(_view(), np.pi / 2, 0.0, np.array([0.0, 1.0, 0.0])).camera
    np.testing.assert_allclose(np.abs(cam.center), [10, 0, 0], atol=1e-9)


def test_pitch_stops_short_of_the_pole():
    view = orbit(_view(), 0.0, 1.6, np.array([0.0, 1.0, 0.0]))  # past 90 degrees: refused
    np.testing.assert_allclose(view.camera.center, [0, 0, 10])


@pytest.mark.parametrize("kind", ["perspective", "orthographic"])
def test_pan_moves_the_target_by_pixels_at_its_distance(kind):
    view = _view(kind)
    moved = pan(view, 10, -4, 100, 50)
    step = pixel_size(view, 100, 50)
    np.testing.assert_allclose(moved.target - view.target, step * np.array([-10, -4, 0]), atol=1e-12)
    np.testing.assert_allclose(moved.camera.direction, view.camera.direction)
    if kind == "perspective":  # the target stays under the same pixel: 10 pixels = 10 * 2 tan(15 deg) * 10 / 100
        assert step == pytest.approx(10 * 2 * np.tan(np.radians(15)) / 100)


def test_zoom_scales_the_distance_or_the_size():
    assert np.linalg.norm(zoom(_view(), 0.5).camera.center) == pytest.approx(5.0)
    assert zoom(_view("orthographic"), 2.0).camera.size == pytest.approx(8.0)
    with pytest.raises(ValueError, match="positive"):
        zoom(_view(), 0.0)
