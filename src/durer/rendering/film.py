"""The film: where on each pixel the camera rays go (sampling) and how samples become pixels (filtering).

Film points are in pixel units, x right and y up from the bottom-left corner (see cameras.py). Images are
(H, W, ...) with row 0 at the top, so pixel (row r, column c) covers x in [c, c+1], y in [H-1-r, H-r].

Assignment 7 of the course, for any sample count n:
* samplers give n offsets in [0,1)^2 inside each pixel: `uniform` (the centres of the a x b stratum grid,
  `strata(n)`: s x s for n = s^2 as the course has it, 4 x 2 for 8, 3 x 1 for 3; one sample is the pixel centre),
  `random` (independent uniform offsets) and `jittered` (one random offset in each cell of that grid). Random
  offsets come from a numpy Generator seeded with options.seed, as if drawn pixel by pixel over the whole image
  on one thread; a tile's offsets are that stream's slice, reached by jumping ahead (`_draws`), so a render is
  the same bit for bit whatever its tiles and threads. The course command (options.course_random) draws them
  instead from the course's own unseeded drand48 stream, in its order, which reproduces the reference images
  exactly (see _draws). Except in output7_05b/c and output7_06b
  (jittered, glass sphere / gem): there the course's stream falls behind ours where rays first reach the glass,
  so something in the course's tracer draws from drand48 too. Measured on output7_05b by rendering with the whole
  stream shifted by K draws: K = 0 up to column 34 (course order: columns from the left, rows from the bottom),
  8 draws from column 40 on, more further right; the 4-8 columns between cannot be matched by any single insertion
  of up to 8 draws, and none of the sphere's rays has total internal reflection. What consumes them is unknown, so
  those pixels carry independent jitter (output7_05b: mean difference 2.3/255). The path tracer places its film
  samples with its own Owen-scrambled Sobol pairs instead (`uses_sobol`).
* filters weigh a sample by its offset (dx, dy) from a pixel's centre: box (|dx|, |dy| <= r), tent
  (max(0, 1 - d/r)), gaussian (exp(-d^2 / 2 sigma^2)). A pixel is the weighted average of the samples of the
  pixels within the filter's integer support radius (cropped at the image border), ceil(extent - 1/2) with extent
  r for box and tent and 2 sigma for the gaussian. The gaussian is not clamped to zero beyond 2 sigma inside that
  support: the reference filter7_*.png images show exp(-2) = 0.135 at the corners of the support.
  Mitsuba 3's filters are separable, w(dx) w(dy), as its film weighs samples: `mitchell` (Mitchell-Netravali with
  options.filter_b and filter_c, Mitsuba's B and C, default 1/3 each, over radius r: Mitsuba's has r = 2),
  `catmullrom` (Mitsuba's: the same cubic with B = 0, C = 1/2, whatever filter_b and filter_c), `lanczos`
  (sinc(x) sinc(x / r), r lobes: Mitsuba's 3) and `mitsuba_gaussian` (exp(-x^2 / 2 sigma^2) less its value at
  4 sigma, zero beyond: Mitsuba's gaussian, read from a fine table as Mitsuba's film reads a coarse one,
  filters.gauss). Their negative lobes (mitchell, catmullrom, lanczos) are kept, as Mitsuba keeps them.
  `reconstruct` filters every sample of an image at once; `gather` does the same for one tile from the samples of
  the tile and its halo (the render's units, units.py), in the same order, so both give the same bits.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..kernels.path.qmc import film_samples
from ..options import RenderOptions
from .filters import (  # noqa: F401  (the filters' names, as film.py has always given them)
    _FILTER_CODES,
    BOX,
    CATMULL_ROM,
    GAUSS_STEPS,
    GAUSSIAN,
    LANCZOS,
    MITCHELL,
    MITSUBA_GAUSSIAN,
    TENT,
    _weight,
    _weight1,
    cubic,
    filter_weight,
    gauss,
    support_radius,
)
from .integrators import integrator_for
from .sampling import PIXEL_KEY, key, seed_key, sobol_pair

LENS_KEY = PIXEL_KEY - 1  # the sample index of a pixel's aperture stream (lens_samples), never a real one


# --- sampling ----------------------------------------------------------------------------------------------------
def strata(n: int) -> tuple[int, int]:
    """(columns, rows) of the stratum grid of n samples: the a x b grid with a * b = n closest to square (rows the
    largest divisor of n not above sqrt(n), so a perfect square s^2 gives today's s x s grid, 8 gives 4 x 2 and a
    prime p gives p x 1). Sample m lies in cell (m mod columns, m div columns)."""
    rows = next(b for b in range(math.isqrt(n), 0, -1) if n % b == 0)
    return n // rows, rows


@nb.njit(cache=True)
def drand48(count: int, state: int = 0) -> np.ndarray:
    """`count` values of glibc's drand48 from the 48-bit `state` (0 is glibc's state when nothing seeded it):
    x <- (0x5DEECE66D x + 0xB) mod 2^48, value x / 2^48."""
    out = np.empty(count)
    x = np.uint64(state)
    a, c, mask = np.uint64(0x5DEECE66D), np.uint64(0xB), np.uint64((1 << 48) - 1)
    for i in range(count):
        x = (a * x + c) & mask
        out[i] = x / 281474976710656.0
    return out


def drand48_state(steps: int, state: int = 0) -> int:
    """The drand48 state `steps` draws after `state`, in O(log steps): the LCG's affine map raised to a power."""
    a, c, mod = 0x5DEECE66D, 0xB, 1 << 48
    mul, add = 1, 0  # the composed map x -> mul x + add
    while steps:
        if steps & 1:
            mul, add = (mul * a) % mod, (add * a + c) % mod
        a, c = (a * a) % mod, (c * a + c) % mod
        steps >>= 1
    return (mul * state + add) % mod


