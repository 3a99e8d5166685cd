"""Checks of the plain values scene objects are made of, shared by shapes, materials and lights."""

from __future__ import annotations

import numpy as np


def finite_triple(v, what: str, form: str = "three numbers") -> np.ndarray:
    """`v` as a finite float64 (3,) array, or a ValueError naming `what` (e.g. "sphere center")."""
    try:
        a = np.asarray(v, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be {form}, got {v!r}") from None
    if not np.isfinite(a).all():
        raise ValueError(f"{what} must be finite, got {a.tolist()}")
    return a


def tame(v) -> np.ndarray:
    """A finite, non-zero vector as it is, or, when its length would overflow or underflow (components of 1e200
    or 1e-200), divided by its largest component: the same direction, a length NumPy can square."""
    v = np.asarray(v, dtype=np.float64)
    biggest = float(np.abs(v).max())
    return v if 1e-150 < biggest < 1e150 else v / biggest


def unit(v) -> np.ndarray:
    """A finite, non-zero vector scaled to unit length, without overflow or underflow (tame)."""
    v = tame(v)
    return v / np.linalg.norm(v)
