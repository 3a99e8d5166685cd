"""Ken Perlin's improved noise (SIGGRAPH 2002, the reference Java implementation at mrl.nyu.edu/~perlin/noise/).

The 256-entry permutation table of the reference, doubled to avoid index wrapping; the quintic fade curve
6t^5 - 15t^4 + 10t^3; twelve gradient directions (edges of a cube) picked by the hash's low four bits.
The course's perlin_noise.C is a C++ translation of the same code, so the values are those of the reference:
0 at every lattice point, continuous with continuous first and second derivatives, in about [-1, 1].

`turbulence` is the course's octave sum N(p) = sum_{k<octaves} noise(2^k p) / 2^k (assignment 6).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

_PERMUTATION = (
    151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99, 37,
    240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32, 57, 177,
    33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146,
    158, 231, 83, 111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25,
    63, 161, 1, 216, 80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100,
    109, 198, 173, 186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206,
    59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153,
    101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246,
    97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192,
    214, 31, 181, 199, 106, 157, 184, 84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114,
    67, 29, 24, 72, 243, 141, 128, 195, 78, 66, 215, 61, 156, 180,
)
PERM = np.array(_PERMUTATION * 2, dtype=np.int64)  # p[256 + i] = p[i], as the reference builds it


@nb.njit(cache=True, inline="always")
def fade(t: float) -> float:
    """6t^5 - 15t^4 + 10t^3: zero first and second derivatives at t = 0 and t = 1."""
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@nb.njit(cache=True, inline="always")
def _lerp(t: float, a: float, b: float) -> float:
    return a + t * (b - a)


@nb.njit(cache=True, inline="always")
def grad(h: int, x: float, y: float, z: float) -> float:
    """Dot product of (x, y, z) with one of the 12 cube-edge gradients (4 repeated to make 16) chosen by h."""
    h = h & 15
    u = x if h < 8 else y
    if h < 4:
        v = y
    elif h == 12 or h == 14:
        v = x
    else:
        v = z
    return (u if (h & 1) == 0 else -u) + (v if (h & 2) == 0 else -v)


@nb.njit(cache=True)
def noise3(x: float, y: float, z: float) -> float:
    """Improved noise at one point (Perlin 2002, line for line)."""
    p = PERM
    fx, fy, fz = math.floor(x), math.floor(y), math.floor(z)
    X, Y, Z = int(fx) & 255, int(fy) & 255, int(fz) & 255
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = fade(x), fade(y), fade(z)
    A = p[X] + Y
    AA = p[A] + Z
    AB = p[A + 1] + Z
    B = p[X + 1] + Y
    BA = p[B] + Z
    BB = p[B + 1] + Z
    return _lerp(w, _lerp(v, _lerp(u, grad(p[AA], x, y, z), grad(p[BA], x - 1.0, y, z)),
                          _lerp(u, grad(p[AB], x, y - 1.0, z), grad(p[BB], x - 1.0, y - 1.0, z))),
                 _lerp(v, _lerp(u, grad(p[AA + 1], x, y, z - 1.0), grad(p[BA + 1], x - 1.0, y, z - 1.0)),
                       _lerp(u, grad(p[AB + 1], x, y - 1.0, z - 1.0), grad(p[BB + 1], x - 1.0, y - 1.0, z - 1.0))))


@nb.njit(cache=True, inline="always")
def turbulence3(x: float, y: float, z: float, octaves: int) -> float:
    """sum_{k < octaves} noise(2^k p) / 2^k (0 when octaves is 0)."""
    total = 0.0
    scale = 1.0
    for _ in range(octaves):
        total += noise3(x * scale, y * scale, z * scale) / scale
        scale *= 2.0
    return total


@nb.njit(cache=True, parallel=True)
def noise_points(points: np.ndarray) -> np.ndarray:
    """Improved noise at each row of points (N,3)."""
    n = points.shape[0]
    out = np.empty(n)
    for i in nb.prange(n):
        out[i] = noise3(points[i, 0], points[i, 1], points[i, 2])
    return out


@nb.njit(cache=True, parallel=True)
def turbulence(points: np.ndarray, octaves: int) -> np.ndarray:
    """The course's octave sum N(p) at each row of points (N,3)."""
    n = points.shape[0]
    out = np.empty(n)
    for i in nb.prange(n):
        out[i] = turbulence3(points[i, 0], points[i, 1], points[i, 2], octaves)
    return out
