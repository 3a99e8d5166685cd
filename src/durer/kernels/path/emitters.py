"""The path tracer's emitters as scalar Numba functions: next-event sampling of one emitter from a point, and the
pdf with which that sampling would have chosen a point found by a BSDF-sampled ray. Emitters are packed by
rendering/emitters.py (which documents the models): per emitter a kind, a radiance and a row of parameters; the
triangles of mesh emitters are concatenated with one area cdf per emitter. An environment map is sampled by
kernels/path/envmap.py over its tables (`env`). A spot's projected texture and an area emitter's textured radiance
are looked up in the path tracer's texture table (`tex` = (TI, TD), kernels/path/textures.py), as the BSDFs' are: the
radiance at the sampled point's UV (barycentric UVs on triangles, the shape's parametrisation on spheres, disks and
cylinders, as surface.uv_at gives a hit), the point still sampled by area or solid angle alone, so the pdfs do not
depend on the texture."""

from __future__ import annotations

import math

import numba as nb

from ..common import CYLINDER_CODE, JIT
from .envmap import envmap_sample
from .textures import tex_eval3
from .warps import frame3, to_world3, uniform_cone3, uniform_cone_pdf, uniform_sphere3

AREA_MESH, AREA_SPHERE, POINT, DIRECTIONAL, ENVIRONMENT, ENVMAP, AREA_SHAPE, SPOT = range(8)
# parameter columns: spheres centre x y z, radius, flip; points position x y z, attenuation a b c; spots those, the
# axis x y z, then cos(outer), cos(inner), the angles outer, inner (radians) and the falloff (0 glTF's, 1 Mitsuba's
# linear in the angle), its texture's index in the texture table (-1: none), its right and up axes x y z and
# tan(outer) (Mitsuba's projection: scene/lights.SpotLight.texture_uv); directional lights direction x y z; meshes
# area, first triangle, triangle count, first cdf entry; disks and cylinders (AREA_SHAPE) their object-to-world
# and world-to-object 3x4 rows, shape code, flip; spheres also their world-to-object rows and object-space centre
# (for the UV); every area emitter its radiance texture's index in the texture table (-1: a constant radiance)
CENTER, RADIUS, SPHERE_FLIP, OBJECT_CENTER = 0, 3, 4, 5
POSITION, ATTENUATION = 0, 3
AXIS, COS_OUTER, COS_INNER, OUTER, INNER, FALLOFF = 6, 9, 10, 11, 12, 13
SPOT_TEX, RIGHT, UP, TAN_OUTER = 14, 15, 18, 21
DIRECTION = 0
AREA, FIRST_TRI, TRI_COUNT, FIRST_CDF = 0, 1, 2, 3
O2W, W2O, SHAPE_CODE, SHAPE_FLIP = 0, 12, 24, 25
AREA_TEX = 26
PARAMS = 27
INSIDE_SLACK = 1.0 + 1e-9  # a point this close to a sphere's surface counts as inside (sampled by area)


@nb.njit(**JIT, inline="always")
def _mesh_point(F, tri_v, tri_n, tri_cdf, e, u0, u1):
    """A point uniform by area on mesh emitter e: (point, normal, (u, v)); tri_n rows: the triangle's unit normal,
    then its corners' texture coordinates u0 v0 u1 v1 u2 v2 (zeros without UVs, as surface.uv_at)."""
    first, count, c0 = int(F[e, FIRST_TRI]), int(F[e, TRI_COUNT]), int(F[e, FIRST_CDF])
    lo, hi = 0, count  # the last j with cdf[j] <= u0 (NumPy's searchsorted(side="right") - 1)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tri_cdf[c0 + mid] <= u0:
            lo = mid
        else:
            hi = mid
    j = lo
    a, b = tri_cdf[c0 + j], tri_cdf[c0 + j + 1]
    u0 = min(max((u0 - a) / max(b - a, 1e-300), 0.0), 1.0 - 1e-16)
    s = math.sqrt(u0)
    b1, b2 = 1.0 - s, u1 * s
    b0 = 1.0 - b1 - b2
    t = first + j
    return ((b0 * tri_v[t, 0] + b1 * tri_v[t, 3] + b2 * tri_v[t, 6], b0 * tri_v[t, 1] + b1 * tri_v[t, 4] +
             b2 * tri_v[t, 7], b0 * tri_v[t, 2] + b1 * tri_v[t, 5] + b2 * tri_v[t, 8]),
            (tri_n[t, 0], tri_n[t, 1], tri_n[t, 2]),
            (b0 * tri_n[t, 3] + b1 * tri_n[t, 5] + b2 * tri_n[t, 7], b0 * tri_n[t, 4] + b1 * tri_n[t, 6] +
             b2 * tri_n[t, 8]))


