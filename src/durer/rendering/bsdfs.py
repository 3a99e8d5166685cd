"""BSDFs for the path tracer: the table of every material slot (packed for kernels/path/bsdf.py, which evaluates and
samples them), and evaluation, importance sampling and pdfs over arrays of rays through those kernels.

Directions are in the local frame of the (possibly flipped) surface normal, z up, both pointing away from the
surface: `wi` towards where the path came from, `wo` the new direction. As in Mitsuba 3, eval returns
f(wi, wo) * cos(theta_o), sample returns wo with weight = f * cos / pdf, and delta lobes (mirror, glass) are
reached only by sampling. One-sided BSDFs are black from behind; TwoSided mirrors the frame first.

The course's PhongMaterial maps onto a mixture (kind PHONG), lit both sides, whose lobes are picked in proportion
to their mean colour:
    diffuseColor kd            -> Lambertian lobe kd / pi
    specularColor ks, exponent -> normalised Phong lobe ks (e + 2) / (2 pi) cos^e(alpha) about the mirror direction
    reflectiveColor kr         -> perfect mirror weighted kr
    transparentColor kt, index -> perfect refraction weighted kt (index entering through the front face; total
                                  internal reflection reflects), no Fresnel term, as in the course's tracer.
Course materials are not energy conserving in general (the glass of scene7_05 has kd + ks + kr + kt = 2.1, which
would multiply light by 2.1 at each bounce inside it): when the lobes' sum exceeds 1 in some channel, all four are
scaled down by that sum, so the material reflects and transmits at most what it receives. Solid textures pick one
of their blended materials per hit with the texture's weight as probability (rendering/path.py), an unbiased
estimate of the blend.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kernels.path.bsdf import (
    AU,
    AV,
    BECKMANN,
    BLACK,
    C1,
    C2,
    C3,
    C4,
    COLUMNS,
    CONDUCTOR,
    DIELECTRIC,
    DIFFUSE,
    EMISSION,
    ETA,
    EXPONENT,
    FDR_INT,
    FLIP,
    KIND,
    NONLINEAR,
    PHONG,
    PLASTIC,
    ROUGHCONDUCTOR,
    ROUGHDIELECTRIC,
    ROUGHPLASTIC,
    SMOOTH,
    SPEC_WEIGHT,
    THINDIELECTRIC,
    TWOSIDED,
    eval_kernel,
    sample_kernel,
)
from ..kernels.path.microfacet import rough_albedo_kernel
from ..scene.bsdfs import (
    Conductor,
    Dielectric,
    Diffuse,
    Plastic,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    Surface,
    ThinDielectric,
    TwoSided,
)
from ..scene.materials import PhongMaterial

ROUGH_RES = 64  # cos(theta) samples of the rough plastic's transmittance table (Mitsuba's MI_ROUGH_TRANSMITTANCE_RES)


def _z3() -> np.ndarray:
    return np.zeros((0, 3))


@dataclass
class BSDFTable:
    """Every material slot's BSDF as arrays indexed by slot, plus what the integrator needs per slot."""

    kind: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int8))
    twosided: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    c1: np.ndarray = field(default_factory=_z3)   # diffuse reflectance; conductor/dielectric specular reflectance; kd
    c2: np.ndarray = field(default_factory=_z3)   # dielectric transmittance; plastic specular reflectance; ks
    c3: np.ndarray = field(default_factory=_z3)   # conductor eta; kr
    c4: np.ndarray = field(default_factory=_z3)   # conductor k; kt
    eta: np.ndarray = field(default_factory=lambda: np.zeros(0))    # relative index int / ext; course index
    alpha_u: np.ndarray = field(default_factory=lambda: np.zeros(0))
    alpha_v: np.ndarray = field(default_factory=lambda: np.zeros(0))
    beckmann: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # rough BSDFs: Beckmann, not GGX
    exponent: np.ndarray = field(default_factory=lambda: np.zeros(0))
    spec_weight: np.ndarray = field(default_factory=lambda: np.zeros(0))  # plastics: specular share of sampling
    fdr_int: np.ndarray = field(default_factory=lambda: np.zeros(0))      # plastics: internal diffuse reflectance
    nonlinear: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    transmittance: np.ndarray = field(default_factory=lambda: np.zeros((0, ROUGH_RES)))  # rough plastics
    emission: np.ndarray = field(default_factory=_z3)  # front-side radiance of each slot (0: not a light)
    flip: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    is_texture: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    _packed: tuple | None = None

    @classmethod
    def from_materials(cls, materials: list) -> BSDFTable:
        """One row per scene material: Surface, a bare BSDF, a course PhongMaterial or a solid texture (a
        texture's row is a placeholder: the integrator resolves it into the materials it blends)."""
        rows = [_row(m) for m in materials]
        t = cls()
        for name in rows[0] if rows else {}:
            setattr(t, name, np.array([r[name] for r in rows]))
        t.kind = t.kind.astype(np.int8)
        return t

    def smooth(self, slot: np.ndarray) -> np.ndarray:
        """(N,) bool: has the BSDF a non-delta lobe, so that light sampling can reach it?"""
        return self.packed()[0][slot, SMOOTH] != 0

    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """The table as kernels/path/bsdf.py reads it: one float64 row per slot (its column layout) and the rough
        plastics' transmittance tables; made once."""
        if self._packed is None:
            n = len(self.kind)
            P = np.zeros((n, COLUMNS))
            for col, colour in ((C1, self.c1), (C2, self.c2), (C3, self.c3), (C4, self.c4), (EMISSION, self.emission)):
                P[:, col:col + 3] = colour.reshape(n, 3)
            for col, value in ((KIND, self.kind), (TWOSIDED, self.twosided), (NONLINEAR, self.nonlinear),
                               (FLIP, self.flip), (ETA, self.eta), (AU, self.alpha_u), (AV, self.alpha_v),
                               (EXPONENT, self.exponent), (SPEC_WEIGHT, self.spec_weight), (FDR_INT, self.fdr_int),
                               (BECKMANN, self.beckmann)):
                P[:, col] = value
            smooth = ~np.isin(self.kind, (DIELECTRIC, THINDIELECTRIC, CONDUCTOR, BLACK))
            phong = self.kind == PHONG
            smooth[phong] = (self.c1[phong].max(1) > 0) | (self.c2[phong].max(1) > 0)
            P[:, SMOOTH] = smooth
            self._packed = P, np.ascontiguousarray(self.transmittance.reshape(n, ROUGH_RES), dtype=np.float64)
        return self._packed


