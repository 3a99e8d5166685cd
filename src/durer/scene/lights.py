"""Lights: directional (no falloff), point (with the course's a + b*d + c*d^2 attenuation), spot (a point light
limited to a cone, as glTF's KHR_lights_punctual defines it), and the path tracer's skies: a constant environment
(Mitsuba's `constant` emitter) and an environment map."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .textures import Bitmap, Checker
from .values import unit


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
        if not (np.isfinite(self.direction).all() and np.isfinite(self.color).all()):
            raise ValueError("light direction and colour must be finite")
        if not self.direction.any():
            raise ValueError("light direction has zero length")
        self.direction = unit(self.direction)


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
    glTF's smooth falloff between: clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1)^2, or with
    `falloff="angle"` Mitsuba's spot (beam_width = inner, cutoff_angle = outer): (outer - a) / (outer - inner),
    linear in the angle a (measured on Mitsuba 3.9's spot). Distance attenuation as PointLight's
    1 / (a + b*d + c*d^2) (default: constant). `texture` (Mitsuba's spot texture, a Bitmap or Checker)
    multiplies the colour by its value at texture_uv, as Mitsuba's spot.
    """

    position: np.ndarray
    direction: np.ndarray
    color: np.ndarray = (1.0, 1.0, 1.0)
    inner_angle: float = 0.0
    outer_angle: float = 45.0
    attenuation: tuple[float, float, float] = (1.0, 0.0, 0.0)
    falloff: str = "gltf"
    # the light's own x and y axes (Mitsuba's to_world), which orient a projected texture (texture_uv)
    right: np.ndarray | None = None
    up: np.ndarray | None = None
    texture: Bitmap | Checker | None = None

    def __post_init__(self):
        if self.texture is not None and not isinstance(self.texture, (Bitmap, Checker)):
            raise ValueError(f"a spot light's texture is a Bitmap or Checker, got {type(self.texture).__name__}")
        if self.texture is not None and (self.right is None or self.up is None):
            raise ValueError("a spot light's texture needs its frame (right and up axes)")
        if self.falloff not in ("gltf", "angle"):
            raise ValueError(f"spot light falloff is 'gltf' or 'angle', got {self.falloff!r}")
        point = PointLight(self.position, self.color, self.attenuation)  # the same checks as a point light
        self.position, self.color, self.attenuation = point.position, point.color, point.attenuation
        self.direction = DirectionalLight(self.direction).direction
        self.inner_angle, self.outer_angle = float(self.inner_angle), float(self.outer_angle)
        if not 0 <= self.inner_angle < self.outer_angle <= 90:
            raise ValueError(f"spot light cone angles need 0 <= inner < outer <= 90 degrees, got "
                             f"{self.inner_angle:g} and {self.outer_angle:g}")

    def texture_uv(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) texture coordinates of world `points` in the image the spot projects, as Mitsuba's spot: with d
        the unit direction from the light in its own frame (right, up, direction), (1/2 + d.x / (2 d.z tan(outer)),
        1/2 + d.y / (2 d.z tan(outer))): the cone of outer_angle fills [0, 1]^2's inscribed disk."""
        if self.right is None or self.up is None:
            raise ValueError("a spot light's texture needs its frame (right and up axes)")
        v = np.asarray(points, dtype=np.float64) - self.position
        x, y, z = v @ np.asarray(self.right), v @ np.asarray(self.up), v @ self.direction
        scale = 0.5 / (z * np.tan(np.radians(self.outer_angle)))
        return np.stack([0.5 + x * scale, 0.5 + y * scale], axis=-1)

    def cone_factor(self, to_light: np.ndarray) -> np.ndarray:
        """(N,) share of the light reaching points whose unit directions towards the light are `to_light`."""
        cos_a = -(to_light @ self.direction)
        if self.falloff == "angle":
            outer, inner = np.radians(self.outer_angle), np.radians(self.inner_angle)
            ramp = (outer - np.arccos(np.clip(cos_a, -1.0, 1.0))) / max(outer - inner, 1e-12)
            return np.where(cos_a > np.cos(outer), np.where(cos_a >= np.cos(inner), 1.0, ramp), 0.0)
        cos_outer, cos_inner = np.cos(np.radians(self.outer_angle)), np.cos(np.radians(self.inner_angle))
        return np.clip((cos_a - cos_outer) / max(cos_inner - cos_outer, 1e-3), 0.0, 1.0) ** 2


@dataclass
class ConstantEnvironment:
    """Radiance arriving from every direction at infinity (seen by rays that escape the scene)."""

    radiance: np.ndarray = (1.0, 1.0, 1.0)

    def __post_init__(self):
        self.radiance = np.asarray(self.radiance, dtype=np.float64).reshape(-1)
        if self.radiance.size == 1:
            self.radiance = np.repeat(self.radiance, 3)
        if self.radiance.size != 3 or not np.isfinite(self.radiance).all() or self.radiance.min() < 0:
            raise ValueError(f"environment radiance must be one or three finite non-negative numbers, "
                             f"got {self.radiance.tolist()}")


@dataclass
class EnvironmentMap:
    """Radiance at infinity from a latitude-longitude image (H, W, 3), Mitsuba's `envmap` convention: in the map's
    own frame (`to_world`, a rotation) the direction (x, y, z) reads the image at u = atan2(x, -z) / 2 pi (column,
    wrapping), v = acos(y) / pi (row 0 at the top, y up), bilinearly; `scale` multiplies it."""

    image: np.ndarray
    scale: float = 1.0
    to_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    source: str | None = None

    def __post_init__(self):
        self.image = np.asarray(self.image, dtype=np.float64)
        if self.image.ndim == 2:
            self.image = np.repeat(self.image[:, :, None], 3, axis=2)
        if self.image.ndim != 3 or self.image.shape[2] not in (3, 4) or min(self.image.shape[:2]) < 2:
            raise ValueError(f"an environment map needs an (H, W, 3) image of at least 2 x 2, got {self.image.shape}")
        self.image = np.ascontiguousarray(self.image[:, :, :3])
        if not np.isfinite(self.image).all() or self.image.min() < 0:
            raise ValueError("environment map values must be finite and non-negative")
        self.scale = float(self.scale)
        self.to_world = np.asarray(self.to_world, dtype=np.float64).reshape(4, 4)
