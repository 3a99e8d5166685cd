"""Solid-texture materials of assignment 6: each blends two other materials (by index) in texture space.

`matrix` is the material's `Transform { }` composed as for objects; the course applies it to the world point directly
("multiply the intersection point by the matrix"), so a world point p is looked up at matrix @ p (texturing.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _identity() -> np.ndarray:
    return np.eye(4)


@dataclass
class _Blend:
    """Every solid texture blends two other materials, by their index in the scene's material list."""

    material1: int
    material2: int


@dataclass
class Checkerboard(_Blend):
    """Unit 3D checker cells: material1 where floor(x)+floor(y)+floor(z) is even, material2 where odd."""

    matrix: np.ndarray = field(default_factory=_identity)


@dataclass
class Noise(_Blend):
    """Perlin's improved noise N summed over octaves: material1 gets clamp(N + 1/2, 0, 1), material2 the rest."""

    octaves: int = 1
    matrix: np.ndarray = field(default_factory=_identity)


@dataclass
class _Waves(_Blend):
    """The fields Marble and Wood share: noise octaves perturbing a wave of `frequency` by `amplitude`."""

    octaves: int = 1
    frequency: float = 1.0
    amplitude: float = 1.0
    matrix: np.ndarray = field(default_factory=_identity)


@dataclass
class Marble(_Waves):
    """sin(frequency * x + amplitude * noise(p)) blending material1 and material2."""


@dataclass
class Wood(_Waves):
    """Rings around the texture-space y axis perturbed by noise, blending material1 and material2."""


Texture = Checkerboard | Noise | Marble | Wood
