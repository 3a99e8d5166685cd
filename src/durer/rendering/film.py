"""The film: where on each pixel the camera rays go (sampling) and how samples become pixels (filtering).

Film points are in pixel units, x right and y up from the bottom-left corner (see cameras.py). Images are
(H, W, ...) with row 0 at the top, so pixel (row r, column c) covers x in [c, c+1], y in [H-1-r, H-r].

Assignment 7 of the course:
* samplers give n offsets in [0,1)^2 inside each pixel: `uniform` (the centres of an s x s grid, n = s^2; one
  sample is the pixel centre), `random` (independent uniform offsets) and `jittered` (one random offset in each
  cell of the s x s grid). Random offsets come from a numpy Generator seeded with options.seed, drawn in a fixed
  order on one thread, so a render is the same bit for bit whatever the number of threads. The course command
  (options.course_random) draws them instead from the course's own unseeded drand48 stream, in its order, which
  reproduces the reference images exactly (see _course_offsets). Except in output7_05b/c and output7_06b
  (jittered, glass sphere / gem): there the course's stream falls behind ours where rays first reach the glass,
  so something in the course's tracer draws from drand48 too. Measured on output7_05b by rendering with the whole
  stream shifted by K draws: K = 0 up to column 34 (course order: columns from the left, rows from the bottom),
  8 draws from column 40 on, more further right; the 4-8 columns between cannot be matched by any single insertion
  of up to 8 draws, and none of the sphere's rays has total internal reflection. What consumes them is unknown, so
  those pixels carry independent jitter (output7_05b: mean difference 2.3/255).
* filters weigh a sample by its offset (dx, dy) from a pixel's centre: box (|dx|, |dy| <= r), tent
  (max(0, 1 - d/r)), gaussian (exp(-d^2 / 2 sigma^2)). A pixel is the weighted average of the samples of the
  pixels within the filter's integer support radius (cropped at the image border), ceil(extent - 1/2) with extent
  r for box and tent and 2 sigma for the gaussian. The gaussian is not clamped to zero beyond 2 sigma inside that
  support: the reference filter7_*.png images show exp(-2) = 0.135 at the corners of the support.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..options import RenderOptions
from ..scene.cameras import pixel_centers

BOX, TENT, GAUSSIAN = 0, 1, 2
_FILTER_CODES = {"box": BOX, "tent": TENT, "gaussian": GAUSSIAN}


# --- sampling ----------------------------------------------------------------------------------------------------
def _grid_side(n: int, sampler: str) -> int:
    s = math.isqrt(n)
    if s * s != n:
        raise ValueError(f"{sampler} sampling needs a perfect square number of samples per pixel "
                         f"(1, 4, 9, 16, ...), got {n}")
    return s


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


def _course_offsets(options: RenderOptions, width: int, height: int) -> np.ndarray:
    """The course's random and jittered offsets (H*W, n, 2) in our pixel order.

    Its samplers call drand48() with no seed while the film is filled column by column from the bottom-left
    pixel (i over x outside, j over y inside, then the n samples). RandomSampler evaluates
    Vec2f(drand48(), drand48()) right to left (the first value is y); JitteredSampler takes x then y and puts
    sample m in cell (m mod s, m div s). This reproduces the reference samples7_* images dot for dot."""
    n = options.samples
    v = drand48(2 * n * width * height).reshape(width, height, n, 2)
    if options.sampler == "random":
        off = v[..., ::-1]
    else:
        s = _grid_side(n, options.sampler)
        m = np.arange(n)
        cells = np.stack([m % s, m // s], axis=-1).astype(np.float64)
        off = (cells + v) / s
    # course (i = column, j = row from the bottom) -> our (row from the top, column)
    return off[:, ::-1].transpose(1, 0, 2, 3).reshape(width * height, n, 2)


def pixel_offsets(options: RenderOptions, width: int, height: int) -> np.ndarray:
    """Sample offsets (H*W, n, 2) in [0,1)^2 for every pixel in row-major order (x right, y up in the pixel)."""
    n, sampler, count = options.samples, options.sampler, width * height
    if sampler == "uniform":
        s = _grid_side(n, sampler)
        c = (np.arange(s) + 0.5) / s
        grid = np.stack(np.meshgrid(c, c, indexing="xy"), axis=-1).reshape(n, 2)
        return np.broadcast_to(grid, (count, n, 2))
    if sampler not in ("random", "jittered"):
        raise ValueError(f"unknown sampler {sampler!r}")
    if options.course_random:
        return _course_offsets(options, width, height)
    rng = np.random.default_rng(options.seed)
    if sampler == "random":
        return rng.random((count, n, 2))
    s = _grid_side(n, sampler)
    a = np.arange(s, dtype=np.float64)
    cells = np.stack(np.meshgrid(a, a, indexing="xy"), axis=-1).reshape(n, 2)
    return (cells + rng.random((count, n, 2))) / s


def sample_points(width: int, height: int, options: RenderOptions) -> tuple[np.ndarray, np.ndarray]:
    """Film points (N,2) of every sample and the flat pixel index (row-major, row 0 on top) each belongs to.

    Samples are grouped by pixel, pixels in row-major order, options.samples per pixel."""
    if options.samples == 1 and options.sampler == "uniform":
        points = pixel_centers(width, height).reshape(-1, 2)
        return points, np.arange(width * height)
    count = width * height
    offsets = pixel_offsets(options, width, height)
    row, col = np.divmod(np.arange(count), width)
    corner = np.stack([col, height - 1 - row], axis=-1).astype(np.float64)  # bottom-left corner of each pixel
    points = (corner[:, None, :] + offsets).reshape(-1, 2)
    return points, np.repeat(np.arange(count), options.samples)


# --- filtering ---------------------------------------------------------------------------------------------------
@nb.njit(cache=True, inline="always")
def _weight(kind: int, r: float, dx: float, dy: float) -> float:
    if kind == BOX:  # edges inclusive, up to float rounding (the course's k/zoom - 4.5 lands on r = 1.7 in float)
        edge = r * (1.0 + 1e-6)
        return 1.0 if abs(dx) <= edge and abs(dy) <= edge else 0.0
    d2 = dx * dx + dy * dy
    if kind == TENT:
        return max(0.0, 1.0 - math.sqrt(d2) / r)
    return math.exp(-d2 / (2.0 * r * r))


@nb.njit(cache=True)
def _weights_at(kind: int, r: float, dx: np.ndarray, dy: np.ndarray, out: np.ndarray) -> None:
    # serial: a few ns a sample, and called while the path tracer's wavefronts run on the other threads, where a
    # parallel region's OpenMP threads went on spinning after it and took 20% of the cores from the wavefronts
    for i in range(dx.shape[0]):
        out[i] = _weight(kind, r, dx[i], dy[i])


def filter_weight(options: RenderOptions, dx, dy) -> np.ndarray:
    """The filter's weight at offsets (dx, dy) in pixels from a pixel centre (arrays broadcast together)."""
    dx, dy = np.broadcast_arrays(np.asarray(dx, dtype=np.float64), np.asarray(dy, dtype=np.float64))
    out = np.empty(dx.size)
    _weights_at(_FILTER_CODES[options.filter], float(options.filter_radius),
                np.ascontiguousarray(dx).ravel(), np.ascontiguousarray(dy).ravel(), out)
    return out.reshape(dx.shape)


