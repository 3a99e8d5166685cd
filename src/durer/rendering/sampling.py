"""Random numbers and warps for the path tracer.

The random stream is counter-based: every number is a hash of (seed, pixel, sample, dimension), so a render is the
same bit for bit whatever the thread count, the batch size or the order in which paths are traced. Pairs of
dimensions (pixel position, light position, BSDF direction) come from Owen-scrambled Sobol points (Burley 2020,
"Practical Hash-based Owen Scrambling", JCGT 9(4)): within one pixel the samples 0..n-1 of a pair form a randomly
scrambled (0, 2)-sequence, stratified at every power of two, and each pair is shuffled and scrambled with its own
hash so pairs are independent of each other. Single dimensions (light choice, lobe choice, Russian roulette) are
plain hashes. Warps map [0,1)^2 to directions or points with the pdfs the integrator needs.
"""

from __future__ import annotations

import numpy as np

from ..kernels.qmc import sobol_pair_kernel, uniform_kernel

_U64 = np.uint64


def mix64(x: np.ndarray) -> np.ndarray:
    """splitmix64's finaliser: a bijective avalanche of uint64 values."""
    x = np.asarray(x, dtype=_U64)
    with np.errstate(over="ignore"):
        x = (x ^ (x >> _U64(30))) * _U64(0xBF58476D1CE4E5B9)
        x = (x ^ (x >> _U64(27))) * _U64(0x94D049BB133111EB)
    return x ^ (x >> _U64(31))


def key(seed: int, pixel: np.ndarray, sample: np.ndarray) -> np.ndarray:
    """(N,) uint64 stream keys of (seed, pixel, sample): distinct inputs give unrelated keys."""
    with np.errstate(over="ignore"):
        s = mix64(_U64(int(seed) & 0xFFFFFFFFFFFFFFFF) + _U64(0x9E3779B97F4A7C15))
        k = mix64(np.asarray(pixel, dtype=_U64) + s)
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


# --- warps --------------------------------------------------------------------------------------------------------
def cosine_hemisphere(u: np.ndarray) -> np.ndarray:
    """(N,2) -> (N,3) directions about +z with pdf cos(theta) / pi (Malley: the concentric disk lifted)."""
    d = concentric_disk(u)
    z = np.sqrt(np.maximum(0.0, 1.0 - d[:, 0] ** 2 - d[:, 1] ** 2))
    return np.column_stack([d, z])


def cosine_hemisphere_pdf(w: np.ndarray) -> np.ndarray:
    return np.maximum(w[:, 2], 0.0) / np.pi


def concentric_disk(u: np.ndarray) -> np.ndarray:
    """Shirley-Chiu concentric map of [0,1)^2 onto the unit disk (area preserving up to a constant)."""
    a = 2.0 * u[:, 0] - 1.0
    b = 2.0 * u[:, 1] - 1.0
    first = np.abs(a) > np.abs(b)
    safe_a = np.where(a == 0, 1.0, a)
    safe_b = np.where(b == 0, 1.0, b)
    r = np.where(first, a, b)
    phi = np.where(first, (np.pi / 4) * (b / safe_a), np.pi / 2 - (np.pi / 4) * (a / safe_b))
    zero = (a == 0) & (b == 0)
    r = np.where(zero, 0.0, r)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi)])


def uniform_sphere(u: np.ndarray) -> np.ndarray:
    """(N,2) -> unit vectors uniform on the sphere, pdf 1 / (4 pi)."""
    z = 1.0 - 2.0 * u[:, 0]
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[:, 1]
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def uniform_cone(u: np.ndarray, cos_max: np.ndarray) -> np.ndarray:
    """(N,2) -> unit vectors about +z uniform in the cone cos(theta) >= cos_max, pdf 1 / (2 pi (1 - cos_max))."""
    z = 1.0 - u[:, 0] * (1.0 - cos_max)
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[:, 1]
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def uniform_cone_pdf(cos_max: np.ndarray) -> np.ndarray:
    return 1.0 / (2.0 * np.pi * np.maximum(1.0 - cos_max, 1e-300))


def uniform_triangle(u: np.ndarray) -> np.ndarray:
    """(N,2) -> barycentrics (b1, b2) uniform over a triangle (the square-root warp)."""
    s = np.sqrt(u[:, 0])
    return np.column_stack([1.0 - s, u[:, 1] * s])


def frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents (N,3) completing unit normals n (N,3) into right-handed frames (Duff et al. 2017)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    s = np.column_stack([1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]])
    t = np.column_stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]])
    return s, t


def to_local(v: np.ndarray, s: np.ndarray, t: np.ndarray, n: np.ndarray) -> np.ndarray:
    return np.column_stack([dot(v, s), dot(v, t), dot(v, n)])


def to_world(v: np.ndarray, s: np.ndarray, t: np.ndarray, n: np.ndarray) -> np.ndarray:
    return v[:, :1] * s + v[:, 1:2] * t + v[:, 2:3] * n


def power_heuristic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MIS weight a^2 / (a^2 + b^2) of the strategy with pdf a against the one with pdf b (0 where both are 0);
    an infinite a (a delta strategy) gets weight 1."""
    delta = np.isinf(a)
    a, b = np.where(delta, 1.0, a), np.where(delta, 0.0, b)
    m = np.maximum(a, b)
    safe = np.where(m > 0, m, 1.0)
    a2, b2 = np.square(a / safe), np.square(b / safe)  # scaled: no underflow of tiny pdfs
    total = a2 + b2
    return np.divide(a2, total, out=np.zeros_like(total), where=total > 0)