@nb.njit(**JIT, inline="always")
def spot_falloff(F, e, cos_a):
    """The share of a spot light's intensity sent at angle a from its axis (scene/lights.SpotLight.cone_factor)."""
    if cos_a <= F[e, COS_OUTER]:
        return 0.0
    if F[e, FALLOFF] != 0:  # Mitsuba's spot
        if cos_a >= F[e, COS_INNER]:
            return 1.0
        return (F[e, OUTER] - math.acos(min(cos_a, 1.0))) / max(F[e, OUTER] - F[e, INNER], 1e-12)
    x = min((cos_a - F[e, COS_OUTER]) / max(F[e, COS_INNER] - F[e, COS_OUTER], 1e-3), 1.0)
    return x * x


@nb.njit(**JIT, inline="always")
def spot_texture(F, TI, TD, e, dx, dy, dz, cos_a):
    """Spot e's projected texture in the unit direction d from the light (cos_a = d . axis > 0): Mitsuba's
    uv = 1/2 + (d.right, d.up) / (2 cos_a tan(outer)); (1, 1, 1) without a texture."""
    t = int(F[e, SPOT_TEX])
    if t < 0:
        return 1.0, 1.0, 1.0
    s = 0.5 / (cos_a * F[e, TAN_OUTER])
    u = 0.5 + s * (dx * F[e, RIGHT] + dy * F[e, RIGHT + 1] + dz * F[e, RIGHT + 2])
    v = 0.5 + s * (dx * F[e, UP] + dy * F[e, UP + 1] + dz * F[e, UP + 2])
    return tex_eval3(TI, TD, t, u, v)


@nb.njit(**JIT, inline="always")
def _shape_jacobian(F, e, qx, qy):
    """Area of the world surface per unit of (u0, u1) at object point q of a disk or cylinder emitter: the disk
    sampled as r = sqrt(u0), phi = 2 pi u1 (area pi |Mx x My| spread evenly), the cylinder as z = u0, phi = 2 pi u1
    (2 pi |dp/dphi x Mz|, exact under any affine to_world)."""
    mx = (F[e, O2W], F[e, O2W + 4], F[e, O2W + 8])
    my = (F[e, O2W + 1], F[e, O2W + 5], F[e, O2W + 9])
    mz = (F[e, O2W + 2], F[e, O2W + 6], F[e, O2W + 10])
    if F[e, SHAPE_CODE] == CYLINDER_CODE:
        a = (qx * my[0] - qy * mx[0], qx * my[1] - qy * mx[1], qx * my[2] - qy * mx[2])  # dp/dphi at |q| = 1
        b = mz
        scale = 2.0 * math.pi
    else:
        a, b, scale = mx, my, math.pi
    cx, cy, cz = a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]
    return scale * math.sqrt(cx * cx + cy * cy + cz * cz)


