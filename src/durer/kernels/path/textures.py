"""Mitsuba's textures as scalar Numba functions over one packed table, and the per-hit resolution of a BSDF row whose
parameters name textures: the path tracer's bounce looks them up at the hit's UV with nothing in Python per bounce.

The table (rendering/textures.py builds it once per render): TI, one float64 row per texture (columns below), and TD,
every bitmap's texels in one float32 array (row-major (H, W, C) from OFFSET, C = 1 or 3, linear values). A bitmap
follows Mitsuba 3's `bitmap` (measured against mi.load_dict(...).eval in scalar_rgb): (u, v) = to_uv @ (u, v, 1), pixel
coordinates x = u W, y = v H with row 0 the file's first (top) row and texel centres at half-integers; bilinear
mixes the four texels around (x - 1/2, y - 1/2), nearest takes floor(x), floor(y); each index is wrapped by repeat,
mirror or clamp. A number read from a colour texture is its luminance (Mitsuba's eval_1). A checkerboard's colour is
color0 where frac(u) > 1/2 and frac(v) > 1/2 agree, color1 where they differ; a number read from it (a roughness,
weight or opacity) is the *other* colour's channel mean, as Mitsuba 3.9's checkerboard eval_1 swaps the two and an
rgb constant's eval_1 is its mean (measured: color0 0, color1 0.4 gives eval 0 and eval_1 0.4 at uv (0.25, 0.25)).
"""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT
from .bsdf import anisotropic
from .columns import (
    AU,
    AV,
    BLEND,
    BUMP_SCALE,
    C1,
    C2,
    CHILD0,
    COLUMNS,
    EMISSION,
    KIND,
    MAP_FLIP,
    MAP_SHADOW,
    MAP_TWOSIDED,
    NUMBER_PAIRS,
    OPACITY,
    TEX_AU,
    TEX_AV,
    TEX_BUMP,
    TEX_C1,
    TEX_C2,
    TEX_EMISSION,
    TEX_NORMAL,
    TEX_NUMBERS,
    TEX_OPACITY,
    TEX_WEIGHT,
    WEIGHT,
)
from .warps import frame3, tangent_frame3

BITMAP, CHECKER = 0, 1
REPEAT, MIRROR, CLAMP = 0, 1, 2
BILINEAR, NEAREST = 0, 1
# columns of TI: kind, texel offset in TD, width, height, channels, wrap mode, filter, to_uv's first two rows (u' = a u
# + b v + c, v' = d u + e v + f), a checkerboard's two colours
TKIND, OFFSET, WIDTH, HEIGHT, CHANNELS, WRAP, FILTER, TO_UV, COLOR0, COLOR1 = 0, 1, 2, 3, 4, 5, 6, 7, 13, 16
TCOLS = 19
LUMA = (0.212671, 0.715160, 0.072169)  # Mitsuba's luminance of linear sRGB


@nb.njit(**JIT, inline="always")
def _wrap(i, n, mode):
    """Texel index i wrapped into [0, n) by Mitsuba's repeat, mirror or clamp."""
    if mode == CLAMP:
        return min(max(i, 0), n - 1)
    if mode == MIRROR:
        i = i % (2 * n)
        return 2 * n - i - 1 if i >= n else i
    return i % n


@nb.njit(**JIT, inline="always")
def _texel(TD, base, w, c, x, y, k):
    return TD[base + (y * w + x) * c + k]


@nb.njit(**JIT)
def _uv(TI, t, u, v):
    return (TI[t, TO_UV] * u + TI[t, TO_UV + 1] * v + TI[t, TO_UV + 2],
            TI[t, TO_UV + 3] * u + TI[t, TO_UV + 4] * v + TI[t, TO_UV + 5])