def _draws(options: RenderOptions, width: int, height: int, rows: range, cols: range) -> np.ndarray:
    """The 2n random numbers of each pixel of the rectangle (len(rows) * len(cols), n, 2), pixels row-major: the
    slice of the whole image's stream a one-thread draw over all pixels gives them, found by jumping ahead.

    Seeded: numpy's PCG64 (default_rng(seed)) draws pixel by pixel in row-major order, one 64-bit output per
    value, so row r's run starts (r W + c0) 2n outputs in. The course (course_random): its unseeded drand48 fills
    the film column by column from the bottom-left pixel (column i, row j from the bottom: 2n((i H + j)) draws
    in), so column runs are contiguous and reversed into our top-down rows."""
    n = options.samples
    out = np.empty((len(rows), len(cols), n, 2))
    if options.course_random:
        j_lo = height - rows.stop  # the rectangle's lowest row counted from the bottom
        for k, i in enumerate(cols):
            run = drand48(2 * n * len(rows), drand48_state(2 * n * (i * height + j_lo)))
            out[:, k] = run.reshape(len(rows), n, 2)[::-1]
        return out.reshape(-1, n, 2)
    start = np.random.PCG64(options.seed)
    for k, r in enumerate(rows):
        bits = np.random.PCG64()
        bits.state = start.state
        bits.advance(2 * n * (r * width + cols.start))
        out[k] = np.random.Generator(bits).random((len(cols), n, 2))
    return out.reshape(-1, n, 2)


def uses_sobol(options: RenderOptions) -> bool:
    """The path tracer places film samples with its Owen-scrambled Sobol pairs (sampling.py), whatever the
    sampler: they are stratified for every sample count and keyed by (pixel, sample), like its other dimensions.
    A trait of the integrator's registration (integrators.Integrator.sobol)."""
    return integrator_for(options).sobol


