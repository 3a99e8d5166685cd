"""Random numbers and warps for the path tracer.

The random stream is counter-based: every number is a hash of (seed, pixel, sample, dimension), so a render is the
same bit for bit whatever the thread count, the batch size or the order in which paths are traced. Pairs of
dimensions (pixel position, light position, BSDF direction) come from Owen-scrambled Sobol points (Burley 2020,
"Practical Hash-based Owen Scrambling", JCGT 9(4)): within one pixel the samples 0..n-1 of a pair form a randomly
scrambled (0, 2)-sequence, stratified at every power of two, and each pair is shuffled and scrambled with its own
hash so pairs are independent of each other. Single dimensions (light choice, lobe choice, Russian roulette) are
plain hashes. (The warps that map them to directions and points are scalar kernels: kernels/path/warps.py.)
"""

from __future__ import annotations

import numpy as np

from ..kernels.path.qmc import sobol_pair_kernel, uniform_kernel

_U64 = np.uint64
PIXEL_KEY = 0xFFFFFFFF  # the sample index of a pixel's own key (Sobol scrambles), never a real sample index


def mix64(x: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser: a bijective avalanche of uint64 values."""
    x = np.asarray(x, dtype=_U64)
    with np.errstate(over="ignore"):
        x = (x ^ (x >> _U64(30))) * _U64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> _U64(27))) * _U64(0x94D049BB133111EB)
    return x ^ (x >> _U64(31))


def seed_key(seed: int) -> np.uint64:
    """The seed's share of every stream key (key, and the path tracer's kernels/path/wavefront.start_paths)."""
    with np.errstate(over="ignore"):
        return _U64(mix64(_U64(int(seed) & 0xFFFFFFFFFFFFFFFF) + _U64(0x9E3779B97F4A7C15)))


def key(seed: int, pixel: np.ndarray, sample: np.ndarray) -> np.ndarray:
    """(N,) uint64 stream keys of (seed, pixel, sample): distinct inputs give unrelated keys."""
    with np.errstate(over="ignore"):
        k = mix64(np.asarray(pixel, dtype=_U64) + seed_key(seed))
        return mix64(k ^ (np.asarray(sample, dtype=_U64) * _U64(0xD1B54A32D192ED03)))


def uniform(keys: np.ndarray, dim: int) -> np.ndarray:
    """(N,) floats in [0, 1) for dimension `dim` of the streams `keys` (53 random bits each)."""
    out = np.empty(len(keys))
    uniform_kernel(np.ascontiguousarray(keys, dtype=_U64), int(dim), out)
    return out


def sobol_pair(pixel_keys: np.ndarray, sample: np.ndarray, dim: int) -> np.ndarray:
    """(N, 2) Owen-scrambled Sobol points in [0,1)^2: pair `dim` of sample `sample` of the pixel whose own stream
    key is `pixel_keys`. Samples 0..n-1 of one pixel are stratified for every power of two (a (0, 2)-sequence); the
    largest 32-bit fraction is below 1, so no value reaches 1."""
    out = np.empty((len(pixel_keys), 2))
    sobol_pair_kernel(np.ascontiguousarray(pixel_keys, dtype=_U64),
                      np.ascontiguousarray(sample, dtype=np.int64), int(dim), out)
    return out


# --- small vector helpers: NumPy's reductions along a length-3 axis are 5-20x slower than these -----------------
def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of (N,3) arrays."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def max3(a: np.ndarray) -> np.ndarray:
    """Row-wise maximum of an (N,3) array."""
    return np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2])


def length(a: np.ndarray) -> np.ndarray:
    """Row-wise Euclidean length (N,) of an (N,3) array."""
    return np.sqrt(dot(a, a))


def normalize(a: np.ndarray) -> np.ndarray:
    return a / length(a)[:, None]
