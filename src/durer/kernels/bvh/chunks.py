"""Rays in chunks of PACKET, and the packet's rows (Numba): which rays a chunk holds, whether they are coherent
enough to walk the tree as one packet, and the rows packet.packet_traverse reads (each ray's watertight-test
constants, the packet's extremes), computed with the one-ray path's exact operations. A chunk that is not coherent
goes one ray at a time.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from ..intersect import shear_axes
from .instances import to_object
from .layout import BLOCK, HI_X, HI_Y, HI_Z, LO_X, LO_Y, LO_Z, PACKET, PACKET_CONE, TILE

# The packet's scratch `rr`: a flat float64 array of _NROW rows of PACKET, row r at offset r * PACKET, so ray k of
# row _X is rr[_X + k] (the names below are offsets) and a row picked at run time (axis a after _DX) is
# rr[_DX + a * PACKET + k]. Flat, every address is a constant offset from one pointer, so LLVM sees that the rows
# do not overlap and vectorises the loops over rays without run-time checks (a 2-D (_NROW, PACKET) array has a
# run-time row stride: measured 1.3x slower traversal). Per ray, but for _EXT, the packet's extremes
# (packet_setup): columns 0-5 the origins' lo, hi on x, y, z; 6-11 the reciprocal directions' lo, hi; 12 the
# lowest t_min.
_NROW = 19
(_OX, _OY, _OZ, _EXT, _TMIN, _BEST, _OKX, _OKY, _OKZ, _SX, _SY, _SZ, _E1, _E2, _DET, _DX, _DY, _DZ,
 _PRIM) = range(0, _NROW * PACKET, PACKET)
_EXT_INV = 6   # column of the reciprocal directions' extremes in _EXT
_EXT_TMIN = 12  # column of the lowest t_min in _EXT


@nb.njit(**JIT, inline="always")
def packet_rows():
    """A packet's scratch rows (uninitialised: packet_setup fills them)."""
    return np.empty(_NROW * PACKET)


