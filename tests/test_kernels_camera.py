"""The pinhole and orthographic cameras' Numba rays (kernels/camera.py, taken by their generate_rays and so by every
render, query and preview) equal the cameras' closed forms evaluated in NumPy, to the bit, for any frame, angle or
size, image shape and film points."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.camera import orthographic_rays, perspective_rays
from durer.options import RenderOptions
from durer.rendering.film import camera_rays
from durer.scene.cameras import OrthographicCamera, PerspectiveCamera

vec = st.tuples(*[st.floats(-5, 5, allow_nan=False)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3)


def numpy_pinhole(cam: PerspectiveCamera, points: np.ndarray, width: int, height: int):
    """The pinhole's rays as array expressions: offsets from the image centre in units of the longer side, scaled
    by the screen's extent 2 tan(angle / 2) one unit ahead, along the camera's frame, normalised."""
    side = float(max(width, height))
    sx, sy = (points[..., 0] - 0.5 * width) / side, (points[..., 1] - 0.5 * height) / side
    extent = 2.0 * np.tan(np.radians(cam.angle) / 2.0)
    d = cam.direction + (sx * extent)[..., None] * cam.horizontal + (sy * extent)[..., None] * cam.up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return np.broadcast_to(cam.center, d.shape), d


@settings(max_examples=60, deadline=None)
@given(vec, vec, vec, st.floats(0.5, 179.5), st.integers(1, 400), st.integers(1, 400), st.integers(0, 2**32 - 1))
def test_the_kernel_gives_the_closed_form_bits(center, direction, up, angle, width, height, seed):
    if np.linalg.norm(np.cross(direction, up)) < 1e-3:
        return  # no frame: the camera refuses it
    cam = PerspectiveCamera(center=center, direction=direction, up=up, angle=angle)
    points = np.random.default_rng(seed).uniform(-0.5, 1.5, (257, 2)) * [width, height]
    o, d = numpy_pinhole(cam, points, width, height)
    o2, d2 = np.empty((257, 3)), np.empty((257, 3))
    perspective_rays(points, width, height, cam.center, cam.direction, cam.horizontal, cam.up,
                     2.0 * np.tan(np.radians(cam.angle) / 2.0), o2, d2)
    np.testing.assert_array_equal(o2, o)
    np.testing.assert_array_equal(d2, d)
    o3, d3, v3 = cam.generate_rays(points, width, height)
    np.testing.assert_array_equal(o3, o)
    np.testing.assert_array_equal(d3, d)
    o4, d4, v4 = camera_rays(cam, points, width, height, RenderOptions(), np.zeros(257, np.int64), np.zeros(257))
    np.testing.assert_array_equal(d4, d)
    assert v3.all() and v4.all()
    np.testing.assert_allclose(np.linalg.norm(d2, axis=1), 1.0, rtol=1e-15)


def test_generate_rays_keeps_the_points_shape():
    """An (H, W, 2) grid of film points gives (H, W, 3) rays, the same as the flat points' rays."""
    cam = PerspectiveCamera(center=(1, 2, 3), direction=(0, 0, -1), up=(0, 1, 0), angle=50)
    ys, xs = np.mgrid[0:6, 0:9] + 0.5
    grid = np.stack([xs, ys], axis=-1)
    o, d, valid = cam.generate_rays(grid, 9, 6)
    assert o.shape == d.shape == (6, 9, 3) and valid.shape == (6, 9)
    of, df, _ = cam.generate_rays(grid.reshape(-1, 2), 9, 6)
    np.testing.assert_array_equal(d.reshape(-1, 3), df)
    np.testing.assert_array_equal(o[2, 3], [1, 2, 3])
    # the pixel at the image centre looks straight ahead
    centre = cam.generate_rays(np.array([4.5, 3.0]), 9, 6)[1]
    np.testing.assert_allclose(centre, [0, 0, -1], atol=1e-15)


def test_mutated_frame_as_lists():
    """A user may assign plain sequences to a camera's fields after construction."""
    cam = PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=90)
    cam.center = [1.0, 1.0, 1.0]
    o, d, _ = cam.generate_rays(np.array([[1.0, 0.5]]), 2, 1)
    np.testing.assert_array_equal(o, [[1.0, 1.0, 1.0]])
    np.testing.assert_allclose(d, [[0.0, 0.0, -1.0]], atol=1e-15)


@settings(max_examples=60, deadline=None)
@given(vec, vec, vec, st.floats(0.01, 50), st.integers(1, 400), st.integers(1, 400), st.integers(0, 2**32 - 1))
def test_the_orthographic_kernel_gives_generate_rays_bits(center, direction, up, size, width, height, seed):
    if np.linalg.norm(np.cross(direction, up)) < 1e-3:
        return  # no frame: the camera refuses it
    cam = OrthographicCamera(center=center, direction=direction, up=up, size=size)
    points = np.random.default_rng(seed).uniform(-0.5, 1.5, (257, 2)) * [width, height]
    side = float(max(width, height))
    sx, sy = (points[:, 0] - 0.5 * width) / side, (points[:, 1] - 0.5 * height) / side
    o = cam.center + (sx * cam.size)[:, None] * cam.horizontal + (sy * cam.size)[:, None] * cam.up
    d = np.broadcast_to(cam.direction, o.shape)
    o1, d1, valid = cam.generate_rays(points, width, height)
    np.testing.assert_array_equal(o1, o)
    np.testing.assert_array_equal(d1, d)
    o2, d2 = np.empty_like(o), np.empty((257, 3))
    orthographic_rays(points, width, height, cam.center, cam.direction, cam.horizontal, cam.up, cam.size, o2, d2)
    np.testing.assert_array_equal(o2, o)
    np.testing.assert_array_equal(d2, d)
    o3, d3, v3 = camera_rays(cam, points, width, height, RenderOptions(), np.zeros(257, np.int64), np.zeros(257))
    np.testing.assert_array_equal(o3, o)
    np.testing.assert_array_equal(d3, d)
    assert v3.all() and valid.all()
