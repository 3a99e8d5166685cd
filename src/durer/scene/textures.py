"""Solid-texture materials of assignment 6: each blends two other materials (by index) in texture space.

`matrix` is the material's `Transform { }` composed as for objects; the course applies it to the world point directly
("multiply the intersection point by the matrix"), so a world point p is looked up at matrix @ p (texturing.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Checkerboard:
    """Unit 3D checker cells: material1 where floor(x)+floor(y)+floor(z) is even, material2 where odd."""

    material1: int
    material2: int
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass
class Noise:
    """Perlin's improved noise N summed over octaves: material1 gets clamp(N + 1/2, 0, 1), material2 the rest."""

    material1: int
    material2: int
    octaves: int = 1
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass
class Marble:
    """sin(frequency * x + amplitude * noise(p)) blending material1 and material2."""

    material1: int
    material2: int
    octaves: int = 1
    frequency: float = 1.0
    amplitude: float = 1.0
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass
class Wood:
    """Rings around the texture-space y axis perturbed by noise, blending material1 and material2."""

    material1: int
    material2: int
    octaves: int = 1
    frequency: float = 1.0
    amplitude: float = 1.0
    matrix: np.ndarray = field(default_factory=lambda: np.eye(4))


Texture = Checkerboard | Noise | Marble | Wood
