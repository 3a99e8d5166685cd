"""Scalar Fresnel and microfacet terms of the path tracer's BSDF kernels (kernels/path/bsdf.py): dielectric and
conductor Fresnel reflectance, the GGX distribution, Smith's masking and Heitz's visible-normal sampling, and the
d1 / g11 / sample_visible1 that pick GGX or Beckmann (kernels/path/beckmann.py) by a flag."""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT
from .beckmann import beckmann_d1, beckmann_g11, beckmann_sample_visible1


@nb.njit(**JIT)
def fresnel1(cos_i, eta):
    """Unpolarised Fresnel reflectance of a dielectric interface of relative index eta (int / ext) for cos(theta_i)
    of either sign. Returns (F, cos_theta_t signed opposite to cos_i, eta_it, eta_ti)."""
    outside = cos_i >= 0
    eta_it = eta if outside else 1.0 / eta
    eta_ti = 1.0 / eta_it
    cos_t2 = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i)
    ci = abs(cos_i)
    ct = math.sqrt(max(cos_t2, 0.0))
    if eta == 1.0:
        f = 0.0
    elif cos_t2 <= 0 or ci == 0:
        f = 1.0
    else:
        a_s = (ci - eta_it * ct) / (ci + eta_it * ct)
        a_p = (eta_it * ci - ct) / (eta_it * ci + ct)
        f = 0.5 * (a_s * a_s + a_p * a_p)
    return f, (-ct if outside else ct), eta_it, eta_ti


@nb.njit(**JIT, inline="always")
def fresnel_conductor1(cos_i, eta, k):
    """Fresnel reflectance of one channel of a conductor with complex index eta + i k at cos(theta_i)."""
    c2 = cos_i * cos_i
    s2 = 1.0 - c2
    t1 = eta * eta - k * k - s2
    ab = math.sqrt(t1 * t1 + 4.0 * k * k * eta * eta)
    a = math.sqrt(max(0.5 * (ab + t1), 0.0))
    term1 = ab + c2
    term2 = 2.0 * math.sqrt(c2) * a
    rs = (term1 - term2) / (term1 + term2)
    term3 = ab * c2 + s2 * s2
    term4 = term2 * s2
    r = 0.5 * (rs + rs * (term3 - term4) / (term3 + term4))
    return 1.0 if r != r else r


@nb.njit(**JIT, inline="always")
def ggx_d1(mx, my, mz, au, av):
    """GGX normal distribution D(m) (projected-area normalised)."""
    if mz <= 0:
        return 0.0
    t = (mx / au) ** 2 + (my / av) ** 2 + mz * mz
    return 1.0 / (math.pi * au * av * t * t)


@nb.njit(**JIT, inline="always")
def ggx_g11(vx, vy, vz, mx, my, mz, au, av):
    """Smith's masking G1(v, m) for GGX; 0 where v sees the back of m."""
    if (vx * mx + vy * my + vz * mz) * vz <= 0:
        return 0.0
    z2 = max(vz * vz, 1e-300)
    lam = 0.5 * (-1.0 + math.sqrt(1.0 + ((au * vx) ** 2 + (av * vy) ** 2) / z2))
    return 1.0 / (1.0 + lam)


@nb.njit(**JIT)
def ggx_sample_visible1(wx, wy, wz, u0, u1, au, av):
    """A microfacet normal distributed as D_wi(m) = G1(wi, m) max(0, wi.m) D(m) / cos(theta_i) (Heitz 2018)."""
    hx, hy, hz = au * wx, av * wy, wz
    ln = math.sqrt(hx * hx + hy * hy + hz * hz)
    hx, hy, hz = hx / ln, hy / ln, hz / ln
    lensq = hx * hx + hy * hy
    if lensq > 0:
        inv = 1.0 / math.sqrt(lensq)
        t1x, t1y, t1z = -hy * inv, hx * inv, 0.0
    else:
        t1x, t1y, t1z = 1.0, 0.0, 0.0
    t2x, t2y, t2z = hy * t1z - hz * t1y, hz * t1x - hx * t1z, hx * t1y - hy * t1x
    r = math.sqrt(u0)
    phi = 2.0 * math.pi * u1
    p1 = r * math.cos(phi)
    p2 = r * math.sin(phi)
    s = 0.5 * (1.0 + hz)
    p2 = (1.0 - s) * math.sqrt(max(0.0, 1.0 - p1 * p1)) + s * p2
    p3 = math.sqrt(max(0.0, 1.0 - p1 * p1 - p2 * p2))
    mx = au * (p1 * t1x + p2 * t2x + p3 * hx)
    my = av * (p1 * t1y + p2 * t2y + p3 * hy)
    mz = max(p1 * t1z + p2 * t2z + p3 * hz, 1e-12)
    ln = math.sqrt(mx * mx + my * my + mz * mz)
    return mx / ln, my / ln, mz / ln


