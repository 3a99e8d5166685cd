"""The pinhole and orthographic cameras' Numba rays (kernels/camera.py) are PerspectiveCamera.generate_rays' and
OrthographicCamera.generate_rays' to the bit, for any frame, angle or size, image shape and film points
(rendering/film.camera_rays takes them for every pinhole and orthographic render)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.camera import orthographic_rays, perspective_rays
from durer.options import RenderOptions
from durer.rendering.film import camera_rays
from durer.scene.cameras import OrthographicCamera, PerspectiveCamera

vec = st.tuples(*[st.floats(-5, 5, allow_nan=False)] * 3).filter(lambda v: np.linalg.norm(v) > 1e-3)


@settings(max_examples=60, deadline=None)
@given(vec, vec, vec, st.floats(0.5, 179.5), st.integers(1, 400), st.integers(1, 400), st.integers(0, 2**32 - 1))
def test_the_kernel_gives_generate_rays_bits(center, direction, up, angle, width, height, seed):
    if np.linalg.norm(np.cross(direction, up)) < 1e-3:
        return  # no frame: the camera refuses it
    cam = PerspectiveCamera(center=center, direction=direction, up=up, angle=angle)
    points = np.random.default_rng(seed).uniform(-0.5, 1.5, (257, 2)) * [width, height]
    o, d, valid = cam.generate_rays(points, width, height)
    o2, d2 = np.empty_like(o), np.empty_like(d)
    perspective_rays(points, width, height, cam.center, cam.direction, cam.horizontal, cam.up,
                     2.0 * np.tan(np.radians(cam.angle) / 2.0), o2, d2)
    np.testing.assert_array_equal(o2, o)
    np.testing.assert_array_equal(d2, d)
    o3, d3, v3 = camera_rays(cam, points, width, height, RenderOptions(), np.zeros(257, np.int64), np.zeros(257))
    np.testing.assert_array_equal(d3, d)
    assert v3.all() and valid.all()
    np.testing.assert_allclose(np.linalg.norm(d2, axis=1), 1.0, rtol=1e-15)


@settings(max_examples=60, deadline=None)
@given(vec, vec, vec, st.floats(0.01, 50), st.integers(1, 400), st.integers(1, 400), st.integers(0, 2**32 - 1))
def test_the_orthographic_kernel_gives_generate_rays_bits(center, direction, up, size, width, height, seed):
    if np.linalg.norm(np.cross(direction, up)) < 1e-3:
        return  # no frame: the camera refuses it
    cam = OrthographicCamera(center=center, direction=direction, up=up, size=size)
    points = np.random.default_rng(seed).uniform(-0.5, 1.5, (257, 2)) * [width, height]
    o, d, valid = cam.generate_rays(points, width, height)
    o2, d2 = np.empty_like(o), np.empty_like(d)
    orthographic_rays(points, width, height, cam.center, cam.direction, cam.horizontal, cam.up, cam.size, o2, d2)
    np.testing.assert_array_equal(o2, o)
    np.testing.assert_array_equal(d2, d)
    o3, d3, v3 = camera_rays(cam, points, width, height, RenderOptions(), np.zeros(257, np.int64), np.zeros(257))
    np.testing.assert_array_equal(o3, o)
    np.testing.assert_array_equal(d3, d)
    assert v3.all() and valid.all()
