"""An environment map as scalar Numba functions: radiance by direction (bilinear), importance sampling in
O(log n) (a binary search in the row cdf, then in that row's column cdf) and its pdf per solid angle, over the
tables rendering/envmap.py builds once per render (which documents the conventions: Mitsuba's latitude-longitude
mapping, texel centres at u = (i + 1/2) / W and v = j / (H - 1)). The path tracer's bounce calls them for rays that
escape and for next-event estimation; the array kernels below serve rendering/envmap.EnvMapLight.

env = (grid (H, W + 1, 3): the scaled image with its first column repeated, cell_pdf (H - 1, W): each cell's
probability, row_cdf (H,), col_cdf (H - 1, W + 1): per row the cdf of its cells, to_local (3, 3), to_world (3, 3),
row_guide (GUIDE + 1,), col_guide (H - 1, GUIDE + 1): where each cdf's search starts, guide_of); a scene without a
map passes the same arrays empty (H = 0)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..common import JIT

GUIDE = 64  # buckets of a cdf's guide table (a power of two: u * GUIDE is exact)


@nb.njit(**JIT, inline="always")
def has_map(env) -> bool:
    """Whether env holds a map (or the empty tables of a scene without one)."""
    return env[0].shape[0] > 0


@nb.njit(**JIT)
def _texel_xy(env, dx, dy, dz):
    """Continuous texel coordinates (x in [0, W], y in [0, H - 1]) of direction d (any length)."""
    grid, to_local = env[0], env[4]
    h, w = grid.shape[0], grid.shape[1] - 1
    vx = to_local[0, 0] * dx + to_local[0, 1] * dy + to_local[0, 2] * dz
    vy = to_local[1, 0] * dx + to_local[1, 1] * dy + to_local[1, 2] * dz
    vz = to_local[2, 0] * dx + to_local[2, 1] * dy + to_local[2, 2] * dz
    ln = math.sqrt(vx * vx + vy * vy + vz * vz)
    vx, vy, vz = vx / ln, vy / ln, vz / ln
    u = math.atan2(vx, -vz) / (2 * math.pi)
    x = (u * w - 0.5) % w  # Python's float modulo: NumPy's np.mod (the sign of w)
    return x, math.acos(min(max(vy, -1.0), 1.0)) / math.pi * (h - 1)


@nb.njit(**JIT, inline="always")
def _bilinear(grid, x, y):
    """The image's radiance (r, g, b) at texel coordinates (x, y): bilinear between the four texels around."""
    h, w = grid.shape[0], grid.shape[1] - 1
    i, j = min(int(x), w - 1), min(int(y), h - 2)
    fx, fy = x - i, y - j
    return _lerp(grid, i, j, fx, fy, 0), _lerp(grid, i, j, fx, fy, 1), _lerp(grid, i, j, fx, fy, 2)


@nb.njit(**JIT, inline="always")
def _lerp(grid, i, j, fx, fy, c):
    """Channel c between texels (i, j) and (i + 1, j + 1) (no list: the fused bounce runs without NRT)."""
    top = (1 - fx) * grid[j, i, c] + fx * grid[j, i + 1, c]
    bottom = (1 - fx) * grid[j + 1, i, c] + fx * grid[j + 1, i + 1, c]
    return (1 - fy) * top + fy * bottom


@nb.njit(**JIT, inline="always")
def _density(cell_pdf, i, j, y):
    """Density per solid angle in cell (i, j) at texel row coordinate y: the cell's probability spread over its
    (theta, phi) rectangle, divided by sin(theta) of the point itself (0 at the poles)."""
    h, w = cell_pdf.shape[0] + 1, cell_pdf.shape[1]
    s = math.sin(y / (h - 1) * math.pi)
    if not s > 0:
        return 0.0
    return cell_pdf[j, i] * w * (h - 1) / (2 * math.pi * math.pi * max(s, 1e-300))


@nb.njit(**JIT)
def envmap_eval(env, dx, dy, dz):
    """Radiance (r, g, b) arriving from direction d (pointing away from the scene): the bilinear lookup."""
    x, y = _texel_xy(env, dx, dy, dz)
    return _bilinear(env[0], x, y)


@nb.njit(**JIT)
def envmap_pdf(env, dx, dy, dz):
    """Density per solid angle with which envmap_sample picks direction d."""
    grid = env[0]
    x, y = _texel_xy(env, dx, dy, dz)
    return _density(env[1], min(int(x), grid.shape[1] - 2), min(int(y), grid.shape[0] - 2), y)


@nb.njit(**JIT)
def envmap_eval_pdf(env, dx, dy, dz):
    """envmap_eval and envmap_pdf of direction d with one mapping to texel coordinates: ((r, g, b), pdf)."""
    grid = env[0]
    x, y = _texel_xy(env, dx, dy, dz)
    pdf = _density(env[1], min(int(x), grid.shape[1] - 2), min(int(y), grid.shape[0] - 2), y)
    return _bilinear(grid, x, y), pdf


@nb.njit(**JIT, inline="always")
def _last_at_most(cdf, n, u):
    """The last k in [0, n) with cdf[k] <= u (cdf non-decreasing from cdf[0] = 0): NumPy's
    searchsorted(side="right") - 1, clipped, by bisection."""
    return _bisect(cdf, 0, n, u)


