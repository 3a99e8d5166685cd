"""Rays laid out as an image: the width that lets the kernels trace them in 4 x 4 tile packets (kernels/bvh/chunks.py),
given or recognised from flat (N, 3) rays. Only speed depends on it: the kernels find the same hits in any order."""

from __future__ import annotations

import numpy as np

from ..kernels.bvh.layout import TILE

_PROBE = 16384  # leading rays looked at to find the row length of flat rays (widths up to this)


def flat_image_width(o: np.ndarray, d: np.ndarray) -> int:
    """The width of the image whose rows flat (N, 3) rays follow (a camera's rays reshaped to (N, 3), row by
    row; float32 or float64, any strides), so the kernels can trace them in 4 x 4 tiles as they do an
    (H, W, ...) array; 0 when they do not look like one: the first jump between consecutive rays (4x the
    first step) must end a row whose length is a multiple of 4 dividing N in whole 4-row bands, and 64 rays
    spread over the batch must lie as close to the ray one row below as to their neighbour. Only speed depends
    on the answer: the packet kernels find the same hits in any order (t to the bit)."""
    n = len(o)
    if n < TILE * TILE * 4:
        return 0
    k = min(n, _PROBE + 1)
    extent = float(np.ptp(o[:257].astype(np.float64), axis=0).max())
    scale = 1.0 / extent if extent > 0.0 else 0.0  # origins count in units of the first rays' spread

    def gap(a, b):  # in float64 whatever the rays' type (float32 query rays: the same answer as converted ones)
        o_a, d_a = o[a].astype(np.float64), d[a].astype(np.float64)
        return np.abs(o_a - o[b]).sum(axis=-1) * scale + np.abs(d_a - d[b]).sum(axis=-1)

    base = float(gap(0, 1))
    if not base > 0.0:
        return 0
    jumps = np.zeros(0, np.int64)
    for m in (257, 2049, k):  # widening windows: a short row is found without looking at 16k rays
        m = min(m, k)
        jumps = np.flatnonzero(gap(slice(0, m - 1), slice(1, m)) > 4.0 * base)
        if len(jumps) or m == k:
            break
    if len(jumps) == 0:
        return 0
    w = int(jumps[0]) + 1
    if w % TILE or n % (TILE * w):
        return 0
    i = np.linspace(0, n - w - 1, 64).astype(np.int64)
    return w if bool(np.all(gap(i, i + w) <= 4.0 * base)) else 0


def checked_width(width: int, o: np.ndarray, d: np.ndarray) -> int:
    """width if the rays form whole rows of 4 x 4 tiles that wide; not given (0): the width flat_image_width
    finds (a renderer's camera rays, row by row); else 0 (rays in their given order)."""
    width, n = int(width), len(o)
    if width == 0:
        return flat_image_width(o, d)
    return width if width > 0 and width % TILE == 0 and n % (TILE * width) == 0 else 0
