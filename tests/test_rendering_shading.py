"""Local shading (assignments 2-4): Blinn-Phong as the course specifies it, and point-light attenuation.

The course images decide two details: the specular lobe is clamped to zero where N.L < 0 (no "specular fix",
scene3_09/3_10/3_12 references), and H is the normalised half vector between the light and the viewer.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from durer.rendering.shading import light_directions, phong
from durer.scene.lights import DirectionalLight, PointLight, SpotLight


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def one(v) -> np.ndarray:
    return np.asarray(v, dtype=np.float64).reshape(1, 3)


# --- attenuation ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("attenuation", "expected"), [
    ((1, 0, 0), 1.0),                    # constant (scene4_11)
    ((0, 1, 0), 1 / 5),                  # 1/d (scene4_12)
    ((0, 0, 1), 1 / 25),                 # 1/d^2 (scene4_13)
    ((1, 0.5, 0.25), 1 / (1 + 2.5 + 6.25)),
    ((2, 0, 0), 0.5),
])
def test_point_light_attenuation_values(attenuation, expected):
    light = PointLight(position=(1, 2, 3), color=(0.8, 0.4, 0.2), attenuation=attenuation)
    points = np.array([[1 + 3, 2 + 4, 3.0], [1, 2 - 5, 3.0]])  # both at distance 5
    to_light, colour, dist = light_directions(light, points)
    np.testing.assert_allclose(dist, [5, 5])
    np.testing.assert_allclose(to_light, [[-0.6, -0.8, 0], [0, 1, 0]], atol=1e-15)
    np.testing.assert_allclose(colour, np.outer([expected, expected], [0.8, 0.4, 0.2]), rtol=1e-12)


def test_directional_light_has_no_falloff():
    light = DirectionalLight(direction=(0, -2, 0), color=(0.5, 0.5, 0.5))
    to_light, colour, dist = light_directions(light, np.array([[0, 0, 0], [1e6, -1e6, 3]]))
    np.testing.assert_allclose(to_light, [[0, 1, 0], [0, 1, 0]])
    np.testing.assert_allclose(colour, [[0.5] * 3] * 2)
    assert np.all(np.isinf(dist))


# --- Blinn-Phong ---------------------------------------------------------------------------------------------
def test_diffuse_is_lambert_clamped():
    n = one([0, 1, 0])
    kd, ks = one([0.5, 0.25, 1.0]), one([0, 0, 0])
    for angle in (0, 30, 60, 89):
        a = np.radians(angle)
        lit = phong(n, one([0, 1, 0]), one([np.sin(a), np.cos(a), 0]), one([1, 1, 1]), kd, ks, np.array([1.0]))
        np.testing.assert_allclose(lit, kd * np.cos(a), atol=1e-15)
    below = phong(n, one([0, 1, 0]), one([0, -1, 0]), one([1, 1, 1]), kd, ks, np.array([1.0]))
    assert below.tolist() == [[0, 0, 0]]


def test_specular_uses_the_half_vector():
    n = one([0, 1, 0])
    to_light = unit(one([1, 1, 0]))
    to_viewer = unit(one([-1, 3, 0]))
    h = unit(to_light + to_viewer)
    kd, ks, e = one([0, 0, 0]), one([1.0, 0.5, 0.25]), np.array([7.0])
    lit = phong(n, to_viewer, to_light, one([0.8, 0.8, 0.8]), kd, ks, e)
    np.testing.assert_allclose(lit, 0.8 * ks * h[0, 1] ** 7, rtol=1e-12)


def test_specular_peak_is_mirror_configuration():
    """Viewer in the mirror direction of the light: N.H = 1, so the highlight is ks * light for any exponent."""
    n = one([0, 0, 1])
    to_light = unit(one([0.3, -0.2, 1]))
    to_viewer = unit(one([-0.3, 0.2, 1]))
    for e in (1.0, 10.0, 1000.0):
        lit = phong(n, to_viewer, to_light, one([1, 1, 1]), one([0, 0, 0]), one([1, 1, 1]), np.array([e]))
        np.testing.assert_allclose(lit, [[1, 1, 1]], rtol=1e-12)


def test_no_specular_when_light_is_behind_the_surface():
    """The course default (without the optional specular fix): N.L < 0 means no highlight at all, even where
    N.H > 0, which is what output3_09/3_10/3_12 show (the *_specular_fix images differ)."""
    n = one([0, 1, 0])
    to_light = unit(one([1, -0.1, 0]))     # just below the horizon
    to_viewer = unit(one([-0.2, 1, 0]))
    assert float(unit(to_light + to_viewer)[0] @ n[0]) > 0
    lit = phong(n, to_viewer, to_light, one([1, 1, 1]), one([0.2, 0.2, 0.2]), one([1, 1, 1]), np.array([1.0]))
    assert lit.tolist() == [[0, 0, 0]]


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=9, max_size=9), st.floats(1, 200))
# light and viewer opposite up to 3e-174: the half vector's length underflowed and its 1e-300 floor made it 3e126 long
@example(v=[1.0, 1.0, 0.0, 1.0, 0.0, 0.0, -1.0, 3.172028261138105e-174, 0.0], exponent=1.0)
def test_phong_bounded_by_ks_plus_kd(v, exponent):
    """No single light gives more than (kd + ks) * light colour."""
    n, l, w = (np.array(v[i:i + 3]) for i in (0, 3, 6))
    if min(np.linalg.norm(n), np.linalg.norm(l), np.linalg.norm(w)) < 1e-3:
        return
    kd, ks = one([0.3, 0.6, 0.9]), one([0.5, 0.5, 0.5])
    lit = phong(unit(one(n)), unit(one(w)), unit(one(l)), one([1, 1, 1]), kd, ks, np.array([exponent]))
    assert np.all(lit >= 0)
    assert np.all(lit <= kd + ks + 1e-12)


# --- spot lights (glTF's KHR_lights_punctual cone) -------------------------------------------------------------
def _at_angle(degrees: float, distance: float = 2.0) -> np.ndarray:
    """A point `distance` from the origin, `degrees` away from the -z axis (towards +x)."""
    a = np.radians(degrees)
    return one([distance * np.sin(a), 0.0, -distance * np.cos(a)])


@pytest.mark.parametrize(("degrees", "factor"), [
    (0.0, 1.0),                                                      # on the axis
    (9.0, 1.0),                                                      # inside the inner cone: full strength
    (20.0, ((np.cos(np.radians(20)) - np.cos(np.radians(30)))
            / (np.cos(np.radians(10)) - np.cos(np.radians(30)))) ** 2),  # glTF's smooth falloff, squared
    (31.0, 0.0),                                                     # outside the outer cone: nothing
    (150.0, 0.0),                                                    # behind the light
])
def test_spot_light_cone_falloff(degrees, factor):
    spot = SpotLight(position=(0, 0, 0), direction=(0, 0, -5), color=(1, 0.5, 0.25), inner_angle=10,
                     outer_angle=30, attenuation=(0, 0, 1))
    p = _at_angle(degrees)
    to_light, color, dist = light_directions(spot, p)
    assert np.allclose(to_light, -p / 2) and dist == pytest.approx([2.0])
    assert np.allclose(color, np.array([[1, 0.5, 0.25]]) * factor / 4)  # inverse square at d = 2


def test_spot_light_shades_like_a_point_light_inside_its_cone():
    kwargs = dict(color=(0.7, 0.7, 0.7), attenuation=(1, 0.5, 0))
    spot = SpotLight((1, 2, 3), (0, -1, 0), inner_angle=60, outer_angle=80, **kwargs)
    point = PointLight((1, 2, 3), **kwargs)
    p = np.array([[1.2, 0.0, 3.1], [0.5, -1.0, 2.5]])
    for a, b in zip(light_directions(spot, p), light_directions(point, p), strict=True):
        assert np.allclose(a, b)


@pytest.mark.parametrize("angles", [(30, 30), (40, 30), (-1, 30), (10, 95)])
def test_spot_light_cone_angles_are_checked(angles):
    with pytest.raises(ValueError, match="cone angles"):
        SpotLight((0, 0, 0), (0, 0, -1), inner_angle=angles[0], outer_angle=angles[1])
