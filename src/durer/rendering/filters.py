"""The film's reconstruction filters: the weight of a sample at offset (dx, dy) from a pixel centre, for the
course's filters (box, tent, gaussian: radial) and Mitsuba 3's (separable: mitchell, catmullrom, lanczos,
mitsuba_gaussian), and the support they reach. film.py (its docstring defines them) sums samples with them."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..options import RenderOptions

BOX, TENT, GAUSSIAN, MITCHELL, LANCZOS, MITSUBA_GAUSSIAN = range(6)
_FILTER_CODES = {"box": BOX, "tent": TENT, "gaussian": GAUSSIAN, "mitchell": MITCHELL, "catmullrom": MITCHELL,
                 "lanczos": LANCZOS, "mitsuba_gaussian": MITSUBA_GAUSSIAN}
CATMULL_ROM = (0.0, 0.5)  # Mitsuba's catmullrom: the cubic's (B, C)
# Mitsuba's gaussian as a table, as Mitsuba's film evaluates its filters (scalar_rgb: 31 steps, nearest below):
# exp(-8 u^2) - exp(-8) at u = |x| / (4 sigma) = i / GAUSS_STEPS, the same for every sigma, read with linear
# interpolation: within 2 / GAUSS_STEPS^2 = 1.9e-6 of the exact filter (which llvm_ad_rgb evaluates; Mitsuba's
# single precision exp is 4e-4 off). Its 10 exps a radius-2 sample were a third of the film's gather.
GAUSS_STEPS = 1024
_GAUSS = np.maximum(0.0, np.exp(-8.0 * (np.arange(GAUSS_STEPS + 1) / GAUSS_STEPS) ** 2) - math.exp(-8.0))
_GAUSS[-1] = 0.0


@nb.njit(cache=True, inline="always")
def gauss(u: float) -> float:
    """Mitsuba's gaussian at u = |x| / (4 sigma) * GAUSS_STEPS (u >= 0), interpolated in the _GAUSS table."""
    if u >= GAUSS_STEPS:
        return 0.0
    i = int(u)
    lo = _GAUSS[i]
    return lo + (u - i) * (_GAUSS[i + 1] - lo)


@nb.njit(cache=True, inline="always")
def _weight1(kind: int, r: float, bc: tuple[float, float], x: float) -> float:
    """One axis of Mitsuba's separable filters (film.py's docstring); bc the cubic's (B, C)."""
    x = abs(x)
    if kind == MITCHELL:
        b, c = bc
        x = 2.0 * x / r
        if x >= 2.0:
            return 0.0
        x2 = x * x
        if x < 1.0:
            return ((12 - 9 * b - 6 * c) * x2 * x + (-18 + 12 * b + 6 * c) * x2 + (6 - 2 * b)) / 6.0
        return ((-b - 6 * c) * x2 * x + (6 * b + 30 * c) * x2 + (-12 * b - 48 * c) * x + (8 * b + 24 * c)) / 6.0
    if kind == LANCZOS:
        if x >= r:
            return 0.0
        if x < 1e-8:
            return 1.0
        a = math.pi * x
        return r * math.sin(a) * math.sin(a / r) / (a * a)
    return gauss(x * (GAUSS_STEPS / (4.0 * r)))  # MITSUBA_GAUSSIAN


@nb.njit(cache=True, inline="always")
def _weight(kind: int, r: float, bc: tuple[float, float], dx: float, dy: float) -> float:
    if kind >= MITCHELL:
        return _weight1(kind, r, bc, dx) * _weight1(kind, r, bc, dy)
    if kind == BOX:  # edges inclusive, up to float rounding (the course's k/zoom - 4.5 lands on r = 1.7 in float)
        edge = r * (1.0 + 1e-6)
        return 1.0 if abs(dx) <= edge and abs(dy) <= edge else 0.0
    d2 = dx * dx + dy * dy
    if kind == TENT:
        return max(0.0, 1.0 - math.sqrt(d2) / r)
    return math.exp(-d2 / (2.0 * r * r))


@nb.njit(cache=True)
def _weights_at(kind: int, r: float, bc: tuple[float, float], dx: np.ndarray, dy: np.ndarray,
                out: np.ndarray) -> None:
    # serial: a few ns a sample, and called while the path tracer's wavefronts run on the other threads, where a
    # parallel region's OpenMP threads went on spinning after it and took 20% of the cores from the wavefronts
    for i in range(dx.shape[0]):
        out[i] = _weight(kind, r, bc, dx[i], dy[i])


def cubic(options: RenderOptions) -> tuple[float, float]:
    """(B, C) of the Mitchell-Netravali cubic the filter uses (catmullrom's own pair; unused by other filters)."""
    if options.filter == "catmullrom":
        return CATMULL_ROM
    return float(options.filter_b), float(options.filter_c)


def filter_weight(options: RenderOptions, dx, dy) -> np.ndarray:
    """The filter's weight at offsets (dx, dy) in pixels from a pixel centre (arrays broadcast together)."""
    dx, dy = np.broadcast_arrays(np.asarray(dx, dtype=np.float64), np.asarray(dy, dtype=np.float64))
    out = np.empty(dx.size)
    _weights_at(_FILTER_CODES[options.filter], float(options.filter_radius), cubic(options),
                np.ascontiguousarray(dx).ravel(), np.ascontiguousarray(dy).ravel(), out)
    return out.reshape(dx.shape)


def support_radius(options: RenderOptions) -> int:
    """Integer radius in pixels of the neighbourhood whose samples can weigh on a pixel: the filter is zero beyond
    `extent` from the centre (options.filter_reach), and a neighbour k pixels away has
    samples from k - 0.5 pixels on, so k <= ceil(extent - 0.5)."""
    return max(0, math.ceil(options.filter_reach() - 0.5 - 1e-9))
