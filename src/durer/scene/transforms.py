"""4x4 affine matrices for the course's transformations (Scale, Translate, the rotations, Matrix).

Angles are in degrees, as in the scene files. Matrices act on column vectors: p' = M @ [x, y, z, 1].
"""

from __future__ import annotations

import numpy as np

from ..errors import DurerError
from .values import unit


def identity() -> np.ndarray:
    return np.eye(4)


def translate(offset) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = np.asarray(offset, dtype=np.float64)
    return m


def scale(factors) -> np.ndarray:
    f = np.asarray(factors, dtype=np.float64)
    if f.shape == ():
        f = np.full(3, float(f))
    return np.diag([f[0], f[1], f[2], 1.0])


def rotate(axis, degrees: float) -> np.ndarray:
    """Rotation by `degrees` about `axis` (right-handed, counter-clockwise looking down the axis)."""
    a = np.asarray(axis, dtype=np.float64)
    if not (np.isfinite(a).all() and a.any()):
        raise DurerError("rotation axis has zero length")
    x, y, z = unit(a)
    th = np.radians(degrees)
    c, s = np.cos(th), np.sin(th)
    C = 1.0 - c
    m = np.eye(4)
    m[:3, :3] = [
        [x * x * C + c, x * y * C - z * s, x * z * C + y * s],
        [y * x * C + z * s, y * y * C + c, y * z * C - x * s],
        [z * x * C - y * s, z * y * C + x * s, z * z * C + c],
    ]
    return m


def x_rotate(degrees: float) -> np.ndarray:
    return rotate((1.0, 0.0, 0.0), degrees)


def y_rotate(degrees: float) -> np.ndarray:
    return rotate((0.0, 1.0, 0.0), degrees)


def z_rotate(degrees: float) -> np.ndarray:
    return rotate((0.0, 0.0, 1.0), degrees)


def compose(*matrices: np.ndarray) -> np.ndarray:
    """Compose in the course's order: M = M1 @ M2 @ ... so the last one listed acts on the object first."""
    m = np.eye(4)
    for t in matrices:
        m = m @ t
    return m


def transform_points(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    return p @ m[:3, :3].T + m[:3, 3]


def transform_normals(m: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Normals go by the inverse transpose of the linear part, then are renormalised."""
    n = np.asarray(normals, dtype=np.float64) @ np.linalg.inv(m[:3, :3])
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