@nb.njit(**JIT)
def _bitmap(TI, TD, t, u, v):
    """(r, g, b) of bitmap t at transformed (u, v); a one-channel bitmap gives its value thrice."""
    w, h, c = int(TI[t, WIDTH]), int(TI[t, HEIGHT]), int(TI[t, CHANNELS])
    base, mode = int(TI[t, OFFSET]), int(TI[t, WRAP])
    x, y = u * w, v * h
    if TI[t, FILTER] == NEAREST:
        i, j = _wrap(int(math.floor(x)), w, mode), _wrap(int(math.floor(y)), h, mode)
        r = _texel(TD, base, w, c, i, j, 0)
        if c == 1:
            return r, r, r
        return r, _texel(TD, base, w, c, i, j, 1), _texel(TD, base, w, c, i, j, 2)
    x, y = x - 0.5, y - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    i0, j0 = _wrap(int(x0), w, mode), _wrap(int(y0), h, mode)
    i1, j1 = _wrap(int(x0) + 1, w, mode), _wrap(int(y0) + 1, h, mode)
    out0 = out1 = out2 = 0.0
    for k in range(c):
        top = (1.0 - fx) * _texel(TD, base, w, c, i0, j0, k) + fx * _texel(TD, base, w, c, i1, j0, k)
        bottom = (1.0 - fx) * _texel(TD, base, w, c, i0, j1, k) + fx * _texel(TD, base, w, c, i1, j1, k)
        val = (1.0 - fy) * top + fy * bottom
        if k == 0:
            out0 = val
        elif k == 1:
            out1 = val
        else:
            out2 = val
    if c == 1:
        return out0, out0, out0
    return out0, out1, out2


@nb.njit(**JIT, inline="always")
def _checker_colour(u, v, number):
    """Column of the checkerboard colour at transformed (u, v): color0 where the halves agree (eval), or for a
    number (eval_1) the other one, as Mitsuba 3.9 does."""
    agree = (u - math.floor(u) > 0.5) == (v - math.floor(v) > 0.5)
    return COLOR0 if agree != number else COLOR1


@nb.njit(**JIT)
def tex_eval3(TI, TD, t, u, v):
    """Colour (r, g, b) of texture t at the hit's texture coordinates (u, v)."""
    u, v = _uv(TI, t, u, v)
    if TI[t, TKIND] == CHECKER:
        col = _checker_colour(u, v, False)
        return TI[t, col], TI[t, col + 1], TI[t, col + 2]
    return _bitmap(TI, TD, t, u, v)


@nb.njit(**JIT)
def tex_eval1(TI, TD, t, u, v):
    """A number from texture t at (u, v): a one-channel texture's value, a colour bitmap's luminance, a
    checkerboard's channel mean of the colour Mitsuba's eval_1 picks (the other one than tex_eval3's)."""
    if TI[t, TKIND] == CHECKER:
        uu, vv = _uv(TI, t, u, v)
        col = _checker_colour(uu, vv, True)
        return (TI[t, col] + TI[t, col + 1] + TI[t, col + 2]) / 3.0  # an rgb constant's eval_1: its mean
    r, g, b = tex_eval3(TI, TD, t, u, v)
    if TI[t, TKIND] == BITMAP and TI[t, CHANNELS] == 1:
        return r
    return LUMA[0] * r + LUMA[1] * g + LUMA[2] * b


