"""Materials: the course's Phong material (assignments 1-4). Solid textures live in textures.py."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _rgb(v) -> np.ndarray:
    return np.asarray(v, dtype=np.float64).reshape(3)


@dataclass
class PhongMaterial:
    """Blinn-Phong surface with optional mirror reflection and refraction.

    `Material { diffuseColor }` of assignments 1-2 is a PhongMaterial with only a diffuse colour.
    """

    diffuse_color: np.ndarray = (1.0, 1.0, 1.0)
    specular_color: np.ndarray = (0.0, 0.0, 0.0)
    exponent: float = 1.0
    reflective_color: np.ndarray = (0.0, 0.0, 0.0)
    transparent_color: np.ndarray = (0.0, 0.0, 0.0)
    index_of_refraction: float = 1.0

    def __post_init__(self):
        self.diffuse_color = _rgb(self.diffuse_color)
        self.specular_color = _rgb(self.specular_color)
        self.reflective_color = _rgb(self.reflective_color)
        self.transparent_color = _rgb(self.transparent_color)
        self.exponent = float(self.exponent)
        self.index_of_refraction = float(self.index_of_refraction)


Material = PhongMaterial
