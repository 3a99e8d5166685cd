"""Scalar Beckmann microfacet terms, as Mitsuba 3's microfacet.h has them (its default distribution): the normal
distribution, Smith's masking by Walter et al.'s rational fit, and visible-normal sampling by Jakob's numerical
inversion (three Newton steps in the erf domain). erfinv is Giles' approximation refined by Newton steps."""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT

INV_SQRT_PI = 1.0 / math.sqrt(math.pi)


@nb.njit(**JIT, inline="always")
def erfinv(y):
    """The inverse error function on (-1, 1), to double precision (Giles 2010, then two Newton steps)."""
    if y <= -1.0:
        return -math.inf
    if y >= 1.0:
        return math.inf
    w = -math.log((1.0 - y) * (1.0 + y))
    if w < 5.0:
        w -= 2.5
        p = 2.81022636e-08
        p = 3.43273939e-07 + p * w
        p = -3.5233877e-06 + p * w
        p = -4.39150654e-06 + p * w
        p = 0.00021858087 + p * w
        p = -0.00125372503 + p * w
        p = -0.00417768164 + p * w
        p = 0.246640727 + p * w
        p = 1.50140941 + p * w
    else:
        w = math.sqrt(w) - 3.0
        p = -0.000200214257
        p = 0.000100950558 + p * w
        p = 0.00134934322 + p * w
        p = -0.00367342844 + p * w
        p = 0.00573950773 + p * w
        p = -0.0076224613 + p * w
        p = 0.00943887047 + p * w
        p = 1.00167406 + p * w
        p = 2.83297682 + p * w
    x = p * y
    for _ in range(2):
        x -= (math.erf(x) - y) / (2.0 * INV_SQRT_PI * math.exp(-x * x))
    return x


@nb.njit(**JIT, inline="always")
def beckmann_d1(mx, my, mz, au, av):
    """Beckmann's D(m) (projected-area normalised)."""
    if mz <= 0:
        return 0.0
    c2 = mz * mz
    return math.exp(-((mx / au) ** 2 + (my / av) ** 2) / c2) / (math.pi * au * av * c2 * c2)


@nb.njit(**JIT, inline="always")
def beckmann_g11(vx, vy, vz, mx, my, mz, au, av):
    """Smith's masking G1(v, m) for Beckmann (the rational fit Mitsuba uses); 0 where v sees the back of m."""
    if (vx * mx + vy * my + vz * mz) * vz <= 0:
        return 0.0
    xy = (au * vx) ** 2 + (av * vy) ** 2
    if xy <= 0:
        return 1.0
    a = abs(vz) / math.sqrt(xy)
    if a >= 1.6:
        return 1.0
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)


@nb.njit(**JIT, inline="always")
def _slopes11(cos_i, u0, u1):
    """Slopes of a visible normal of the unit-roughness Beckmann distribution seen at cos(theta_i)."""
    if cos_i > 0.99999:
        r = math.sqrt(-math.log(max(1.0 - u0, 1e-300)))
        return r * math.cos(2.0 * math.pi * u1), r * math.sin(2.0 * math.pi * u1)
    tan_i = math.sqrt(max(0.0, 1.0 - cos_i * cos_i)) / cos_i
    cot_i = 1.0 / tan_i
    maxval = math.erf(cot_i)
    u0 = min(max(u0, 1e-6), 1.0 - 1e-6)
    u1 = min(max(u1, 1e-6), 1.0 - 1e-6)
    x = maxval - (maxval + 1.0) * math.erf(math.sqrt(-math.log(u0)))
    u0 *= 1.0 + maxval + INV_SQRT_PI * tan_i * math.exp(-cot_i * cot_i)
    for _ in range(3):
        slope = erfinv(x)
        value = 1.0 + x + INV_SQRT_PI * tan_i * math.exp(-slope * slope) - u0
        x -= value / (1.0 - slope * tan_i)
    return erfinv(x), erfinv(2.0 * u1 - 1.0)


@nb.njit(**JIT)
def beckmann_sample_visible1(wx, wy, wz, u0, u1, au, av):
    """A microfacet normal distributed as D_wi(m) = G1(wi, m) max(0, wi.m) D(m) / cos(theta_i) for Beckmann
    (Mitsuba's MicrofacetDistribution::sample with sample_visible)."""
    sx, sy, sz = au * wx, av * wy, wz
    ln = math.sqrt(sx * sx + sy * sy + sz * sz)
    sx, sy, sz = sx / ln, sy / ln, sz / ln
    sin_t = math.sqrt(sx * sx + sy * sy)
    if sin_t > 0:
        cos_phi, sin_phi = min(max(sx / sin_t, -1.0), 1.0), min(max(sy / sin_t, -1.0), 1.0)
    else:
        cos_phi, sin_phi = 1.0, 0.0
    px, py = _slopes11(sz, u0, u1)
    qx = (cos_phi * px - sin_phi * py) * au
    qy = (sin_phi * px + cos_phi * py) * av
    ln = math.sqrt(qx * qx + qy * qy + 1.0)
    return -qx / ln, -qy / ln, 1.0 / ln