@nb.njit(**JIT, inline="always")
def _shape_point(F, e, u0, u1):
    """A point on disk or cylinder emitter e: (world point, unit world normal (flipped as the surface emits),
    area pdf, (u, v) by Mitsuba's parametrisation: the cylinder's (phi / 2 pi, z), the disk's (r, phi / 2 pi))."""
    phi = 2.0 * math.pi * u1
    c, s = math.cos(phi), math.sin(phi)
    if F[e, SHAPE_CODE] == CYLINDER_CODE:
        qx, qy, qz, nx, ny, nz = c, s, u0, c, s, 0.0
        uv = (u1, u0)
    else:
        r = math.sqrt(u0)
        qx, qy, qz, nx, ny, nz = r * c, r * s, 0.0, 0.0, 0.0, 1.0
        uv = (r, u1)
    y = (F[e, O2W] * qx + F[e, O2W + 1] * qy + F[e, O2W + 2] * qz + F[e, O2W + 3],
         F[e, O2W + 4] * qx + F[e, O2W + 5] * qy + F[e, O2W + 6] * qz + F[e, O2W + 7],
         F[e, O2W + 8] * qx + F[e, O2W + 9] * qy + F[e, O2W + 10] * qz + F[e, O2W + 11])
    # normals by the inverse transpose: the world-to-object rows' columns
    wx = F[e, W2O] * nx + F[e, W2O + 4] * ny + F[e, W2O + 8] * nz
    wy = F[e, W2O + 1] * nx + F[e, W2O + 5] * ny + F[e, W2O + 9] * nz
    wz = F[e, W2O + 2] * nx + F[e, W2O + 6] * ny + F[e, W2O + 10] * nz
    ln = math.sqrt(wx * wx + wy * wy + wz * wz)
    sign = (-1.0 if F[e, SHAPE_FLIP] != 0 else 1.0) / max(ln, 1e-300)
    return y, (wx * sign, wy * sign, wz * sign), 1.0 / max(_shape_jacobian(F, e, qx, qy), 1e-300), uv


@nb.njit(**JIT, inline="always")
def _sphere_uv(F, e, y):
    """Mitsuba's sphere parametrisation (phi / 2 pi, theta / pi) of world point y on sphere emitter e, from its
    object-space point (surface.uv_at's)."""
    qx = F[e, W2O] * y[0] + F[e, W2O + 1] * y[1] + F[e, W2O + 2] * y[2] + F[e, W2O + 3] - F[e, OBJECT_CENTER]
    qy = F[e, W2O + 4] * y[0] + F[e, W2O + 5] * y[1] + F[e, W2O + 6] * y[2] + F[e, W2O + 7] - F[e, OBJECT_CENTER + 1]
    qz = F[e, W2O + 8] * y[0] + F[e, W2O + 9] * y[1] + F[e, W2O + 10] * y[2] + F[e, W2O + 11] - F[e, OBJECT_CENTER + 2]
    phi = math.atan2(qy, qx)
    if phi < 0:
        phi += 2.0 * math.pi
    r = max(math.sqrt(qx * qx + qy * qy + qz * qz), 1e-300)
    return phi / (2.0 * math.pi), math.acos(min(max(qz / r, -1.0), 1.0)) / math.pi


