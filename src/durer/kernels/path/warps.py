"""Scalar helpers of the path tracer's Numba kernels: 3-vectors as tuples, shading frames, the warps of [0,1)^2 to
directions and points, and the power heuristic. They mirror rendering/sampling.py's NumPy warps one ray at a time
(the same formulas, so the fused kernels draw the same directions from the same random numbers)."""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT

INV_PI = 1.0 / math.pi


@nb.njit(**JIT, inline="always")
def dot3(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@nb.njit(**JIT, inline="always")
def frame3(nx, ny, nz):
    """Two unit tangents completing the unit normal n into a right-handed frame (Duff et al. 2017)."""
    sign = 1.0 if nz >= 0 else -1.0
    a = -1.0 / (sign + nz)
    b = nx * ny * a
    return (1.0 + sign * nx * nx * a, sign * b, -sign * nx), (b, sign + ny * ny * a, -ny)


@nb.njit(**JIT, inline="always")
def tangent_frame3(nx, ny, nz, ux, uy, uz, gx, gy, gz):
    """Mitsuba's shading frame (SurfaceInteraction::initialize_sh_frame): the tangent dp/du (ux, uy, uz) made
    orthogonal to the unit shading normal n, then t = n x s. Where dp/du is zero (no UVs) Mitsuba takes the
    geometric normal g's coordinate system (frame3(g)'s first tangent) as dp/du; where that too is parallel to n,
    frame3(n). Orients anisotropic BSDFs as Mitsuba does; isotropic ones keep frame3(n)."""
    if ux == 0.0 and uy == 0.0 and uz == 0.0:
        ux, uy, uz = frame3(gx, gy, gz)[0]
    d = nx * ux + ny * uy + nz * uz
    sx, sy, sz = ux - d * nx, uy - d * ny, uz - d * nz
    ln = math.sqrt(sx * sx + sy * sy + sz * sz)
    if not ln > 1e-12 * math.sqrt(ux * ux + uy * uy + uz * uz):
        return frame3(nx, ny, nz)
    sx, sy, sz = sx / ln, sy / ln, sz / ln
    return (sx, sy, sz), (ny * sz - nz * sy, nz * sx - nx * sz, nx * sy - ny * sx)


@nb.njit(**JIT, inline="always")
def to_local3(vx, vy, vz, s, t, nx, ny, nz):
    return (vx * s[0] + vy * s[1] + vz * s[2], vx * t[0] + vy * t[1] + vz * t[2], vx * nx + vy * ny + vz * nz)


@nb.njit(**JIT, inline="always")
def to_world3(lx, ly, lz, s, t, nx, ny, nz):
    return (lx * s[0] + ly * t[0] + lz * nx, lx * s[1] + ly * t[1] + lz * ny, lx * s[2] + ly * t[2] + lz * nz)


@nb.njit(**JIT, inline="always")
def cosine_hemisphere3(u0, u1):
    """Directions about +z with pdf cos(theta) / pi: the Shirley-Chiu concentric disk lifted (Malley)."""
    a = 2.0 * u0 - 1.0
    b = 2.0 * u1 - 1.0
    if a == 0.0 and b == 0.0:
        return 0.0, 0.0, 1.0
    if abs(a) > abs(b):
        r, phi = a, (math.pi / 4) * (b / a)
    else:
        r, phi = b, math.pi / 2 - (math.pi / 4) * (a / b)
    x, y = r * math.cos(phi), r * math.sin(phi)
    return x, y, math.sqrt(max(0.0, 1.0 - x * x - y * y))


@nb.njit(**JIT, inline="always")
def uniform_sphere3(u0, u1):
    """Unit vectors uniform on the sphere, pdf 1 / (4 pi)."""
    z = 1.0 - 2.0 * u0
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * u1
    return r * math.cos(phi), r * math.sin(phi), z


@nb.njit(**JIT, inline="always")
def uniform_cone3(u0, u1, cos_max):
    """Unit vectors about +z uniform in the cone cos(theta) >= cos_max, pdf 1 / (2 pi (1 - cos_max))."""
    z = 1.0 - u0 * (1.0 - cos_max)
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * u1
    return r * math.cos(phi), r * math.sin(phi), z


@nb.njit(**JIT, inline="always")
def uniform_cone_pdf(cos_max):
    return 1.0 / (2.0 * math.pi * max(1.0 - cos_max, 1e-300))


@nb.njit(**JIT, inline="always")
def power_heuristic1(a, b):
    """MIS weight a^2 / (a^2 + b^2) (0 where both are 0); an infinite a (a delta strategy) gets weight 1."""
    if math.isinf(a):
        return 1.0
    m = max(a, b)
    if not m > 0:
        return 0.0
    a2, b2 = (a / m) ** 2, (b / m) ** 2
    return a2 / (a2 + b2)