def support_radius(options: RenderOptions) -> int:
    """Integer radius in pixels of the neighbourhood whose samples can weigh on a pixel: the filter is zero beyond
    `extent` from the centre (r for box and tent, 2 sigma for the gaussian), and a neighbour k pixels away has
    samples from k - 0.5 pixels on, so k <= ceil(extent - 0.5)."""
    extent = options.filter_radius * (2.0 if options.filter == "gaussian" else 1.0)
    return max(0, math.ceil(extent - 0.5 - 1e-9))


@nb.njit(cache=True, parallel=True)
def _reconstruct(points, start, order, values, width, height, kind, r, radius, out):
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
                    w = _weight(kind, r, points[s, 0] - cx, points[s, 1] - cy)
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
                 _FILTER_CODES[options.filter], float(options.filter_radius), support_radius(options), out)
    return out.reshape((count,) + np.shape(values)[1:])


# --- issue 24: splatting extra per-sample values (the path tracer's features) into per-pixel sums ------------------
def filter_code(options: RenderOptions) -> int:
    """The reconstruction filter's code for the kernels (BOX, TENT, GAUSSIAN)."""
    return _FILTER_CODES[options.filter]


@nb.njit(cache=True)
def splat_values(kind, r, radius, points, row, col, values, width, height, total, weight):
    """total[p] += w * values[s] and weight[p] += w for each sample s (film point, pixel row and column) and each
    pixel p within `radius` of its own, w the filter's weight at s from p's centre: one pass over the samples for
    every channel (serial, as _weights_at, beside the running wavefronts)."""
    for i in range(row.shape[0]):
        for dr in range(-radius, radius + 1):
            rr = row[i] + dr
            if rr < 0 or rr >= height:
                continue
            for dc in range(-radius, radius + 1):
                cc = col[i] + dc
                if cc < 0 or cc >= width:
                    continue
                w = _weight(kind, r, points[i, 0] - (cc + 0.5), points[i, 1] - (height - rr - 0.5))
                if w != 0.0:
                    p = rr * width + cc
                    weight[p] += w
                    for c in range(values.shape[1]):
                        total[p, c] += w * values[i, c]
