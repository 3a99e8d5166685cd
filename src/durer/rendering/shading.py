"""Local shading at hit points: the course's flat colour (assignment 1) and Blinn-Phong (assignments 2-3).

    colour = ambient * kd + sum_lights  light_i * (kd * max(N.L_i, 0) + ks * max(N.H_i, 0)^exponent)

with H the half vector between the direction to the light and the direction to the viewer, as the course's
"Blinn-Torrance version of the Phong model". Everything is vectorised over the hits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.lights import DirectionalLight, PointLight, SpotLight
from ..scene.materials import PBRMaterial, PhongMaterial
from .textures import TextureTable


@dataclass
class MaterialTable:
    """The scene's Phong materials as arrays indexed by material id."""

    diffuse: np.ndarray      # (M,3)
    specular: np.ndarray     # (M,3)
    exponent: np.ndarray     # (M,)
    reflective: np.ndarray   # (M,3)
    transparent: np.ndarray  # (M,3)
    ior: np.ndarray          # (M,)
    emission: np.ndarray | None = None  # (M,3) PBR materials' emitted colour; None when nothing glows

    @classmethod
    def from_materials(cls, materials: list) -> MaterialTable:
        """Rows indexed by scene material id. Solid textures get all-zero rows: they are never shaded directly,
        texturing.leaf_weights resolves them into the Phong materials they blend."""
        phong = [m if isinstance(m, PhongMaterial) else _NO_MATERIAL for m in materials]
        return cls(
            diffuse=np.array([m.diffuse_color for m in phong]).reshape(-1, 3),
            specular=np.array([m.specular_color for m in phong]).reshape(-1, 3),
            exponent=np.array([m.exponent for m in phong], dtype=np.float64),
            reflective=np.array([m.reflective_color for m in phong]).reshape(-1, 3),
            transparent=np.array([m.transparent_color for m in phong]).reshape(-1, 3),
            ior=np.array([m.index_of_refraction for m in phong], dtype=np.float64),
            emission=_glow(materials),
        )


_NO_MATERIAL = PhongMaterial(diffuse_color=(0.0, 0.0, 0.0))


def _glow(materials: list) -> np.ndarray | None:
    """Emitted colour (M,3) by material id (PBR materials' emissive, zero elsewhere), or None if nothing glows."""
    glow = np.array([m.emission if isinstance(m, PBRMaterial) else np.zeros(3) for m in materials]).reshape(-1, 3)
    return glow if glow.any() else None


def light_directions(light, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each point: unit direction towards the light, the light's colour there, and its distance (inf for
    a directional light). A spot light is a point light times its cone's falloff (SpotLight.cone_factor)."""
    n = len(points)
    if isinstance(light, DirectionalLight):
        to_light = np.broadcast_to(-light.direction, (n, 3))
        return to_light, np.broadcast_to(light.color, (n, 3)), np.full(n, np.inf)
    if isinstance(light, (PointLight, SpotLight)):
        v = light.position - points
        dist = np.linalg.norm(v, axis=1)
        to_light = v / np.maximum(dist, 1e-300)[:, None]
        a, b, c = light.attenuation
        scale = 1.0 / np.maximum(a + b * dist + c * dist * dist, 1e-300)
        color = np.broadcast_to(light.color, (n, 3))
        if isinstance(light, SpotLight):
            scale = scale * light.cone_factor(to_light)
            if light.texture is not None:
                lit = scale > 0  # texture_uv is finite only in front of the light
                color = np.zeros((n, 3))
                color[lit] = light.color * _texture_at(light.texture, light.texture_uv(points[lit]))
        return to_light, color * scale[:, None], dist
    raise TypeError(f"not a light: {type(light).__name__}")


def _texture_at(texture, uv: np.ndarray) -> np.ndarray:
    """(N, 3) values of a Bitmap or Checker at texture coordinates uv (N, 2), by the path tracer's lookup."""
    table = TextureTable()
    return table.eval3(table.add(texture), uv)


def phong(normals: np.ndarray, to_viewer: np.ndarray, to_light: np.ndarray, light_color: np.ndarray,
          diffuse: np.ndarray, specular: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """One light's diffuse + specular contribution (N,3); normals, to_viewer and to_light are unit vectors."""
    n_dot_l = np.einsum("ij,ij->i", normals, to_light)
    lit = np.maximum(n_dot_l, 0.0)[:, None] * diffuse
    if np.any(specular):
        h = to_light + to_viewer  # the half vector; none (no highlight) where light and viewer are opposite, whose
        length = np.linalg.norm(h, axis=1, keepdims=True)  # sum's length underflows or is all rounding error
        h = np.divide(h, length, out=np.zeros_like(h), where=length > 1e-12)
        n_dot_h = np.maximum(np.einsum("ij,ij->i", normals, h), 0.0)
        spec = np.where(n_dot_l > 0, n_dot_h ** exponent, 0.0)
        lit = lit + spec[:, None] * specular
    return lit * light_color
