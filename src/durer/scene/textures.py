"""Texture materials: each blends two other materials (by index). The solid textures of assignment 6 work in 3D
texture space; UVCheckerboard (Mitsuba's checkerboard texture) in a mesh's texture coordinates.

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


@dataclass
class UVCheckerboard(_Blend):
    """Mitsuba's `checkerboard` texture on one BSDF parameter, as a blend of the BSDF with color0 (material1) and
    with color1 (material2): with (u, v) = to_uv @ (u, v, 1) from the mesh's texture coordinates, material1 where
    frac(u) > 1/2 and frac(v) > 1/2 agree, material2 where they differ (Mitsuba's checkerboard.cpp)."""

    to_uv: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        self.to_uv = np.asarray(self.to_uv, dtype=np.float64)
        if self.to_uv.shape != (3, 3) or not np.isfinite(self.to_uv).all():
            raise ValueError("to_uv must be a finite 3x3 matrix (a 2D affine transform)")


Texture = Checkerboard | Noise | Marble | Wood | UVCheckerboard