def tile_offsets(options: RenderOptions, width: int, height: int, rows: range, cols: range,
                 samples: range) -> np.ndarray:
    """Sample offsets (P, S, 2) in [0,1)^2 (x right, y up in the pixel) of samples `samples` of the P pixels of
    the rectangle rows x cols, row-major: the same values whatever rectangle a pixel is generated in."""
    n, sampler = options.samples, options.sampler
    count, s = len(rows) * len(cols), len(samples)
    if uses_sobol(options):
        r, c = np.divmod(np.arange(count), len(cols))
        pix = np.repeat((r + rows.start) * width + c + cols.start, s)
        sidx = np.tile(np.arange(samples.start, samples.stop), count)
        return sobol_pair(key(options.seed, pix, np.full(len(pix), PIXEL_KEY)), sidx, 0).reshape(count, s, 2)
    a, b = strata(n)
    m = np.arange(samples.start, samples.stop)
    cells = np.stack([m % a, m // a], axis=-1).astype(np.float64)  # cell (x, y) of each sample
    size = np.array([a, b], dtype=np.float64)
    if sampler == "uniform":
        return np.broadcast_to((cells + 0.5) / size, (count, s, 2))
    if sampler not in ("random", "jittered"):
        raise ValueError(f"unknown sampler {sampler!r}")
    v = _draws(options, width, height, rows, cols)[:, samples.start:samples.stop]
    if sampler == "random":
        # the course's RandomSampler evaluates Vec2f(drand48(), drand48()) right to left: the first value is y
        return v[..., ::-1] if options.course_random else v
    return (cells + v) / size


def pixel_offsets(options: RenderOptions, width: int, height: int) -> np.ndarray:
    """Sample offsets (H*W, n, 2) in [0,1)^2 for every pixel in row-major order (x right, y up in the pixel)."""
    return tile_offsets(options, width, height, range(height), range(width), range(options.samples))


def tile_samples(options: RenderOptions, width: int, height: int, rows: range, cols: range,
                 samples: range) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """tile_points with each point's flat pixel index and sample index (P*S,): a unit's film samples. The path
    tracer's Sobol points are made in one Numba pass (qmc.film_samples: the same bits as tile_points' NumPy)."""
    count, m = len(rows) * len(cols), len(samples)
    if uses_sobol(options):
        points, pixel, sample = np.empty((count * m, 2)), np.empty(count * m, np.int64), np.empty(count * m, np.int64)
        film_samples(seed_key(options.seed), PIXEL_KEY, int(width), int(height), rows.start, len(rows), cols.start,
                     len(cols), samples.start, samples.stop, points, pixel, sample)
        return points, pixel, sample
    r, c = np.divmod(np.arange(count), len(cols))
    pixel = np.repeat((r + rows.start) * width + c + cols.start, m)
    return (_offset_points(options, width, height, rows, cols, samples), pixel,
            np.tile(np.arange(samples.start, samples.stop), count))


def tile_points(options: RenderOptions, width: int, height: int, rows: range, cols: range,
                samples: range) -> np.ndarray:
    """Film points (P*S, 2) of samples `samples` of the rectangle's pixels, grouped by pixel (row-major)."""
    if uses_sobol(options):
        return tile_samples(options, width, height, rows, cols, samples)[0]
    return _offset_points(options, width, height, rows, cols, samples)


def _offset_points(options: RenderOptions, width: int, height: int, rows: range, cols: range,
                   samples: range) -> np.ndarray:
    """tile_points in NumPy: each pixel's corner plus its tile_offsets."""
    off = tile_offsets(options, width, height, rows, cols, samples)
    r, c = np.divmod(np.arange(len(rows) * len(cols)), len(cols))
    corner = np.stack([c + cols.start, height - 1 - (r + rows.start)], axis=-1).astype(np.float64)
    return (corner[:, None, :] + off).reshape(-1, 2)


def lens_samples(options: RenderOptions, pixel: np.ndarray, sample: np.ndarray) -> np.ndarray:
    """(N, 2) points in [0, 1)^2 on a thin lens's aperture for samples `sample` of pixels `pixel` (flat, row-major
    over the whole image): Owen-scrambled Sobol pairs of their own key, unrelated to the film position and the
    path tracer's dimensions, so a pixel's aperture samples are stratified and the same in every tile."""
    keys = key(options.seed, np.asarray(pixel), np.full(len(pixel), LENS_KEY))
    return sobol_pair(keys, np.asarray(sample), 0)


def camera_rays(camera, points: np.ndarray, width: int, height: int, options: RenderOptions, pixel: np.ndarray,
                sample: np.ndarray):
    """The camera's rays (origins, directions, valid) through film points of samples `sample` of pixels `pixel`,
    with aperture samples for a thin lens (PerspectiveCamera.aperture_radius > 0)."""
    if getattr(camera, "aperture_radius", 0.0) > 0:
        return camera.generate_rays(points, width, height, lens_samples(options, pixel, sample))
    return camera.generate_rays(points, width, height)


def sample_points(width: int, height: int, options: RenderOptions) -> tuple[np.ndarray, np.ndarray]:
    """Film points (N,2) of every sample of the image and the flat pixel index (row-major, row 0 on top) each
    belongs to. Samples are grouped by pixel, pixels in row-major order, options.samples per pixel; the render's
    units place the same points (tile_points)."""
    points = tile_points(options, width, height, range(height), range(width), range(options.samples))
    return points, np.repeat(np.arange(width * height), options.samples)


@nb.njit(cache=True)
def nearest_samples(points, t, normal, per_pixel, halo, tile, height, depth, nrm, centre, index):
    """For each pixel p of the tile (row, col, rows, cols; row-major) the sample of its own per_pixel samples (of
    the halo rectangle's, as gather reads them) whose film point is nearest the pixel's centre, the first on a tie:
    its index in index[p], its t and normal (N,3) in depth[p] and nrm[p], its squared distance in centre[p]."""
    hr, hc, _, hw = halo
    tr, tc, th, tw = tile
    for i in range(th):
        cy = (height - (tr + i)) - 0.5
        for j in range(tw):
            cx = (tc + j) + 0.5
            best = ((tr + i - hr) * hw + tc + j - hc) * per_pixel
            dx, dy = points[best, 0] - cx, points[best, 1] - cy
            near = dx * dx + dy * dy
            for s in range(best + 1, best + per_pixel):
                dx, dy = points[s, 0] - cx, points[s, 1] - cy
                d2 = dx * dx + dy * dy
                if d2 < near:
                    best, near = s, d2
            p = i * tw + j
            index[p], depth[p], centre[p] = best, t[best], near
            nrm[p, 0], nrm[p, 1], nrm[p, 2] = normal[best, 0], normal[best, 1], normal[best, 2]


# --- filtering ---------------------------------------------------------------------------------------------------
@nb.njit(cache=True, parallel=True)
def _reconstruct(points, start, order, values, width, height, kind, r, bc, radius, out):
    """out[p] = sum w(s - centre(p)) * value(s) / sum w over samples s of the pixels within `radius` of p."""
    channels = values.shape[1]
    for p in nb.prange(width * height):
        row = p // width
        col = p - row * width
        cx = col + 0.5
        cy = height - row - 0.5
        acc = np.zeros(channels)
        total = 0.0
        for rr in range(max(0, row - radius), min(height, row + radius + 1)):
            for cc in range(max(0, col - radius), min(width, col + radius + 1)):
                q = rr * width + cc
                for k in range(start[q], start[q + 1]):
                    s = order[k]
                    w = _weight(kind, r, bc, points[s, 0] - cx, points[s, 1] - cy)
                    if w != 0.0:
                        total += w
                        for c in range(channels):
                            acc[c] += w * values[s, c]
        if total > 0.0:
            for c in range(channels):
                out[p, c] = acc[c] / total
        else:
            for c in range(channels):
                out[p, c] = 0.0


def reconstruct(points: np.ndarray, pixel: np.ndarray, values: np.ndarray, width: int, height: int,
                options: RenderOptions) -> np.ndarray:
    """Filter sample values (N,C) into pixels (H*W, C): the weighted average described in the module docstring.

    A pixel whose neighbourhood holds no sample with a non-zero weight is black."""
    count = width * height
    if (options.samples == 1 and options.sampler == "uniform" and support_radius(options) == 0
            and np.array_equal(pixel, np.arange(count))):
        # one sample per pixel at its centre, where every filter weighs 1, and no neighbour counts: the values
        return np.array(values, dtype=np.float64)
    vals = np.ascontiguousarray(np.asarray(values, dtype=np.float64).reshape(len(pixel), -1))
    order = np.argsort(pixel, kind="stable")
    start = np.zeros(count + 1, dtype=np.int64)
    np.cumsum(np.bincount(pixel, minlength=count), out=start[1:])
    out = np.empty((count, vals.shape[1]))
    _reconstruct(np.ascontiguousarray(points, dtype=np.float64), start, order.astype(np.int64), vals, width, height,
                 _FILTER_CODES[options.filter], float(options.filter_radius), cubic(options), support_radius(options),
                 out)
    return out.reshape((count,) + np.shape(values)[1:])


@nb.njit(cache=True)
def _gather(points, values, per_pixel, halo, tile, width, height, kind, r, bc, radius, acc, wsum):
    """acc[p] += w * value and wsum[p] += w over the samples of the pixels within `radius` of each tile pixel p, in
    _reconstruct's order (neighbour pixels row-major, then their samples in order). The samples are those of the
    halo rectangle (row, col, rows, cols), per_pixel to a pixel, row-major; the tile lies inside it."""
    if kind >= MITCHELL:  # separable: each sample's axis weights once per offset, not per (offset x, offset y)
        _gather_separable(points, values, per_pixel, halo, tile, width, height, kind, r, bc, radius, acc, wsum)
    else:
        _gather_each(points, values, per_pixel, halo, tile, width, height, kind, r, bc, radius, acc, wsum)


@nb.njit(cache=True, inline="always")
def _finite(values) -> bool:
    """Are all sample values finite? Then _gather_each and _gather_separable add every weight, zeros included
    (w * v adds +-0, the same bits): their `w != 0` test, a coin toss for the samples at a filter's edge (a fifth
    of the radius-2 gaussian's (sample, pixel) pairs), cost more than the sums (the separable sums 2.3x faster);
    a NaN or inf sample still counts only where its weight is not zero."""
    for v in values.flat:
        if not math.isfinite(v):
            return False
    return True


@nb.njit(cache=True)
def _gather_each(points, values, per_pixel, halo, tile, width, height, kind, r, bc, radius, acc, wsum):
    """_gather with the filter evaluated per (tile pixel, sample): any filter."""
    channels = values.shape[1]
    hr, hc, _, hw = halo
    tr, tc, th, tw = tile
    dense = radius > 0 and _finite(values)  # radius 0 (the box): one pixel, every weight 1, no scan
    for i in range(th):
        row = tr + i
        cy = height - row - 0.5
        for j in range(tw):
            col = tc + j
            cx = col + 0.5
            p = i * tw + j
            total = wsum[p]
            a0, a1, a2 = (acc[p, 0], acc[p, 1], acc[p, 2]) if channels == 3 else (0.0, 0.0, 0.0)  # as separable's
            for rr in range(max(0, row - radius), min(height, row + radius + 1)):
                for cc in range(max(0, col - radius), min(width, col + radius + 1)):
                    q = (rr - hr) * hw + (cc - hc)
                    for s in range(q * per_pixel, (q + 1) * per_pixel):
                        w = _weight(kind, r, bc, points[s, 0] - cx, points[s, 1] - cy)
                        if dense or w != 0.0:
                            total += w
                            if channels == 3:
                                a0 += w * values[s, 0]
                                a1 += w * values[s, 1]
                                a2 += w * values[s, 2]
                            else:
                                for c in range(channels):
                                    acc[p, c] += w * values[s, c]
            if channels == 3:
                acc[p, 0], acc[p, 1], acc[p, 2] = a0, a1, a2
            wsum[p] = total


@nb.njit(cache=True)
def _gather_separable(points, values, per_pixel, halo, tile, width, height, kind, r, bc, radius, acc, wsum):
    """_gather for Mitsuba's separable filters (gaussian, mitchell, catmullrom, lanczos) with the same sums to the
    bit: a sample's weight for the pixel `k` columns and `l` rows off is wx[s, k] * wy[s, l], each axis' factor
    computed once per sample and offset from the same operands as _weight's (2 (2 radius + 1) filter evaluations
    a sample instead of 2 (2 radius + 1)^2: the Gaussian's exps were a third of a radius-2 render)."""
    channels = values.shape[1]
    hr, hc, hh, hw = halo
    tr, tc, th, tw = tile
    span = 2 * radius + 1
    n = points.shape[0]
    wx, wy = np.empty((n, span)), np.empty((n, span))
    scale = GAUSS_STEPS / (4.0 * r)  # the Gaussian's: _weight1's operands (the same bits)
    for q in range(hh * hw):
        rr, cc = hr + q // hw, hc + q % hw
        for s in range(q * per_pixel, (q + 1) * per_pixel):
            for k in range(span):
                col = cc + k - radius
                row = rr + k - radius
                cx = col + 0.5
                cy = height - row - 0.5
                if kind == MITSUBA_GAUSSIAN:
                    x, y = abs(points[s, 0] - cx), abs(points[s, 1] - cy)
                    wx[s, k] = gauss(x * scale)
                    wy[s, k] = gauss(y * scale)
                else:
                    wx[s, k] = _weight1(kind, r, bc, points[s, 0] - cx)
                    wy[s, k] = _weight1(kind, r, bc, points[s, 1] - cy)
    dense = radius > 0 and _finite(values)  # radius 0 (the box): one pixel, every weight 1, no scan
    for i in range(th):
        row = tr + i
        for j in range(tw):
            col = tc + j
            p = i * tw + j
            total = wsum[p]
            # three channels (a plain colour) summed in registers: acc[p, c] in memory made every add wait on the
            # last one's store (0.83x the gather's time, the same additions in the same order)
            a0, a1, a2 = (acc[p, 0], acc[p, 1], acc[p, 2]) if channels == 3 else (0.0, 0.0, 0.0)
            for rr in range(max(0, row - radius), min(height, row + radius + 1)):
                for cc in range(max(0, col - radius), min(width, col + radius + 1)):
                    q = (rr - hr) * hw + (cc - hc)
                    kx, ky = col - cc + radius, row - rr + radius
                    for s in range(q * per_pixel, (q + 1) * per_pixel):
                        w = wx[s, kx] * wy[s, ky]
                        if dense or w != 0.0:
                            total += w
                            if channels == 3:
                                a0 += w * values[s, 0]
                                a1 += w * values[s, 1]
                                a2 += w * values[s, 2]
                            else:
                                for c in range(channels):
                                    acc[p, c] += w * values[s, c]
            if channels == 3:
                acc[p, 0], acc[p, 1], acc[p, 2] = a0, a1, a2
            wsum[p] = total


def gather(points: np.ndarray, values: np.ndarray, per_pixel: int, halo: tuple[int, int, int, int],
           tile: tuple[int, int, int, int], width: int, height: int, options: RenderOptions,
           acc: np.ndarray, wsum: np.ndarray) -> None:
    """Add the filter-weighted sample values (N,C) and weights of a halo rectangle's samples into the sums acc
    (T,C) and wsum (T,) of the tile's T pixels (rectangles as (row, col, rows, cols)). With acc and wsum zero and
    every sample of the image at hand this is reconstruct's numerator and denominator to the bit."""
    _gather(np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(values, dtype=np.float64),
            int(per_pixel), halo, tile, int(width), int(height), _FILTER_CODES[options.filter],
            float(options.filter_radius), cubic(options), support_radius(options), acc, wsum)


@nb.njit(cache=True)
def pack(inputs, part, start, color, split, sources, moment):
    """One batch of a denoised render's per-sample values copied into the film's arrays in one pass, rows start
    onward (units._Values): inputs[:, :3] the colour less the split part (split (n, k <= 3), also copied to
    part; k = 0: none), then each (n, 3) source in order, and inputs[:, moment] the squared norm of that colour
    (moment < 0: none). Each row is written once while its sources are in the cache: the NumPy copies, one
    strided pass per output, were most of the film's own cost (benchmarks/README.md)."""
    n, k = color.shape[0], split.shape[1]
    for i in range(n):
        r = start + i
        c0, c1, c2 = color[i, 0], color[i, 1], color[i, 2]
        if k:
            s0, s1, s2 = split[i, 0], split[i, 1], split[i, 2]
            part[r, 0], part[r, 1], part[r, 2] = s0, s1, s2
            c0, c1, c2 = c0 - s0, c1 - s1, c2 - s2
        inputs[r, 0], inputs[r, 1], inputs[r, 2] = c0, c1, c2
        col = 3
        for src in sources:
            inputs[r, col], inputs[r, col + 1], inputs[r, col + 2] = src[i, 0], src[i, 1], src[i, 2]
            col += 3
        if moment >= 0:
            inputs[r, moment] = (c0 * c0 + c2 * c2) + c1 * c1  # NumPy's einsum order: the same bits