@nb.njit(**JIT, inline="always")
def half_vector(wi, wo, k):
    """The microfacet normal between wi and wo: wi + k wo normalised and turned to +z (k = 1 for a reflection, the
    relative index on wi's side for a refraction, Walter et al.'s generalised half vector), with its dot products
    with wi and wo; ok is False where wi + k wo has no direction."""
    hx, hy, hz = wi[0] + wo[0] * k, wi[1] + wo[1] * k, wi[2] + wo[2] * k
    ln = math.sqrt(hx * hx + hy * hy + hz * hz)
    if ln == 0:
        return 0.0, 0.0, 0.0, 0.0, 0.0, False
    if hz < 0:
        ln = -ln
    hx, hy, hz = hx / ln, hy / ln, hz / ln
    return hx, hy, hz, wi[0] * hx + wi[1] * hy + wi[2] * hz, wo[0] * hx + wo[1] * hy + wo[2] * hz, True


@nb.njit(**JIT, inline="always")
def d1(mx, my, mz, au, av, beckmann):
    """D(m) of GGX, or of Beckmann where `beckmann`."""
    return beckmann_d1(mx, my, mz, au, av) if beckmann else ggx_d1(mx, my, mz, au, av)


@nb.njit(**JIT, inline="always")
def g11(vx, vy, vz, mx, my, mz, au, av, beckmann):
    """Smith's G1(v, m) of GGX, or of Beckmann where `beckmann`."""
    return beckmann_g11(vx, vy, vz, mx, my, mz, au, av) if beckmann else ggx_g11(vx, vy, vz, mx, my, mz, au, av)


@nb.njit(**JIT)
def sample_visible1(wx, wy, wz, u0, u1, au, av, beckmann):
    """A visible normal of GGX, or of Beckmann where `beckmann`."""
    if beckmann:
        return beckmann_sample_visible1(wx, wy, wz, u0, u1, au, av)
    return ggx_sample_visible1(wx, wy, wz, u0, u1, au, av)


@nb.njit(**JIT)
def rough_albedo_kernel(mu, alpha, eta, transmit, n, out, beckmann=False):
    """out[i]: single-scattering reflectance (or transmittance) of a rough GGX (or Beckmann) dielectric interface
    at cos(theta) = mu[i], by the midpoint rule on n x n visible normals: E[F G1(wo)] (or E[(1 - F) G1(wo)] through
    refraction). The rough plastic's tables."""
    for i in range(mu.shape[0]):
        c = mu[i]
        wx, wz = math.sqrt(1.0 - c * c), c
        total = 0.0
        for a in range(n):
            for b in range(n):
                mx, my, mz = sample_visible1(wx, 0.0, wz, (a + 0.5) / n, (b + 0.5) / n, alpha, alpha, beckmann)
                c_im = wx * mx + wz * mz
                f, cos_t, _, eta_ti = fresnel1(c_im, eta)
                if transmit:
                    k = eta_ti * c_im + cos_t
                    ox, oy, oz = k * mx - eta_ti * wx, k * my, k * mz - eta_ti * wz
                    if oz < 0:
                        total += (1.0 - f) * g11(ox, oy, oz, mx, my, mz, alpha, alpha, beckmann)
                else:
                    ox, oy, oz = 2.0 * c_im * mx - wx, 2.0 * c_im * my, 2.0 * c_im * mz - wz
                    if oz > 0:
                        total += f * g11(ox, oy, oz, mx, my, mz, alpha, alpha, beckmann)
        out[i] = total / (n * n)