@nb.njit(**JIT, inline="always")
def _bisect(cdf, lo, hi, u):
    """The last k in [lo, hi) with cdf[k] <= u, given cdf[lo] <= u (or lo = 0) and cdf[hi] > u (or hi = n)."""
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if cdf[mid] <= u:
            lo = mid
        else:
            hi = mid
    return lo


@nb.njit(**JIT, inline="always")
def _guided(cdf, guide, n, u):
    """_last_at_most(cdf, n, u) for u in [0, 1), the bisection started in the bucket of u: the answer lies between
    the answers for the bucket's two ends, guide[g] and guide[g + 1] (guide_of), so the same index is found in a
    few steps within a cache line or two of the cdf instead of ~log2(n) steps across it, each a likely cache miss
    (museum.exr, 512 x 256: envmap_sample 261 -> 233 ns, medians of 5 alternating processes, loaded machine)."""
    g = min(int(u * GUIDE), GUIDE - 1)
    return _bisect(cdf, guide[g], min(guide[g + 1] + 1, n), u)


def guide_of(cdf: np.ndarray, n: int) -> np.ndarray:
    """The guide table of a cdf's first n entries (cdf[0] = 0, non-decreasing), or of each row of a 2-D cdf:
    entry g = _last_at_most(cdf, n, g / GUIDE) for g = 0..GUIDE (int32)."""
    ends = np.arange(GUIDE + 1) / GUIDE
    rows = np.atleast_2d(cdf)[:, :n]
    out = np.empty((len(rows), GUIDE + 1), np.int32)
    for k, row in enumerate(rows):
        out[k] = np.searchsorted(row, ends, side="right") - 1
    return out[0] if cdf.ndim == 1 else out


@nb.njit(**JIT)
def envmap_sample(env, u0, u1):
    """A direction drawn with density envmap_pdf from (u0, u1) in [0, 1)^2: the row by u0, the cell in it by u1,
    then uniformly in the cell's (theta, phi) rectangle. Returns (direction, radiance / pdf (0 where the pdf is
    0), pdf), radiance and pdf taken at the sampled texel coordinates (envmap_eval and envmap_pdf of the direction
    up to rounding, without mapping it back)."""
    grid, row_cdf, col_cdf, to_world = env[0], env[2], env[3], env[5]
    h, w = grid.shape[0], grid.shape[1] - 1
    j = _guided(row_cdf, env[6], h - 1, u0)
    v = (u0 - row_cdf[j]) / max(row_cdf[j + 1] - row_cdf[j], 1e-300)
    i = _guided(col_cdf[j], env[7][j], w, u1)
    u = (u1 - col_cdf[j, i]) / max(col_cdf[j, i + 1] - col_cdf[j, i], 1e-300)
    x, y = i + min(max(u, 0.0), 1.0), j + min(max(v, 0.0), 1.0)
    theta, phi = y / (h - 1) * math.pi, (x + 0.5) / w * 2 * math.pi
    s = math.sin(theta)
    lx, ly, lz = s * math.sin(phi), math.cos(theta), -s * math.cos(phi)
    dx = to_world[0, 0] * lx + to_world[0, 1] * ly + to_world[0, 2] * lz
    dy = to_world[1, 0] * lx + to_world[1, 1] * ly + to_world[1, 2] * lz
    dz = to_world[2, 0] * lx + to_world[2, 1] * ly + to_world[2, 2] * lz
    ln = math.sqrt(dx * dx + dy * dy + dz * dz)
    # radiance and pdf at (x, y) itself, the texel coordinates the direction maps back to (up to rounding)
    pdf = _density(env[1], i, j, y)
    if not pdf > 0:
        return (dx / ln, dy / ln, dz / ln), (0.0, 0.0, 0.0), pdf
    r, g, b = _bilinear(grid, x, y)
    m = 1.0 / max(pdf, 1e-300)
    return (dx / ln, dy / ln, dz / ln), (r * m, g * m, b * m), pdf


@nb.njit(**JIT)
def envmap_eval_kernel(env, d, out):
    """out[i] = envmap_eval of direction d[i] (arrays (n, 3))."""
    for i in range(d.shape[0]):
        out[i, 0], out[i, 1], out[i, 2] = envmap_eval(env, d[i, 0], d[i, 1], d[i, 2])


@nb.njit(**JIT)
def envmap_pdf_kernel(env, d, out):
    """out[i] = envmap_pdf of direction d[i]."""
    for i in range(d.shape[0]):
        out[i] = envmap_pdf(env, d[i, 0], d[i, 1], d[i, 2])


@nb.njit(**JIT)
def envmap_sample_kernel(env, u, d, weight, pdf):
    """envmap_sample of each pair u[i] (n, 2): directions d (n, 3), radiance / pdf (n, 3), pdfs (n,)."""
    for i in range(u.shape[0]):
        di, wi, pdf[i] = envmap_sample(env, u[i, 0], u[i, 1])
        d[i, 0], d[i, 1], d[i, 2] = di
        weight[i, 0], weight[i, 1], weight[i, 2] = wi
