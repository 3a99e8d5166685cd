"""Perlin's improved noise (kernels/course/noise.py): the reference implementation's values and the properties textures
rely on (zero on the lattice, bounded, deterministic, continuous, periodic with period 256)."""

from __future__ import annotations

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.course.noise import PERM, fade, grad, noise3, noise_points, turbulence

coord = st.floats(min_value=-300.0, max_value=300.0, allow_nan=False, allow_infinity=False)

# the 12 gradient directions of the reference (edges of a cube), indexed by hash & 15 (12-15 repeat four of them)
GRADIENTS = [(1, 1, 0), (-1, 1, 0), (1, -1, 0), (-1, -1, 0), (1, 0, 1), (-1, 0, 1), (1, 0, -1), (-1, 0, -1),
             (0, 1, 1), (0, -1, 1), (0, 1, -1), (0, -1, -1), (1, 1, 0), (0, -1, 1), (-1, 1, 0), (0, -1, -1)]


def test_permutation_is_the_references_doubled():
    assert sorted(PERM[:256]) == list(range(256))
    assert np.array_equal(PERM[:256], PERM[256:])
    assert PERM[:5].tolist() == [151, 160, 137, 91, 90] and PERM[255] == 180


def test_value_of_the_java_reference():
    # ImprovedNoise.noise(3.14, 42, 7) in Perlin's Java reference
    assert noise3(3.14, 42.0, 7.0) == pytest.approx(0.13691995878400012, abs=1e-15)


def test_fade_curve():
    t = np.linspace(0.0, 1.0, 101)
    expected = 6 * t**5 - 15 * t**4 + 10 * t**3
    assert np.allclose([fade(x) for x in t], expected, atol=1e-15)
    assert fade(0.0) == 0.0 and fade(1.0) == 1.0 and fade(0.5) == 0.5
    h = 1e-4  # zero slope at both ends (the slope 30 t^2 (1 - t)^2 is 3e-7 one step in)
    assert abs(fade(h) - fade(0.0)) / h < 1e-6 and abs(fade(1.0) - fade(1.0 - h)) / h < 1e-6


@pytest.mark.parametrize("h", range(16))
def test_grad_is_a_dot_product_with_the_cube_edge_gradients(h):
    x, y, z = 0.3, -0.7, 0.45
    gx, gy, gz = GRADIENTS[h]
    assert grad(h, x, y, z) == pytest.approx(gx * x + gy * y + gz * z, abs=1e-15)
    assert grad(h + 16, x, y, z) == grad(h, x, y, z)  # only the low four bits count


@given(st.integers(-1000, 1000), st.integers(-1000, 1000), st.integers(-1000, 1000))
def test_zero_at_lattice_points(i, j, k):
    assert noise3(float(i), float(j), float(k)) == 0.0


def test_bounded_and_centred():
    rng = np.random.default_rng(1)
    values = noise_points(rng.uniform(-100, 100, (200_000, 3)))
    assert np.abs(values).max() <= 1.05  # |noise| stays about 1 (the theoretical bound of the 2002 noise)
    assert abs(values.mean()) < 0.01
    assert values.std() > 0.2  # and it is not flat


@settings(max_examples=200)
@given(coord, coord, coord, st.integers(0, 2))
def test_continuous(x, y, z, axis):
    """Lipschitz: every corner term has slope at most 2*sqrt(2) and the fade curves at most 15/8, so a step of
    1e-7 changes the value by far less than 1e-5, also across lattice-cell boundaries."""
    step = np.zeros(3)
    step[axis] = 1e-7
    p = np.array([x, y, z])
    q = p + step
    assert abs(noise3(*p) - noise3(*q)) < 1e-5


def test_continuous_across_a_cell_boundary():
    for y, z in [(0.3, 0.7), (5.5, -2.25), (-7.1, 3.9)]:
        below, above = noise3(np.nextafter(3.0, 0.0), y, z), noise3(3.0, y, z)
        assert abs(below - above) < 1e-12


@settings(max_examples=100)
@given(st.integers(-4096, 4096), st.integers(-4096, 4096), st.integers(-4096, 4096), st.sampled_from([256, -512]))
def test_periodic_with_period_256(a, b, c, shift):
    x, y, z = a / 64, b / 64, c / 64  # dyadic, so x + shift is exact
    assert noise3(x + shift, y, z) == noise3(x, y, z)
    assert noise3(x, y + shift, z + shift) == noise3(x, y, z)


def test_deterministic_and_independent_of_threads():
    rng = np.random.default_rng(2)
    pts = rng.uniform(-50, 50, (50_000, 3))
    threads = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = turbulence(pts, 5)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = turbulence(pts, 5)
    finally:
        numba.set_num_threads(threads)
    assert np.array_equal(one, two)
    assert np.array_equal(noise_points(pts), noise_points(pts.copy()))


def test_turbulence_is_the_course_octave_sum():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-10, 10, (1000, 3))
    assert np.array_equal(turbulence(pts, 0), np.zeros(1000))
    assert np.array_equal(turbulence(pts, 1), noise_points(pts))
    expected = sum(noise_points(pts * 2.0**k) / 2.0**k for k in range(4))
    assert np.allclose(turbulence(pts, 4), expected, atol=1e-14)
    assert np.abs(turbulence(pts, 5)).max() <= 1.05 * (2 - 2**-4)