@nb.njit(**JIT, inline="always")
def emitter_sample(K, R, F, tri_v, tri_n, tri_cdf, env, tex, e, px, py, pz, u0, u1):
    """Sample emitter e from point p: (unit direction, distance (inf at infinity), radiance / pdf (0 where the
    sample is invalid), solid-angle pdf (inf for delta lights)). env: the environment map's tables; tex: the
    texture table (TI, TD)."""
    k = K[e]
    if k == POINT or k == SPOT:
        tx, ty, tz = F[e, POSITION] - px, F[e, POSITION + 1] - py, F[e, POSITION + 2] - pz
        dist = math.sqrt(tx * tx + ty * ty + tz * tz)
        att = F[e, ATTENUATION] + F[e, ATTENUATION + 1] * dist + F[e, ATTENUATION + 2] * dist * dist
        d = (tx / dist, ty / dist, tz / dist)
        f0 = f1 = f2 = 1.0
        if k == SPOT:
            cos_a = -(d[0] * F[e, AXIS] + d[1] * F[e, AXIS + 1] + d[2] * F[e, AXIS + 2])
            f = spot_falloff(F, e, cos_a)
            f0 = f1 = f2 = f
            if f > 0:
                r, g, b = spot_texture(F, tex[0], tex[1], e, -d[0], -d[1], -d[2], cos_a)
                f0, f1, f2 = f * r, f * g, f * b
        return d, dist, (R[e, 0] * f0 / att, R[e, 1] * f1 / att, R[e, 2] * f2 / att), math.inf
    if k == DIRECTIONAL:
        return ((-F[e, DIRECTION], -F[e, DIRECTION + 1], -F[e, DIRECTION + 2]), math.inf,
                (R[e, 0], R[e, 1], R[e, 2]), math.inf)
    if k == ENVMAP:
        d, w, pdf = envmap_sample(env, u0, u1)
        return d, math.inf, w, pdf
    if k == ENVIRONMENT:
        s = 4.0 * math.pi
        return uniform_sphere3(u0, u1), math.inf, (R[e, 0] * s, R[e, 1] * s, R[e, 2] * s), 1.0 / s
    inside = False
    uv = (0.0, 0.0)
    if k == AREA_MESH:
        y, nrm, uv = _mesh_point(F, tri_v, tri_n, tri_cdf, e, u0, u1)
        area_pdf = 1.0 / F[e, AREA]
    elif k == AREA_SHAPE:
        y, nrm, area_pdf, uv = _shape_point(F, e, u0, u1)
    else:  # AREA_SPHERE: by the solid angle of its cone from outside, uniformly by area from inside
        cx, cy, cz, r = F[e, CENTER], F[e, CENTER + 1], F[e, CENTER + 2], F[e, RADIUS]
        tx, ty, tz = cx - px, cy - py, cz - pz
        dc = math.sqrt(tx * tx + ty * ty + tz * tz)
        inside = dc <= r * INSIDE_SLACK
        if inside:
            q = uniform_sphere3(u0, u1)
            y = (cx + r * q[0], cy + r * q[1], cz + r * q[2])
            area_pdf = 1.0 / (4.0 * math.pi * r * r)
        else:
            inv = 1.0 / max(dc, 1e-300)
            ax, ay, az = tx * inv, ty * inv, tz * inv
            cos_max = math.sqrt(1.0 - min((r * inv) ** 2, 1.0))
            s, t = frame3(ax, ay, az)
            lx, ly, lz = uniform_cone3(u0, u1, cos_max)
            dx, dy, dz = to_world3(lx, ly, lz, s, t, ax, ay, az)
            # the nearest intersection of p + x d with the sphere (the tangent ray when rounding misses it)
            b = dx * tx + dy * ty + dz * tz
            x = b - math.sqrt(max(b * b - (dc * dc - r * r), 0.0))
            y = (px + x * dx, py + x * dy, pz + x * dz)
            area_pdf = uniform_cone_pdf(cos_max)
        sign = -1.0 if F[e, SPHERE_FLIP] != 0 else 1.0
        nrm = ((y[0] - cx) / r * sign, (y[1] - cy) / r * sign, (y[2] - cz) / r * sign)
        if F[e, AREA_TEX] >= 0:
            uv = _sphere_uv(F, e, y)
    tx, ty, tz = y[0] - px, y[1] - py, y[2] - pz
    dist = math.sqrt(tx * tx + ty * ty + tz * tz)
    inv = 1.0 / max(dist, 1e-300)
    d = (tx * inv, ty * inv, tz * inv)
    cos_l = -(d[0] * nrm[0] + d[1] * nrm[1] + d[2] * nrm[2])
    if not (cos_l > 0 and dist > 0):
        return d, dist, (0.0, 0.0, 0.0), 0.0
    pdf = area_pdf if k == AREA_SPHERE and not inside else area_pdf * dist * dist / max(cos_l, 1e-300)
    m = 1.0 / max(pdf, 1e-300)
    le0, le1, le2 = R[e, 0], R[e, 1], R[e, 2]
    if F[e, AREA_TEX] >= 0:
        le0, le1, le2 = tex_eval3(tex[0], tex[1], int(F[e, AREA_TEX]), uv[0], uv[1])
    return d, dist, (le0 * m, le1 * m, le2 * m), pdf