def _row(m) -> dict:
    r = dict(kind=BLACK, twosided=False, c1=np.zeros(3), c2=np.zeros(3), c3=np.zeros(3), c4=np.zeros(3), eta=1.0,
             alpha_u=0.1, alpha_v=0.1, exponent=1.0, spec_weight=0.0, fdr_int=0.0, nonlinear=False,
             transmittance=np.ones(ROUGH_RES), emission=np.zeros(3), flip=False, is_texture=False, beckmann=False)
    if isinstance(m, Surface):
        if m.radiance is not None:
            r["emission"] = m.radiance
        r["flip"] = m.flip_normals
        m = m.bsdf
    if isinstance(m, TwoSided):
        r["twosided"] = True
        m = m.bsdf
    if m is None:
        return r
    if isinstance(m, PhongMaterial):
        lobes = np.array([m.diffuse_color, m.specular_color, m.reflective_color, m.transparent_color])
        lobes = lobes / max(1.0, float(lobes.sum(axis=0).max()))  # energy conservation (module docstring)
        r.update(kind=PHONG, c1=lobes[0], c2=lobes[1], c3=lobes[2], c4=lobes[3], eta=m.index_of_refraction,
                 exponent=m.exponent)
    elif isinstance(m, Diffuse):
        r.update(kind=DIFFUSE, c1=m.reflectance)
    elif isinstance(m, RoughDielectric):
        r.update(kind=ROUGHDIELECTRIC, c1=m.specular_reflectance, c2=m.specular_transmittance,
                 eta=m.int_ior / m.ext_ior, alpha_u=m.alpha_u, alpha_v=m.alpha_v, beckmann=m.distribution == "beckmann")
    elif isinstance(m, ThinDielectric):
        r.update(kind=THINDIELECTRIC, c1=m.specular_reflectance, c2=m.specular_transmittance,
                 eta=m.int_ior / m.ext_ior)
    elif isinstance(m, Dielectric):
        r.update(kind=DIELECTRIC, c1=m.specular_reflectance, c2=m.specular_transmittance, eta=m.int_ior / m.ext_ior)
    elif isinstance(m, Conductor):
        r.update(kind=CONDUCTOR, c1=m.specular_reflectance, c3=m.eta, c4=m.k)
        if isinstance(m, RoughConductor):
            r.update(kind=ROUGHCONDUCTOR, alpha_u=m.alpha_u, alpha_v=m.alpha_v, beckmann=m.distribution == "beckmann")
    elif isinstance(m, Plastic):
        eta = m.int_ior / m.ext_ior
        d_mean, s_mean = m.diffuse_reflectance.mean(), m.specular_reflectance.mean()
        r.update(kind=PLASTIC, c1=m.diffuse_reflectance, c2=m.specular_reflectance, eta=eta, nonlinear=m.nonlinear,
                 spec_weight=s_mean / (d_mean + s_mean), fdr_int=fresnel_diffuse_reflectance(1.0 / eta))
        if isinstance(m, RoughPlastic):
            mu = np.maximum(1e-6, np.linspace(0.0, 1.0, ROUGH_RES))
            b = m.distribution == "beckmann"
            r.update(kind=ROUGHPLASTIC, alpha_u=m.alpha, alpha_v=m.alpha, beckmann=b,
                     transmittance=_rough_albedo(mu, m.alpha, eta, transmit=True, beckmann=b),
                     fdr_int=2.0 * np.mean(_rough_albedo(mu, m.alpha, 1.0 / eta, transmit=False, beckmann=b) * mu))
    else:
        r["is_texture"] = True  # a solid texture: resolved per hit into the materials it blends
    return r