@nb.njit(**JIT)
def tex_grad1(TI, TD, t, u, v):
    """(d/du, d/dv) of tex_eval1 at (u, v) (Mitsuba's eval_1_grad: the bilinear patch's slopes in texels, times
    the resolution, through to_uv); zero for checkerboards and nearest filtering."""
    if TI[t, TKIND] != BITMAP or TI[t, FILTER] == NEAREST:
        return 0.0, 0.0
    uu, vv = _uv(TI, t, u, v)
    w, h, c = int(TI[t, WIDTH]), int(TI[t, HEIGHT]), int(TI[t, CHANNELS])
    base, mode = int(TI[t, OFFSET]), int(TI[t, WRAP])
    x, y = uu * w - 0.5, vv * h - 0.5
    x0, y0 = math.floor(x), math.floor(y)
    fx, fy = x - x0, y - y0
    i0, j0 = _wrap(int(x0), w, mode), _wrap(int(y0), h, mode)
    i1, j1 = _wrap(int(x0) + 1, w, mode), _wrap(int(y0) + 1, h, mode)
    f00 = f10 = f01 = f11 = 0.0
    for k in range(c):
        wk = 1.0 if c == 1 else LUMA[k]
        f00 += wk * _texel(TD, base, w, c, i0, j0, k)
        f10 += wk * _texel(TD, base, w, c, i1, j0, k)
        f01 += wk * _texel(TD, base, w, c, i0, j1, k)
        f11 += wk * _texel(TD, base, w, c, i1, j1, k)
    du = ((f10 - f00) * (1.0 - fy) + (f11 - f01) * fy) * w
    dv = ((f01 - f00) * (1.0 - fx) + (f11 - f10) * fx) * h
    return (du * TI[t, TO_UV] + dv * TI[t, TO_UV + 3], du * TI[t, TO_UV + 1] + dv * TI[t, TO_UV + 4])


@nb.njit(**JIT, inline="always")
def _copy_row(P, s, Q, r):
    for c in range(COLUMNS):
        Q[r, c] = P[s, c]


@nb.njit(**JIT)
def _substitute(Q, r, TI, TD, u, v):
    """Row r of Q with each textured parameter (a TEX_* column's, or a TEX_NUMBERS pair's) replaced by its
    texture's value at (u, v)."""
    for col, ref in ((C1, TEX_C1), (C2, TEX_C2), (EMISSION, TEX_EMISSION)):
        t = int(Q[r, ref])
        if t >= 0:
            Q[r, col], Q[r, col + 1], Q[r, col + 2] = tex_eval3(TI, TD, t, u, v)
    for col, ref in ((AU, TEX_AU), (AV, TEX_AV)):
        t = int(Q[r, ref])
        if t >= 0:
            Q[r, col] = max(tex_eval1(TI, TD, t, u, v), 1e-4)  # as Mitsuba's microfacet distributions
    for col, ref in ((OPACITY, TEX_OPACITY), (WEIGHT, TEX_WEIGHT)):
        t = int(Q[r, ref])
        if t >= 0:
            Q[r, col] = min(max(tex_eval1(TI, TD, t, u, v), 0.0), 1.0)
    for k in range(NUMBER_PAIRS):  # (column, texture) pairs, the used ones first: eval_1 unclamped, as Mitsuba's
        t = int(Q[r, TEX_NUMBERS + 2 * k + 1])  # principled reads its weights
        if t < 0:
            break
        Q[r, int(Q[r, TEX_NUMBERS + 2 * k])] = tex_eval1(TI, TD, t, u, v)


@nb.njit(**JIT)
def resolve_row(P, s, Q, r, TI, TD, u, v):
    """Slot s's row with its textures looked up at (u, v), written to Q[r] (a blend's two BSDFs to Q[r + 1] and
    Q[r + 2], which Q[r] then names): the BSDF kernels read Q[r] as they read a constant row."""
    _copy_row(P, s, Q, r)
    _substitute(Q, r, TI, TD, u, v)
    if Q[r, KIND] == BLEND:
        for k in range(2):
            _copy_row(P, int(P[s, CHILD0 + k]), Q, r + 1 + k)
            _substitute(Q, r + 1 + k, TI, TD, u, v)
            Q[r, CHILD0 + k] = r + 1 + k


