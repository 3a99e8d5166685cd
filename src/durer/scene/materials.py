"""Materials: the course's Phong material (assignments 1-4). Solid textures live in textures.py."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .values import finite_triple


def _rgb(v, what: str = "colour") -> np.ndarray:
    """A finite float64 RGB triple, or a ValueError naming the field."""
    return finite_triple(v, what, "three numbers (r, g, b)")


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
        kind = type(self).__name__
        for name in ("diffuse_color", "specular_color", "reflective_color", "transparent_color"):
            setattr(self, name, _rgb(getattr(self, name), f"{kind} {name}"))
        for name in ("exponent", "index_of_refraction"):
            try:
                setattr(self, name, float(getattr(self, name)))
            except (TypeError, ValueError):
                raise ValueError(f"{kind} {name} must be a number, got {getattr(self, name)!r}") from None
        if not 0 <= self.exponent < np.inf:  # cos^exponent: a negative one divides by zero at grazing angles
            raise ValueError(f"{kind} exponent must be finite and not negative, got {self.exponent:g}")


Material = PhongMaterial


@dataclass
class PBRMaterial(PhongMaterial):
    """A glTF metallic-roughness material, kept as given and shaded through the Phong fields it derives.

    Build it with `PBRMaterial.from_pbr(...)`, which fills the Phong fields (the mapping below); the PBR values stay
    for integrators that can use them. `emission` (linear RGB) is added to the shaded colour; `texture` (linear
    RGB float32 (H, W, 3), or None) multiplies the diffuse colour through the mesh's UVs (row 0 at v = 1).

    Mapping (durer's Phong has no environment to reflect, so metals keep part of their colour as diffuse):
      diffuse     = base_color * (1 - 0.7 * metallic)
      F0          = 0.04 * (1 - metallic) + base_color * metallic       (glTF's specular colour at normal incidence)
      exponent    = clip(2 / roughness^4 - 2, 1, 1000)                  (Blinn-Phong lobe of GGX alpha = roughness^2)
      specular    = F0 * (exponent + 8) / 8                             (energy-normalised Blinn-Phong peak)
      reflective  = F0 * (1 - roughness)^2                              (mirror rays, with --bounces)
    """

    base_color: np.ndarray = (1.0, 1.0, 1.0)
    metallic: float = 0.0
    roughness: float = 1.0
    emission: np.ndarray = (0.0, 0.0, 0.0)
    texture: np.ndarray | None = None
    name: str = ""

    def __post_init__(self):
        super().__post_init__()
        self.base_color = _rgb(self.base_color, f"material {self.name!r} base_color")
        self.emission = _rgb(self.emission, f"material {self.name!r} emission")
        self.metallic, self.roughness = float(self.metallic), float(self.roughness)
        if not (0 <= self.metallic <= 1 and 0 <= self.roughness <= 1):
            raise ValueError(f"material {self.name!r}: metallic and roughness must be in [0, 1], got "
                             f"{self.metallic:g} and {self.roughness:g}")
        if self.texture is not None:
            tex = np.asarray(self.texture, dtype=np.float32)
            if tex.ndim != 3 or tex.shape[2] != 3 or not tex.size:
                raise ValueError(f"material {self.name!r}: texture must be an (H, W, 3) array, got {tex.shape}")
            self.texture = tex

    @classmethod
    def from_pbr(cls, base_color=(1.0, 1.0, 1.0), metallic: float = 0.0, roughness: float = 1.0,
                 emission=(0.0, 0.0, 0.0), texture: np.ndarray | None = None, name: str = "") -> PBRMaterial:
        """The material with its Phong fields derived from the glTF values (see the class docstring)."""
        base = _rgb(base_color)
        m, r = float(metallic), float(roughness)
        f0 = 0.04 * (1.0 - m) + base * m
        exponent = float(np.clip(2.0 / max(r, 1e-3) ** 4 - 2.0, 1.0, 1000.0))
        return cls(diffuse_color=base * (1.0 - 0.7 * m), specular_color=f0 * (exponent + 8.0) / 8.0,
                   exponent=exponent, reflective_color=f0 * (1.0 - r) ** 2, base_color=base, metallic=m,
                   roughness=r, emission=emission, texture=texture, name=name)
