"""Lights: directional (no falloff), point (with the course's a + b*d + c*d^2 attenuation) and spot (a point light
limited to a cone, as glTF's KHR_lights_punctual defines it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _three(v, what: str) -> np.ndarray:
    """Three float64 numbers, or a ValueError naming the field (finiteness is checked by each light)."""
    try:
        return np.asarray(v, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be three numbers, got {v!r}") from None


@dataclass
class DirectionalLight:
    """Light arriving everywhere along `direction` (the direction it travels, not towards the light)."""

    direction: np.ndarray
    color: np.ndarray = (1.0, 1.0, 1.0)

    def __post_init__(self):
        self.direction = _three(self.direction, "DirectionalLight direction")
        self.color = _three(self.color, "DirectionalLight color")
        n = np.linalg.norm(self.direction)
        if not (np.isfinite(self.direction).all() and np.isfinite(self.color).all()):
            raise ValueError("light direction and colour must be finite")
        if not n > 0:
            raise ValueError("light direction has zero length")
        self.direction = self.direction / n


@dataclass
class PointLight:
    """Light from `position`, scaled by 1 / (a + b*d + c*d^2) at distance d (default: constant)."""

    position: np.ndarray
    color: np.ndarray = (1.0, 1.0, 1.0)
    attenuation: tuple[float, float, float] = (1.0, 0.0, 0.0)

    def __post_init__(self):
        self.position = _three(self.position, "PointLight position")
        self.color = _three(self.color, "PointLight color")
        self.attenuation = tuple(_three(self.attenuation, "PointLight attenuation").tolist())
        if not (np.isfinite(self.position).all() and np.isfinite(self.color).all()
                and np.isfinite(self.attenuation).all()):
            raise ValueError("light position, colour and attenuation must be finite")
        if len(self.attenuation) != 3 or min(self.attenuation) < 0 or sum(self.attenuation) <= 0:
            raise ValueError("attenuation needs three non-negative coefficients, not all zero")


@dataclass
class SpotLight:
    """A point light at `position` shining along `direction` into a cone (glTF KHR_lights_punctual's spot).

    Full strength inside `inner_angle`, none outside `outer_angle` (half-angles from the axis, in degrees), and
    glTF's smooth falloff between: clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1)^2. Distance
    attenuation as PointLight's 1 / (a + b*d + c*d^2) (default: constant).
    """

    position: np.ndarray
    direction: np.ndarray
    color: np.ndarray = (1.0, 1.0, 1.0)
    inner_angle: float = 0.0
    outer_angle: float = 45.0
    attenuation: tuple[float, float, float] = (1.0, 0.0, 0.0)

    def __post_init__(self):
        point = PointLight(self.position, self.color, self.attenuation)  # the same checks as a point light
        self.position, self.color, self.attenuation = point.position, point.color, point.attenuation
        self.direction = DirectionalLight(self.direction).direction
        self.inner_angle, self.outer_angle = float(self.inner_angle), float(self.outer_angle)
        if not 0 <= self.inner_angle < self.outer_angle <= 90:
            raise ValueError(f"spot light cone angles need 0 <= inner < outer <= 90 degrees, got "
                             f"{self.inner_angle:g} and {self.outer_angle:g}")

    def cone_factor(self, to_light: np.ndarray) -> np.ndarray:
        """(N,) share of the light reaching points whose unit directions towards the light are `to_light`."""
        cos_a = -(to_light @ self.direction)
        cos_outer, cos_inner = np.cos(np.radians(self.outer_angle)), np.cos(np.radians(self.inner_angle))
        return np.clip((cos_a - cos_outer) / max(cos_inner - cos_outer, 1e-3), 0.0, 1.0) ** 2