@nb.njit(**JIT)
def eval3_kernel(TI, TD, t, uv, out):
    """out[i] = tex_eval3 of texture t at uv[i] (arrays (n, 2) -> (n, 3))."""
    for i in range(uv.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = tex_eval3(TI, TD, t, uv[i, 0], uv[i, 1])


@nb.njit(**JIT, inline="always")
def _unit(x, y, z):
    ln = math.sqrt(x * x + y * y + z * z)
    if ln == 0:
        return 0.0, 0.0, 0.0, False
    return x / ln, y / ln, z / ln, True


@nb.njit(**JIT)
def shading_frame(P, s, TI, TD, n, g, surf, wi):
    """_map_frame's frame and the unperturbed normal on its side, which map_factor reads: (normal, tangent s, tangent
    t, perturbed, side). side is n, or -n where a `twosided` around the map (MAP_TWOSIDED) is seen from behind:
    Mitsuba's twosided mirrors wi and wo about the surface before the map sees them, which is the map's frame (made
    for the mirrored wi) mirrored, since the BSDF reads only local coordinates."""
    nx, ny, nz = n
    c = 2.0 * (wi[0] * nx + wi[1] * ny + wi[2] * nz)
    if P[s, MAP_TWOSIDED] == 0 or c >= 0:
        m, a, b, bent = _map_frame(P, s, TI, TD, n, g, surf, wi)
        return m, a, b, bent, n
    m, a, b, bent = _map_frame(P, s, TI, TD, n, g, surf, (wi[0] - c * nx, wi[1] - c * ny, wi[2] - c * nz))
    return _mirror(m, n), _mirror(a, n), _mirror(b, n), bent, (-nx, -ny, -nz)


@nb.njit(**JIT, inline="always")
def _mirror(v, n):
    c = 2.0 * (v[0] * n[0] + v[1] * n[1] + v[2] * n[2])
    return v[0] - c * n[0], v[1] - c * n[1], v[2] - c * n[2]


@nb.njit(**JIT)
def _map_frame(P, s, TI, TD, n, g, surf, wi):
    """The BSDF frame (normal, tangent s, tangent t, perturbed) at a hit with unit shading normal n and geometric
    normal g (both on the side the BSDF uses), surf = (u, v, dp/du, dp/dv), seen from world direction wi: the plain
    frame3(n), or the frame of Mitsuba's normalmap or bumpmap, whose formulas (Mitsuba 3.9, measured through its
    eval; see tests/test_kernels_path_compose.py) start from the shading frame (s0, t0, n), s0 = dp/du made
    orthogonal to n. normalmap: normal 2 rgb - 1 in that frame, tangent s0 made orthogonal to it. bumpmap: dp/du and
    dp/dv tilted along n by the height's gradient times the scale, normal their cross product turned to g's side,
    tangent Mitsuba's sh_frame.to_world(dp/du) (dp/du's world components read as local ones, as Mitsuba 3.9 does)
    made orthogonal to it. With MAP_FLIP (flip_invalid_normals) a map normal m on the other side of wi than n is
    mirrored about n first, 2 (m.n) n - m (measured: Mitsuba negates its two tangential components; wi from behind
    flips m where wi.m > 0). Anisotropic BSDFs without a map use Mitsuba's frame of dp/du (warps.tangent_frame3)."""
    nx, ny, nz = n
    tn, tb = int(P[s, TEX_NORMAL]), int(P[s, TEX_BUMP])
    u, v, dux, duy, duz, dvx, dvy, dvz = surf
    if tn >= 0 or tb >= 0:
        d = nx * dux + ny * duy + nz * duz
        sx, sy, sz, ok = _unit(dux - d * nx, duy - d * ny, duz - d * nz)
        if not ok:
            sx, sy, sz = frame3(nx, ny, nz)[0]
        tx, ty, tz = ny * sz - nz * sy, nz * sx - nx * sz, nx * sy - ny * sx
        if tn >= 0:
            r, gg, b = tex_eval3(TI, TD, tn, u, v)
            lx, ly, lz = 2.0 * r - 1.0, 2.0 * gg - 1.0, 2.0 * b - 1.0
            mx, my, mz, ok = _unit(lx * sx + ly * tx + lz * nx, lx * sy + ly * ty + lz * ny,
                                   lx * sz + ly * tz + lz * nz)
            dux, duy, duz = sx, sy, sz  # the tangent to make orthogonal to the new normal
        else:
            gu, gv = tex_grad1(TI, TD, tb, u, v)
            gu, gv = gu * P[s, BUMP_SCALE], gv * P[s, BUMP_SCALE]
            a, b = gu - d, gv - (nx * dvx + ny * dvy + nz * dvz)
            pux, puy, puz = dux + a * nx, duy + a * ny, duz + a * nz  # the tilted dp/du and dp/dv
            pvx, pvy, pvz = dvx + b * nx, dvy + b * ny, dvz + b * nz
            mx, my, mz, ok = _unit(puy * pvz - puz * pvy, puz * pvx - pux * pvz, pux * pvy - puy * pvx)
            if mx * g[0] + my * g[1] + mz * g[2] < 0:
                mx, my, mz = -mx, -my, -mz
            dux, duy, duz = (dux * sx + duy * tx + duz * nx, dux * sy + duy * ty + duz * ny,
                             dux * sz + duy * tz + duz * nz)  # sh_frame.to_world(dp/du), as Mitsuba 3.9
        if ok and P[s, MAP_FLIP] != 0 and (mx * wi[0] + my * wi[1] + mz * wi[2]) * (nx * wi[0] + ny * wi[1]
                                                                                  + nz * wi[2]) < 0:
            c = 2.0 * (mx * nx + my * ny + mz * nz)
            mx, my, mz = c * nx - mx, c * ny - my, c * nz - mz
        if ok:
            d = mx * dux + my * duy + mz * duz
            sx, sy, sz, ok = _unit(dux - d * mx, duy - d * my, duz - d * mz)
            if ok:
                return ((mx, my, mz), (sx, sy, sz), (my * sz - mz * sy, mz * sx - mx * sz, mx * sy - my * sx), True)
            return (mx, my, mz), frame3(mx, my, mz)[0], frame3(mx, my, mz)[1], True
    if anisotropic(P, s):  # Mitsuba's dp/du frame orients anisotropic roughness; the rest keep frame3(n)
        ts, tt = tangent_frame3(nx, ny, nz, dux, duy, duz, g[0], g[1], g[2])
    else:
        ts, tt = frame3(nx, ny, nz)
    return (nx, ny, nz), ts, tt, False


@nb.njit(**JIT)
def map_factor(P, s, n, m, w):
    """What a normal or bump map multiplies the BSDF's value (and a sampled weight) by for world direction w, n the
    unperturbed and m the map's normal: 0 where w lies on different sides of the two (Mitsuba's test of both frames'
    cos(theta)), else with MAP_SHADOW (use_shadowing_function) the shadowing term of Conty Estevez et al. 2019 that
    Mitsuba 3.9 applies, 2 / (1 + sqrt(1 + a2 tan^2(theta_w))) with a2 = clamp(tan^2(theta_d) / 8, 0, 1), theta_d the
    angle between m and n and theta_w w's to n (measured: eval and sample weight, not the pdf), else 1."""
    cw = w[0] * n[0] + w[1] * n[1] + w[2] * n[2]
    if cw * (w[0] * m[0] + w[1] * m[1] + w[2] * m[2]) <= 0:
        return 0.0
    if P[s, MAP_SHADOW] == 0:
        return 1.0
    cd = min(abs(m[0] * n[0] + m[1] * n[1] + m[2] * n[2]), 1.0)
    a2 = min(max(0.125 * (1.0 - cd * cd) / (cd * cd), 0.0), 1.0) if cd > 0 else 1.0
    ci = max(min(abs(cw), 1.0), 1e-6)
    return 2.0 / (1.0 + math.sqrt(1.0 + a2 * (1.0 - ci * ci) / (ci * ci)))