# --- tables -------------------------------------------------------------------------------------------------------
def fresnel_diffuse_reflectance(eta: float) -> float:
    """Hemispherical average of the dielectric Fresnel reflectance (fits by Egan-Hilgeman and d'Eon-Irving, as
    in Mitsuba's fresnel_diffuse_reflectance)."""
    if eta < 1:
        return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    i = 1.0 / eta
    return 0.919317 - 3.4793 * i + 6.75335 * i ** 2 - 7.80989 * i ** 3 + 4.98554 * i ** 4 - 1.36881 * i ** 5


def _rough_albedo(mu: np.ndarray, alpha: float, eta: float, transmit: bool, n: int = 64,
                  beckmann: bool = False) -> np.ndarray:
    """Single-scattering reflectance (or transmittance) of a rough GGX (or Beckmann) dielectric interface at
    cos(theta) = mu (kernels/path/microfacet.rough_albedo_kernel: the midpoint rule on n x n visible normals)."""
    out = np.empty(len(mu))
    rough_albedo_kernel(np.ascontiguousarray(mu, dtype=np.float64), float(alpha), float(eta), bool(transmit), n, out,
                        np.bool_(beckmann))
    return out


# --- evaluation and sampling: the Numba kernels of kernels/path/bsdf.py ------------------------------------------
def eval_pdf(t: BSDFTable, slot: np.ndarray, wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """f(wi, wo) * cos(theta_o) (N,3) and the pdf (N,) with which `sample` would pick wo (delta lobes excluded)."""
    n = len(slot)
    value, pdf = np.zeros((n, 3)), np.zeros(n)
    P, T = t.packed()
    eval_kernel(P, T, _i64(slot), _f64(wi), _f64(wo), value, pdf)
    return value, pdf


def sample(t: BSDFTable, slot: np.ndarray, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray):
    """Sample wo for each ray: returns wo (N,3), weight = f cos / pdf (N,3; 0 where nothing was sampled), pdf (N,),
    delta (N,) bool (a specular lobe was picked) and eta (N,) (relative index crossed, 1 for reflection)."""
    n = len(slot)
    wo, weight, pdf = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    delta, eta = np.zeros(n, bool), np.ones(n)
    P, T = t.packed()
    sample_kernel(P, T, _i64(slot), _f64(wi), _f64(u1), _f64(u2), wo, weight, pdf, delta, eta)
    return wo, weight, pdf, delta, eta


def _i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def _f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)