@nb.njit(**JIT, inline="always")
def chunk_rays(c, n, width, idx):
    """The rays of chunk c into idx; returns how many. width = 0: rays c * PACKET onwards, in order. width > 0
    (the rays are an image `width` wide, both sides multiples of TILE): the TILE x TILE tile c, row by row,
    whose rays are closer together than a 16 x 1 strip's, so a packet visits fewer nodes. (8 x 8 tiles of 64
    rays measured slower: more rays test each leaf.)"""
    if width == 0:
        i0 = c * PACKET
        m = min(n, i0 + PACKET) - i0
        for k in range(m):
            idx[k] = i0 + k
        return m
    tiles = width // TILE
    ty = c // tiles
    tx = c - ty * tiles
    for k in range(PACKET):
        idx[k] = (TILE * ty + k // TILE) * width + TILE * tx + k % TILE
    return PACKET


@nb.njit(**JIT, inline="always")
def chunk_span(blk0, blk1, n):
    """The chunks c0..c1 of blocks blk0..blk1 (BLOCK chunks each: threads.run_blocks' work items) of n rays."""
    return blk0 * BLOCK, min((n + PACKET - 1) // PACKET, blk1 * BLOCK)


@nb.njit(**JIT, inline="always")
def load_chunk(c, origins, directions, t_min, t_max, width, idx, rr, max_spread):
    """Chunk c's rays into idx (chunk_rays) and the packet rows rr (packet_setup): (m rays, whether they go as a
    packet (coherent and a whole chunk), nrx, nry, nrz, kx, ky, kz)."""
    m = chunk_rays(c, origins.shape[0], width, idx)
    coherent, nrx, nry, nrz, kx, ky, kz = packet_setup(origins, directions, t_min, t_max, idx, m, rr, max_spread)
    return m, coherent & (m == PACKET), nrx, nry, nrz, kx, ky, kz


@nb.njit(**JIT, inline="always")
def _pick(axis, x, y, z):
    """x, y or z by axis 0, 1 or 2."""
    return x if axis == 0 else (y if axis == 1 else z)


@nb.njit(**JIT, inline="always")
def _nonzero(x):
    """A direction component as the slab test takes it: 0 as 1e-300 (ray_setup's reciprocal of 1e300)."""
    return x if x != 0.0 else 1e-300


@nb.njit(**JIT, inline="always")
def direction_class(dx, dy, dz):
    """A direction's sign bits (x 1, y 2, z 4) and the watertight test's largest axis (shear_axes' kz; kx and ky
    follow from it and the signs): the rays of a packet must share both."""
    ax, ay, az = abs(dx), abs(dy), abs(dz)
    kz = 0 if (ax >= ay) & (ax >= az) else (1 if ay >= az else 2)
    return (dx < 0.0) + 2 * (dy < 0.0) + 4 * (dz < 0.0), kz


@nb.njit(**JIT, inline="always")
def origin_extremes(rr, axis):
    """The lowest and highest origin of the packet's rays on `axis`."""
    lo = hi = rr[_OX + axis * PACKET]
    for k in range(1, PACKET):
        lo, hi = min(lo, rr[_OX + axis * PACKET + k]), max(hi, rr[_OX + axis * PACKET + k])
    return lo, hi


@nb.njit(**JIT, inline="always")
def reciprocal_extremes(rr, axis):
    """The lowest and highest reciprocal direction of the packet's rays on `axis` (a zero component as 1e-300, as
    ray_setup takes it): the rays share each component's sign and 1 / x falls with x on either side of 0, rounding
    included, so the extremes of the rounded reciprocals are the reciprocals of the extremes: 6 divisions a
    packet, not 48, and the same bits."""
    lo = hi = _nonzero(rr[_DX + axis * PACKET])
    for k in range(1, PACKET):
        dk = _nonzero(rr[_DX + axis * PACKET + k])
        lo, hi = min(lo, dk), max(hi, dk)
    return 1.0 / hi, 1.0 / lo


@nb.njit(**JIT)
def packet_setup(origins, directions, t_min, t_max, idx, n, rr, max_spread):
    """Load rays idx[:n] into the scratch rows (padding rays never hit) and return (coherent, nrx, nry, nrz,
    kx, ky, kz): coherent when all n rays share direction signs and axis permutation, their directions lie
    within PACKET_CONE of the first ray's and their origins within max_spread of each other (packet_spread_limit)
    on every axis. Only then are the per-ray constants computed, with ray_setup's exact operations. Each loop
    reads and writes few rows, so that LLVM vectorises it (one loop writing every row was left scalar: too many
    arrays to check for overlap)."""
    i0 = idx[0]
    for k in range(PACKET):
        i = idx[k] if k < n else i0
        rr[_DX + k], rr[_DY + k], rr[_DZ + k] = directions[i, 0], directions[i, 1], directions[i, 2]
    dx0, dy0, dz0 = rr[_DX], rr[_DY], rr[_DZ]
    kx0, ky0, kz0 = shear_axes(dx0, dy0, dz0)
    s0, _ = direction_class(dx0, dy0, dz0)
    cone0 = PACKET_CONE * np.sqrt(dx0 * dx0 + dy0 * dy0 + dz0 * dz0)
    bad = 0
    for k in range(PACKET):
        dx, dy, dz = rr[_DX + k], rr[_DY + k], rr[_DZ + k]
        sgn, kz = direction_class(dx, dy, dz)
        bad += ((sgn != s0) | (kz != kz0)
                | (dx * dx0 + dy * dy0 + dz * dz0 < cone0 * np.sqrt(dx * dx + dy * dy + dz * dz)))
    if bad:
        return False, LO_X, LO_Y, LO_Z, kx0, ky0, kz0
    for k in range(PACKET):
        i = idx[k] if k < n else i0
        rr[_OX + k], rr[_OY + k], rr[_OZ + k] = origins[i, 0], origins[i, 1], origins[i, 2]
        if k < n:
            rr[_TMIN + k], rr[_BEST + k] = t_min[i], t_max[i]
        else:
            rr[_TMIN + k], rr[_BEST + k] = np.inf, -np.inf
    for axis in range(3):
        lo, hi = origin_extremes(rr, axis)
        if hi - lo > max_spread:
            return False, LO_X, LO_Y, LO_Z, kx0, ky0, kz0
        rr[_EXT + 2 * axis], rr[_EXT + 2 * axis + 1] = lo, hi
    for axis in range(3):
        rr[_EXT + _EXT_INV + 2 * axis], rr[_EXT + _EXT_INV + 2 * axis + 1] = reciprocal_extremes(rr, axis)
    tlo = rr[_TMIN]
    for k in range(1, PACKET):
        tlo = min(tlo, rr[_TMIN + k])
    rr[_EXT + _EXT_TMIN] = tlo
    nrx, nry, nrz = packet_constants(rr, kx0, ky0, kz0)
    return True, nrx, nry, nrz, kx0, ky0, kz0


@nb.njit(**JIT, inline="always")
def object_packet(rr, ro, w2o):
    """The packet rr moved into object space (rows of ro, t range and best so far copied): returns (coherent,
    nrx, nry, nrz, kx, ky, kz), coherent when the moved rays share direction signs and shear axes; only then
    are their extremes and per-ray constants computed, as packet_setup computes them (no cone or spread
    test: the world-space packet passed them)."""
    for k in range(PACKET):
        (ro[_OX + k], ro[_OY + k], ro[_OZ + k], ro[_DX + k], ro[_DY + k],
         ro[_DZ + k]) = to_object(w2o, rr[_OX + k], rr[_OY + k], rr[_OZ + k], rr[_DX + k], rr[_DY + k], rr[_DZ + k])
        ro[_TMIN + k], ro[_BEST + k] = rr[_TMIN + k], rr[_BEST + k]
    kx0, ky0, kz0 = shear_axes(ro[_DX], ro[_DY], ro[_DZ])
    s0, _ = direction_class(ro[_DX], ro[_DY], ro[_DZ])
    bad = 0
    for k in range(PACKET):
        sgn, kz = direction_class(ro[_DX + k], ro[_DY + k], ro[_DZ + k])
        bad += (sgn != s0) | (kz != kz0)
    if bad:
        return False, LO_X, LO_Y, LO_Z, kx0, ky0, kz0
    for axis in range(3):  # the extremes packet_traverse reads: origins, reciprocal directions, t_min
        ro[_EXT + 2 * axis], ro[_EXT + 2 * axis + 1] = origin_extremes(ro, axis)
        ro[_EXT + _EXT_INV + 2 * axis], ro[_EXT + _EXT_INV + 2 * axis + 1] = reciprocal_extremes(ro, axis)
    ro[_EXT + _EXT_TMIN] = rr[_EXT + _EXT_TMIN]
    nrx, nry, nrz = packet_constants(ro, kx0, ky0, kz0)
    return True, nrx, nry, nrz, kx0, ky0, kz0


@nb.njit(**JIT, inline="always")
def packet_constants(rr, kx0, ky0, kz0):
    """The per-ray constants of the watertight test for every ray of the packet rr (ray_setup's exact operations,
    shear axes kx0, ky0, kz0 shared by the packet), its hit rows cleared, and the near-plane row offsets (nrx, nry,
    nrz) from the reciprocal directions' extremes, as in ray_setup (a zero component counts as positive there too).
    Used by packet_setup and by instance_packets for rays moved into an instance's object space."""
    for k in range(PACKET):  # rows by selects, not run-time offsets, so LLVM sees no overlap and vectorises
        dx, dy, dz = rr[_DX + k], rr[_DY + k], rr[_DZ + k]
        ox, oy, oz = rr[_OX + k], rr[_OY + k], rr[_OZ + k]
        dkz = _pick(kz0, dx, dy, dz)
        rr[_SX + k] = _pick(kx0, dx, dy, dz) / dkz
        rr[_SY + k] = _pick(ky0, dx, dy, dz) / dkz
        rr[_SZ + k] = 1.0 / dkz
        rr[_OKX + k] = _pick(kx0, ox, oy, oz)
        rr[_OKY + k] = _pick(ky0, ox, oy, oz)
        rr[_OKZ + k] = _pick(kz0, ox, oy, oz)
        rr[_E1 + k] = 0.0
        rr[_E2 + k] = 0.0
        rr[_DET + k] = 1.0
        rr[_PRIM + k] = -np.inf
    nrx = HI_X if rr[_EXT + _EXT_INV] < 0.0 else LO_X
    nry = HI_Y if rr[_EXT + _EXT_INV + 2] < 0.0 else LO_Y
    nrz = HI_Z if rr[_EXT + _EXT_INV + 4] < 0.0 else LO_Z
    return nrx, nry, nrz
