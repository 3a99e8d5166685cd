"""Numba kernels of the path tracer's random stream (rendering/sampling.py): splitmix64 hashes of (key, dimension)
and Owen-scrambled Sobol pairs (Burley 2020). Every value depends only on its inputs, never on thread or order."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT

_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_GOLD = np.uint64(0x9E3779B97F4A7C15)
_PAIR = np.uint64(0xA0761D6478BD642F)
_LOW = np.uint64(0xFFFFFFFF)
SAMPLE_MIX = np.uint64(0xD1B54A32D192ED03)  # rendering/sampling.key's multiplier of the sample index


def _sobol2_table() -> np.ndarray:
    """Sobol's second dimension is linear over GF(2) in the index bits (direction numbers v_0 = 2^31,
    v_k+1 = v_k ^ (v_k >> 1)): the XOR of v_k over the bits of each byte of the index, for each of its 4 bytes."""
    v = [0x80000000]
    for _ in range(31):
        v.append(v[-1] ^ (v[-1] >> 1))
    table = np.zeros((4, 256), np.uint32)
    for k in range(4):
        for byte in range(256):
            for bit in range(8):
                if byte >> bit & 1:
                    table[k, byte] ^= v[8 * k + bit]
    return table


_SOBOL2 = _sobol2_table()
_S30, _S27, _S31, _S32, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(32), np.uint64(11)


@nb.njit(**JIT, inline="always")
def mix64(x):
    x = (x ^ (x >> _S30)) * _M1
    x = (x ^ (x >> _S27)) * _M2
    return x ^ (x >> _S31)


@nb.njit(**JIT, inline="always")
def _rev32(x):
    x = ((x >> np.uint32(1)) & np.uint32(0x55555555)) | ((x & np.uint32(0x55555555)) << np.uint32(1))
    x = ((x >> np.uint32(2)) & np.uint32(0x33333333)) | ((x & np.uint32(0x33333333)) << np.uint32(2))
    x = ((x >> np.uint32(4)) & np.uint32(0x0F0F0F0F)) | ((x & np.uint32(0x0F0F0F0F)) << np.uint32(4))
    x = ((x >> np.uint32(8)) & np.uint32(0x00FF00FF)) | ((x & np.uint32(0x00FF00FF)) << np.uint32(8))
    return np.uint32((x >> np.uint32(16)) | (x << np.uint32(16)))


@nb.njit(**JIT, inline="always")
def _owen(x, seed):
    """Nested uniform scramble of a 32-bit fraction (Laine-Karras permutation on the reversed bits)."""
    x = _rev32(x)
    x = np.uint32(x + seed)
    x ^= np.uint32(x * np.uint32(0x6C50B47C))
    x ^= np.uint32(x * np.uint32(0xB82F1E52))
    x ^= np.uint32(x * np.uint32(0xC7AFE638))
    x ^= np.uint32(x * np.uint32(0x8D22F6E6))
    return _rev32(x)


@nb.njit(**JIT, inline="always")
def uniform1(k, dim):
    """A 53-bit float in [0, 1) from hash(k, dim): dimension `dim` of the stream keyed k."""
    return np.float64(mix64(k + np.uint64(dim + 1) * _GOLD) >> _S11) * (1.0 / 9007199254740992.0)


@nb.njit(**JIT)
def sobol2(pixel_key, sample, dim):
    """Owen-scrambled Sobol point (dimensions 0 and 1) of `sample`, shuffled and scrambled by a hash of
    (pixel_key, dim): pair `dim` of a pixel's stratified samples."""
    h = mix64(pixel_key ^ (np.uint64(dim + 1) * _PAIR))
    shuffle = np.uint32(h & _LOW)
    s1 = np.uint32(h >> _S32)
    s2 = np.uint32(mix64(h) >> _S32)
    index = _owen(np.uint32(sample), shuffle)
    x = _rev32(index)
    y = (_SOBOL2[0, index & np.uint32(255)] ^ _SOBOL2[1, (index >> np.uint32(8)) & np.uint32(255)]
         ^ _SOBOL2[2, (index >> np.uint32(16)) & np.uint32(255)] ^ _SOBOL2[3, index >> np.uint32(24)])
    return np.float64(_owen(x, s1)) * 2.0 ** -32, np.float64(_owen(y, s2)) * 2.0 ** -32


@nb.njit(**JIT)
def uniform_kernel(keys, dim, out):
    """out[i] = uniform1(keys[i], dim)."""
    for i in range(keys.shape[0]):
        out[i] = uniform1(keys[i], dim)


@nb.njit(**JIT)
def sobol_pair_kernel(pixel_keys, sample, dim, out):
    """out[i] = sobol2(pixel_keys[i], sample[i], dim)."""
    for i in range(pixel_keys.shape[0]):
        out[i, 0], out[i, 1] = sobol2(pixel_keys[i], sample[i], dim)


@nb.njit(**JIT)
def film_samples(seed_key, pixel_sample, width, height, row0, rows, col0, cols, s0, s1, points, pixel, sample):
    """The path tracer's film samples of the rectangle rows x cols at (row0, col0) of a width x height image,
    samples s0..s1 of each pixel, grouped by pixel (row-major), in one pass: pixel[i] its flat index, sample[i]
    its sample index, points[i] its film point (pixels, y up): the pixel's corner plus Sobol pair 0 of the
    pixel's own key (rendering/sampling.key(seed, pixel, pixel_sample), seed_key = sampling.seed_key(seed)), the
    same numbers as film.tile_points' NumPy passes."""
    pk = np.uint64(pixel_sample) * SAMPLE_MIX
    m = s1 - s0
    for r in range(rows):
        y = np.float64(height - 1 - (r + row0))
        for c in range(cols):
            p = (r + row0) * width + c + col0
            key = mix64(mix64(np.uint64(p) + seed_key) ^ pk)
            x = np.float64(c + col0)
            i = (r * cols + c) * m
            for s in range(s0, s1):
                u, v = sobol2(key, s, 0)
                points[i, 0], points[i, 1] = x + u, y + v
                pixel[i], sample[i] = p, s
                i += 1
