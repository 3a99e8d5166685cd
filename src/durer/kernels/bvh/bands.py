"""Ray batches of the query API (Numba): the user's rays read as given, one cache-sized band at a time.

`RaycastingScene` takes origins and directions as two (..., 3) arrays or one (..., 6) array, float32 or float64,
with any strides, and t_min / t_max as scalars or per-ray arrays. A ray with a NaN or an infinity in it, or a zero
direction, misses (as in Open3D and Embree): it is traced as a ray with an empty t range. The traversal kernels want
C-contiguous float64 (N, 3) rays and (N,) t ranges. Converting a whole batch up front cost ~100 MB of fresh arrays
per million rays, whose first touch is expensive (benchmarks/ README.md, issue 9). Instead each work item copies one
band of rays (TILE rows of an image, or BAND rays) into small float64 scratch that stays in cache, checking the rays
as it copies them, and the query passes (kernels/bvh/queries.py) trace the scratch and write the user's outputs from
it. float32 converts to float64 exactly, so float32 rays give the results of the same values given in float64, to
the bit."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from .instances import to_object
from .layout import TILE

BAND = 4096  # rays per work item when the rays are not an image (32 blocks of the one-level kernels)


def band_size(width: int) -> int:
    """Rays per band: TILE rows of an image `width` wide (whole tiles for the packet kernels), else BAND."""
    return TILE * int(width) if width > 0 else BAND


def n_bands(n: int, band: int) -> int:
    return -(-int(n) // band)


@nb.njit(**JIT, inline="always")
def ray_at(origins, directions, i):
    """Ray i of two (N, 3) arrays of any float type and strides, as six float64 scalars."""
    return (np.float64(origins[i, 0]), np.float64(origins[i, 1]), np.float64(origins[i, 2]),
            np.float64(directions[i, 0]), np.float64(directions[i, 1]), np.float64(directions[i, 2]))


@nb.njit(**JIT, inline="always")
def load_band(origins, directions, t_min, t_max, w2o, moved, k, band, o, d, lo, hi, first):
    """Band k's rays (r0 = k * band onwards, m of them) and their t ranges into the scratch o, d, lo, hi from
    row 0, as float64; with `moved`, into the object space of w2o (3, 4) by the two-level kernels' arithmetic
    (instances.to_object), so a lone transformed instance gets their t to the bit. Records the band's problems
    in first[k] (first ray with a NaN or infinity, 0 if in its origin / 1 if in its direction, first ray with a
    zero direction; -1: none); each such ray is stored as the ray from 0 along +z with the empty t range (0, 0),
    which every kernel reports as a miss. Returns (r0, m, True: the band is to be traced)."""
    r0 = k * band
    r1 = min(origins.shape[0], r0 + band)
    bad, where, zero = -1, -1, -1
    for i in range(r0, r1):
        ox, oy, oz, dx, dy, dz = ray_at(origins, directions, i)
        finite_o = np.isfinite(ox) and np.isfinite(oy) and np.isfinite(oz)
        finite_d = np.isfinite(dx) and np.isfinite(dy) and np.isfinite(dz)
        null = dx == 0.0 and dy == 0.0 and dz == 0.0
        if bad < 0 and not (finite_o and finite_d):
            bad, where = i, (1 if finite_o else 0)
        if zero < 0 and null:
            zero = i
        j = i - r0
        lo[j], hi[j] = t_min[i], t_max[i]
        if not (finite_o and finite_d) or null:
            ox, oy, oz, dx, dy, dz = 0.0, 0.0, 0.0, 0.0, 0.0, 1.0
            lo[j], hi[j] = 0.0, 0.0
        elif moved:
            ox, oy, oz, dx, dy, dz = to_object(w2o, ox, oy, oz, dx, dy, dz)
        o[j, 0], o[j, 1], o[j, 2] = ox, oy, oz
        d[j, 0], d[j, 1], d[j, 2] = dx, dy, dz
    first[k, 0], first[k, 1], first[k, 2] = bad, where, zero
    return r0, r1 - r0, True


@nb.njit(**JIT, inline="always")
def band_scratch(band):
    """Scratch for one band: origins, directions (band, 3) and t_min, t_max (band,), float64, C-contiguous (the
    arrays the renderer passes the same kernels, so no new variant of them is compiled)."""
    return np.empty((band, 3)), np.empty((band, 3)), np.empty(band), np.empty(band)


@nb.njit(**JIT)
def check_bands(origins, directions, t_min, t_max, w2o, band, first, k0, k1):
    """load_band's checks alone, bands k0..k1 (for a scene with nothing to trace)."""
    o, d, lo, hi = band_scratch(band)
    for k in range(k0, k1):
        load_band(origins, directions, t_min, t_max, w2o, False, k, band, o, d, lo, hi, first)


def first_problem(first: np.ndarray) -> tuple[int, int, int]:
    """Reduce load_band's per-band findings to (first bad ray, its part, first zero direction)."""
    bad = first[:, 0]
    zero = first[:, 2]
    b = int(np.argmax(bad >= 0)) if (bad >= 0).any() else -1
    z = zero[zero >= 0]
    return (int(bad[b]) if b >= 0 else -1, int(first[b, 1]) if b >= 0 else -1, int(z.min()) if len(z) else -1)
