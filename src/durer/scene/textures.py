"""Textures. The course's solid textures are materials that blend two other materials (by index) in 3D texture
space; Mitsuba's `bitmap` and `checkerboard` are values of a BSDF parameter (Bitmap, Checker), looked up at a hit's
texture coordinates.

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


def _to_uv(m) -> np.ndarray:
    m = np.asarray(m, dtype=np.float64)
    if m.shape != (3, 3) or not np.isfinite(m).all():
        raise ValueError("to_uv must be a finite 3x3 matrix (a 2D affine transform)")
    return m


@dataclass
class Bitmap:
    """Mitsuba's `bitmap` texture: an image looked up at a hit's texture coordinates (to_uv @ (u, v, 1)), pixel
    row 0 at v = 0, with `filter` bilinear or nearest and `wrap` repeat, mirror or clamp (kernels/path/textures.py
    documents the lookup). `image` (H, W, C), C = 1 or 3, holds linear values: the reader decodes sRGB unless the
    texture is raw. `mean` is what Mitsuba's Texture::mean gives (a plastic's sampling weights use it)."""

    image: np.ndarray
    filter: str = "bilinear"
    wrap: str = "repeat"
    to_uv: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        img = np.asarray(self.image, dtype=np.float32)
        if img.ndim == 2:
            img = img[:, :, None]
        if img.ndim != 3 or img.shape[2] not in (1, 3) or not img.size or not np.isfinite(img).all():
            raise ValueError(f"a bitmap is a finite (H, W, 1 or 3) image, got shape {img.shape}")
        self.image = np.ascontiguousarray(img)
        if self.filter not in ("bilinear", "nearest"):
            raise ValueError(f"bitmap filter_type must be bilinear or nearest, got {self.filter!r}")
        if self.wrap not in ("repeat", "mirror", "clamp"):
            raise ValueError(f"bitmap wrap_mode must be repeat, mirror or clamp, got {self.wrap!r}")
        self.to_uv = _to_uv(self.to_uv)

    @property
    def mean(self) -> float:
        return float(self.image.mean())


@dataclass
class Checker:
    """Mitsuba's `checkerboard` texture: color0 where frac(u) > 1/2 and frac(v) > 1/2 agree, color1 where they
    differ, with (u, v) = to_uv @ (u, v, 1) from the hit's texture coordinates (Mitsuba's checkerboard.cpp)."""

    color0: np.ndarray = 0.4
    color1: np.ndarray = 0.2
    to_uv: np.ndarray = field(default_factory=lambda: np.eye(3))

    def __post_init__(self):
        self.color0, self.color1 = (np.broadcast_to(np.asarray(c, dtype=np.float64).reshape(-1), (3,)).copy()
                                    for c in (self.color0, self.color1))
        if not (np.isfinite(self.color0).all() and np.isfinite(self.color1).all()):
            raise ValueError("checkerboard colours must be finite")
        self.to_uv = _to_uv(self.to_uv)

    @property
    def mean(self) -> float:
        return float(0.5 * (self.color0.mean() + self.color1.mean()))


TextureValue = Bitmap | Checker  # a BSDF parameter given as a texture (looked up per hit by the path tracer)
Texture = Checkerboard | Noise | Marble | Wood