@nb.njit(**JIT)
def emitter_pdf(K, F, e, px, py, pz, yx, yy, yz, nx, ny, nz):
    """Solid-angle pdf with which emitter_sample(e) from p would have chosen the point y (emitting normal n) of an
    area emitter; the constant environment's for directions. (Environment maps: kernels/path/envmap.py.)"""
    k = K[e]
    if k == ENVIRONMENT:
        return 1.0 / (4.0 * math.pi)
    if k != AREA_MESH and k != AREA_SPHERE and k != AREA_SHAPE:
        return 0.0
    tx, ty, tz = yx - px, yy - py, yz - pz
    dist2 = tx * tx + ty * ty + tz * tz
    cos_l = abs(tx * nx + ty * ny + tz * nz) / math.sqrt(max(dist2, 1e-300))
    if k == AREA_MESH:
        return dist2 / max(F[e, AREA] * cos_l, 1e-300)
    if k == AREA_SHAPE:
        qx = F[e, W2O] * yx + F[e, W2O + 1] * yy + F[e, W2O + 2] * yz + F[e, W2O + 3]
        qy = F[e, W2O + 4] * yx + F[e, W2O + 5] * yy + F[e, W2O + 6] * yz + F[e, W2O + 7]
        return dist2 / max(_shape_jacobian(F, e, qx, qy) * cos_l, 1e-300)
    r = F[e, RADIUS]
    cx, cy, cz = F[e, CENTER] - px, F[e, CENTER + 1] - py, F[e, CENTER + 2] - pz
    dc = math.sqrt(cx * cx + cy * cy + cz * cz)
    if dc <= r * INSIDE_SLACK:
        return dist2 / max(4.0 * math.pi * r * r * cos_l, 1e-300)
    return uniform_cone_pdf(math.sqrt(1.0 - min((r / max(dc, 1e-300)) ** 2, 1.0)))


@nb.njit(**JIT, inline="always")
def pick_sample(lights, env, tex, u_pick, u0, u1, px, py, pz):
    """Next-event estimation from p: an emitter picked uniformly by u_pick, then sampled by (u0, u1); the weight
    and pdf include the pick (weight times the count, finite pdfs divided by it). lights and env as in
    kernels/path/bounce.shade_bounce, tex the texture table (TI, TD)."""
    K, R, F, tri_v, tri_n, tri_cdf, _, _ = lights
    count = K.shape[0]
    e = min(int(u_pick * count), count - 1)
    d, dist, w, pdf = emitter_sample(K, R, F, tri_v, tri_n, tri_cdf, env, tex, e, px, py, pz, u0, u1)
    if not math.isinf(pdf):
        pdf /= count
    return d, dist, (w[0] * count, w[1] * count, w[2] * count), pdf


@nb.njit(**JIT)
def sample_lights_kernel(p, u_pick, u, lights, env, tex, d, dist, w, pdf):
    """pick_sample for every point p[i] (NumPy arrays in, outputs written in place)."""
    for i in range(p.shape[0]):
        di, dist[i], wi, pdf[i] = pick_sample(lights, env, tex, u_pick[i], u[i, 0], u[i, 1], p[i, 0], p[i, 1], p[i, 2])
        d[i, 0], d[i, 1], d[i, 2] = di
        w[i, 0], w[i, 1], w[i, 2] = wi


@nb.njit(**JIT)
def light_pdf_kernel(em, p, y, normal, K, F, out):
    """out[i] = emitter_pdf of emitter em[i] from p[i] to y[i], divided by the emitter count (the pick)."""
    for i in range(em.shape[0]):
        out[i] = emitter_pdf(K, F, em[i], p[i, 0], p[i, 1], p[i, 2], y[i, 0], y[i, 1], y[i, 2], normal[i, 0],
                             normal[i, 1], normal[i, 2]) / K.shape[0]
