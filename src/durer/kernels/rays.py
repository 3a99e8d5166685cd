"""Ray batches (Numba): split and check the query API's input rays in one parallel pass.

`RaycastingScene` takes origins and directions as two (N, 3) arrays or as one (N, 6) array; the traversal
kernels want two C-contiguous float64 (N, 3) arrays, and every ray must be finite with a non-zero direction.
NumPy would copy each column block and check each condition in a pass of its own (about a quarter of a query's
time on a million rays); this does it all in one pass, on every thread (threads.run_pieces: serial nogil chunks
on a thread pool, not a parallel=True region).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from .threads import run_pieces

CHUNK = 8192  # rays per parallel work item


def split_rays(src_o, src_d, o, d, first) -> None:
    """split_checked_rays over all chunks, on every thread."""
    run_pieces(split_checked_rays, n_chunks(len(src_o)), src_o, src_d, o, d, first)


@nb.njit(cache=True, nogil=True)
def split_checked_rays(src_o, src_d, o, d, first, c0, c1):
    """o, d = src_o, src_d as float64 for the rays of chunks c0..c1 (src may be strided views, e.g. the two
    halves of an (N, 6) array). first[c] = (first ray of chunk c with a NaN or infinity, 0 if it is in the
    origin and 1 if in the direction, first ray of chunk c whose direction is zero), -1 where there is none."""
    n = src_o.shape[0]
    for c in range(c0, c1):
        bad, where, zero = -1, -1, -1
        for i in range(c * CHUNK, min(n, (c + 1) * CHUNK)):
            ox, oy, oz = np.float64(src_o[i, 0]), np.float64(src_o[i, 1]), np.float64(src_o[i, 2])
            dx, dy, dz = np.float64(src_d[i, 0]), np.float64(src_d[i, 1]), np.float64(src_d[i, 2])
            o[i, 0], o[i, 1], o[i, 2] = ox, oy, oz
            d[i, 0], d[i, 1], d[i, 2] = dx, dy, dz
            if bad < 0:
                if not (np.isfinite(ox) and np.isfinite(oy) and np.isfinite(oz)):
                    bad, where = i, 0
                elif not (np.isfinite(dx) and np.isfinite(dy) and np.isfinite(dz)):
                    bad, where = i, 1
            if zero < 0 and dx == 0.0 and dy == 0.0 and dz == 0.0:
                zero = i
        first[c, 0], first[c, 1], first[c, 2] = bad, where, zero


def first_problem(first: np.ndarray) -> tuple[int, int, int]:
    """Reduce split_checked_rays' per-chunk findings to (first bad ray, its part, first zero direction)."""
    bad = first[:, 0]
    zero = first[:, 2]
    b = int(np.argmax(bad >= 0)) if (bad >= 0).any() else -1
    z = zero[zero >= 0]
    return (int(bad[b]) if b >= 0 else -1, int(first[b, 1]) if b >= 0 else -1, int(z.min()) if len(z) else -1)


def n_chunks(n: int) -> int:
    return -(-int(n) // CHUNK)
