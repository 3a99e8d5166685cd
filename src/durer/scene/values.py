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
