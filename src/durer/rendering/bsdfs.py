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
from functools import lru_cache

import numpy as np

from ..kernels.path.columns import (
    AU,
    AV,
    BECKMANN,
    BLACK,
    BLEND,
    BUMP_SCALE,
    C1,
    C2,
    C3,
    C4,
    CHILD0,
    CHILD1,
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
    MAP_FLIP,
    MAP_SHADOW,
    MAP_TWOSIDED,
    NONLINEAR,
    NUMBER_PAIRS,
    OPACITY,
    PHONG,
    PLASTIC,
    PR_ANISO,
    PRINCIPLED,
    PRINCIPLED_PARAMS,
    PRINCIPLEDTHIN,
    ROUGHCONDUCTOR,
    ROUGHDIELECTRIC,
    ROUGHPLASTIC,
    SMOOTH,
    SPEC_WEIGHT,
    TEX_C1,
    TEX_NUMBERS,
    TEXTURED,
    THINDIELECTRIC,
    TROW,
    TWOSIDED,
    WEIGHT,
)
from ..kernels.path.compose import eval_kernel, sample_kernel
from ..kernels.path.microfacet import rough_albedo_kernel
from ..scene.bsdfs import (
    Blend,
    BumpMap,
    Conductor,
    Dielectric,
    Diffuse,
    Mask,
    NormalMap,
    Plastic,
    Principled,
    PrincipledThin,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    Surface,
    ThinDielectric,
    TwoSided,
)
from ..scene.materials import PhongMaterial
from ..scene.textures import Bitmap, Checker
from .textures import TextureTable, mean

# the textured parameters, in the order of the TEX_* columns (kernels/path/bsdf.py)
TEXTURED_PARAMS = ("c1", "c2", "alpha_u", "alpha_v", "opacity", "weight", "emission", "normalmap", "bump")
ROUGH_RES = 64  # cos(theta) samples of the rough plastic's transmittance table (Mitsuba's MI_ROUGH_TRANSMITTANCE_RES)
ROUGH_MU = np.maximum(1e-6, np.linspace(0.0, 1.0, ROUGH_RES))  # those cos(theta)


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
    opacity: np.ndarray = field(default_factory=lambda: np.zeros(0))      # Mitsuba's mask (1: opaque)
    weight: np.ndarray = field(default_factory=lambda: np.zeros(0))       # a blend's weight of child1
    child0: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))  # a blend's rows (after the slots)
    child1: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    tex: np.ndarray = field(default_factory=lambda: np.zeros((0, len(TEXTURED_PARAMS)), np.int64))  # ids or -1
    bump_scale: np.ndarray = field(default_factory=lambda: np.zeros(0))
    principled: np.ndarray = field(default_factory=lambda: np.zeros((0, len(PRINCIPLED_PARAMS))))  # PR_* columns
    numbers: np.ndarray = field(default_factory=lambda: np.zeros((0, 2 * NUMBER_PAIRS), np.int64))  # TEX_NUMBERS
    map_flip: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))    # a normal/bump map's two options
    map_shadow: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    map_twosided: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))  # a twosided around the map
    textures: TextureTable = field(default_factory=TextureTable)
    _packed: tuple | None = None

    @classmethod
    def from_materials(cls, materials: list) -> BSDFTable:
        """One row per scene material: Surface, a bare BSDF, a course PhongMaterial or a solid texture (a
        texture's row is a placeholder: the integrator resolves it into the materials it blends); then the rows of
        blends' two BSDFs. Textured parameters name their texture in `textures` and hold its mean."""
        textures = TextureTable()
        rows = [_row(m, textures) for m in materials]
        for r in list(rows):
            for k, child in enumerate(r.pop("children")):
                r[f"child{k}"] = len(rows)
                rows.append(_row(child, textures))
                rows[-1].pop("children")
        t = cls(textures=textures)
        for name in rows[0] if rows else {}:
            setattr(t, name, np.array([r[name] for r in rows]))
        t.kind = t.kind.astype(np.int8)
        t.tex = t.tex.reshape(len(rows), len(TEXTURED_PARAMS))
        t.principled = t.principled.reshape(len(rows), len(PRINCIPLED_PARAMS))
        t.numbers = t.numbers.reshape(len(rows), 2 * NUMBER_PAIRS)
        return t

    def smooth(self, slot: np.ndarray) -> np.ndarray:
        """(N,) bool: has the BSDF a non-delta lobe, so that light sampling can reach it?"""
        return self.packed()[0][slot, SMOOTH] != 0

    def packed(self) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
        """The table as kernels/path/bsdf.py reads it: one float64 row per slot (its column layout), the rough
        plastics' transmittance tables and the texture table (TI, TD); made once (the texture table's arrays
        anew when a texture was added since, as the emitters add spots' textures)."""
        if self._packed is None:
            n = len(self.kind)
            P = np.zeros((n, COLUMNS))
            for col, colour in ((C1, self.c1), (C2, self.c2), (C3, self.c3), (C4, self.c4), (EMISSION, self.emission)):
                P[:, col:col + 3] = colour.reshape(n, 3)
            for col, value in ((KIND, self.kind), (TWOSIDED, self.twosided), (NONLINEAR, self.nonlinear),
                               (FLIP, self.flip), (ETA, self.eta), (AU, self.alpha_u), (AV, self.alpha_v),
                               (EXPONENT, self.exponent), (SPEC_WEIGHT, self.spec_weight), (FDR_INT, self.fdr_int),
                               (BECKMANN, self.beckmann), (OPACITY, self.opacity), (WEIGHT, self.weight),
                               (CHILD0, self.child0), (CHILD1, self.child1), (BUMP_SCALE, self.bump_scale),
                               (MAP_FLIP, self.map_flip), (MAP_SHADOW, self.map_shadow),
                               (MAP_TWOSIDED, self.map_twosided)):
                P[:, col] = value
            P[:, TROW] = np.arange(n)
            P[:, TEX_C1:TEX_C1 + len(TEXTURED_PARAMS)] = self.tex
            P[:, PR_ANISO:PR_ANISO + len(PRINCIPLED_PARAMS)] = self.principled
            P[:, TEX_NUMBERS:TEX_NUMBERS + 2 * NUMBER_PAIRS] = self.numbers
            textured = (self.tex >= 0).any(axis=1) | (self.numbers[:, 1::2] >= 0).any(axis=1)
            blend = self.kind == BLEND
            textured[blend] |= textured[self.child0[blend]] | textured[self.child1[blend]]
            P[:, TEXTURED] = textured
            smooth = ~np.isin(self.kind, (DIELECTRIC, THINDIELECTRIC, CONDUCTOR, BLACK))
            phong = self.kind == PHONG
            smooth[phong] = (self.c1[phong].max(1) > 0) | (self.c2[phong].max(1) > 0)
            smooth[blend] = smooth[self.child0[blend]] | smooth[self.child1[blend]]
            P[:, SMOOTH] = smooth
            self._packed = (P, np.ascontiguousarray(self.transmittance.reshape(n, ROUGH_RES), dtype=np.float64))
        return self._packed[0], self._packed[1], self.textures.packed()


def _row(m, textures: TextureTable) -> dict:
    r = dict(kind=BLACK, twosided=False, c1=np.zeros(3), c2=np.zeros(3), c3=np.zeros(3), c4=np.zeros(3), eta=1.0,
             alpha_u=0.1, alpha_v=0.1, exponent=1.0, spec_weight=0.0, fdr_int=0.0, nonlinear=False,
             transmittance=np.ones(ROUGH_RES), emission=np.zeros(3), flip=False, is_texture=False, beckmann=False,
             opacity=1.0, weight=0.0, child0=0, child1=0, tex=np.full(len(TEXTURED_PARAMS), -1), bump_scale=0.0,
             principled=np.zeros(len(PRINCIPLED_PARAMS)), numbers=np.full(2 * NUMBER_PAIRS, -1), map_flip=False,
             map_shadow=False, map_twosided=False, children=())
    if isinstance(m, Surface):
        if m.radiance is not None:
            r["emission"] = m.radiance
        r["flip"] = m.flip_normals
        m = m.bsdf
    while isinstance(m, (Mask, NormalMap, BumpMap, TwoSided)):  # modifiers of one row, in any order
        if isinstance(m, Mask):
            r["opacity"] = m.opacity
        elif isinstance(m, (NormalMap, BumpMap)):
            if isinstance(m, NormalMap):
                r["normalmap"] = m.normalmap
            else:
                r["bump"], r["bump_scale"] = m.texture, m.scale
            r["map_flip"], r["map_shadow"] = m.flip_invalid_normals, m.use_shadowing_function
        elif "normalmap" in r or "bump" in r:
            r["twosided"] = True
        else:  # around a map, if one follows: Mitsuba mirrors wi and wo before the map sees them
            r["map_twosided"] = True
        m = m.bsdf
    if r["map_twosided"] and "normalmap" not in r and "bump" not in r:  # no map: an ordinary two-sided BSDF
        r["twosided"], r["map_twosided"] = True, False
    if m is None:
        return _textures(r, textures)
    if isinstance(m, PhongMaterial):
        lobes = np.array([m.diffuse_color, m.specular_color, m.reflective_color, m.transparent_color])
        lobes = lobes / max(1.0, float(lobes.sum(axis=0).max()))  # energy conservation (module docstring)
        r.update(kind=PHONG, c1=lobes[0], c2=lobes[1], c3=lobes[2], c4=lobes[3], eta=m.index_of_refraction,
                 exponent=m.exponent)
    elif isinstance(m, Blend):
        r.update(kind=BLEND, weight=m.weight, children=(m.bsdf0, m.bsdf1))
    elif isinstance(m, Diffuse):
        r.update(kind=DIFFUSE, c1=m.reflectance)
    elif isinstance(m, (Principled, PrincipledThin)):
        thin = isinstance(m, PrincipledThin)
        names = {"main_specular_sampling_rate": "specular_reflectance_sampling_rate"} if thin else {}
        values = [getattr(m, names.get(n, n), 0.0) for n in PRINCIPLED_PARAMS]
        eta = m.eta if thin else m.relative_eta
        pairs = [(PR_ANISO + k, v) for k, v in enumerate(values) if isinstance(v, (Bitmap, Checker))]
        pairs += [(ETA, eta)] if isinstance(eta, (Bitmap, Checker)) else []
        for k, (col, tex) in enumerate(pairs):  # numbers read per hit (kernels/path/textures._substitute)
            r["numbers"][2 * k:2 * k + 2] = col, textures.add(tex)
        r.update(kind=PRINCIPLEDTHIN if thin else PRINCIPLED, c1=m.base_color, alpha_u=m.roughness,
                 eta=_mean1(eta), principled=np.array([_mean1(v) for v in values], np.float64))
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
        # Mitsuba weighs the lobes' sampling by the textures' means
        d_mean, s_mean = mean(m.diffuse_reflectance).mean(), mean(m.specular_reflectance).mean()
        r.update(kind=PLASTIC, c1=m.diffuse_reflectance, c2=m.specular_reflectance, eta=eta, nonlinear=m.nonlinear,
                 spec_weight=s_mean / (d_mean + s_mean), fdr_int=fresnel_diffuse_reflectance(1.0 / eta))
        if isinstance(m, RoughPlastic):
            b = m.distribution == "beckmann"
            alpha = float(m.alpha)
            r.update(kind=ROUGHPLASTIC, alpha_u=m.alpha, alpha_v=m.alpha, beckmann=b,
                     transmittance=_rough_albedo(alpha, float(eta), True, b),
                     fdr_int=2.0 * np.mean(_rough_albedo(alpha, 1.0 / float(eta), False, b) * ROUGH_MU))
    else:
        r["is_texture"] = True  # a solid texture: resolved per hit into the materials it blends
    return _textures(r, textures)


def _mean1(v) -> float:
    """A number parameter's constant column: its value, or a texture's mean (the row holds it until the hit's UV
    resolves the texture)."""
    return float(v.mean) if isinstance(v, (Bitmap, Checker)) else float(v)


def _textures(r: dict, textures: TextureTable) -> dict:
    """Move each texture out of row r into the texture table: its id in r["tex"], its mean in the constant
    column (what Mitsuba's sampling weights read)."""
    for k, name in enumerate(TEXTURED_PARAMS):
        v = r.pop(name, None) if name in ("normalmap", "bump") else r[name]
        if isinstance(v, (Bitmap, Checker)):
            r["tex"][k] = textures.add(v)
            if name in r:
                r[name] = mean(v) if name in ("c1", "c2", "emission") else float(v.mean)
    return r


# --- tables -------------------------------------------------------------------------------------------------------
def fresnel_diffuse_reflectance(eta: float) -> float:
    """Hemispherical average of the dielectric Fresnel reflectance (fits by Egan-Hilgeman and d'Eon-Irving, as
    in Mitsuba's fresnel_diffuse_reflectance)."""
    if eta < 1:
        return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    i = 1.0 / eta
    return 0.919317 - 3.4793 * i + 6.75335 * i ** 2 - 7.80989 * i ** 3 + 4.98554 * i ** 4 - 1.36881 * i ** 5


@lru_cache(maxsize=256)
def _rough_albedo(alpha: float, eta: float, transmit: bool, beckmann: bool = False, n: int = 64) -> np.ndarray:
    """Single-scattering reflectance (or transmittance) of a rough GGX (or Beckmann) dielectric interface at
    cos(theta) = ROUGH_MU (kernels/path/microfacet.rough_albedo_kernel: the midpoint rule on n x n visible normals).
    Kept per process (read-only): a table took 0.1-0.35 s, every render, and a scene with several rough
    plastics spent most of a 16-spp render building them (integrator_direct_both: 8 tables, benchmarks/README)."""
    out = np.empty(len(ROUGH_MU))
    rough_albedo_kernel(ROUGH_MU, float(alpha), float(eta), bool(transmit), n, out, np.bool_(beckmann))
    out.flags.writeable = False
    return out


# --- evaluation and sampling: the Numba kernels of kernels/path/bsdf.py ------------------------------------------
def eval_pdf(t: BSDFTable, slot: np.ndarray, wi: np.ndarray, wo: np.ndarray,
             uv: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """f(wi, wo) * cos(theta_o) (N,3) and the pdf (N,) with which `sample` would pick wo (delta lobes excluded);
    textures looked up at uv (N,2) (default 0)."""
    n = len(slot)
    value, pdf = np.zeros((n, 3)), np.zeros(n)
    P, T, tex = t.packed()
    eval_kernel(P, T, tex, _i64(slot), _uv(uv, n), _f64(wi), _f64(wo), value, pdf)
    return value, pdf


def sample(t: BSDFTable, slot: np.ndarray, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray,
           uv: np.ndarray | None = None):
    """Sample wo for each ray: returns wo (N,3), weight = f cos / pdf (N,3; 0 where nothing was sampled), pdf (N,),
    delta (N,) bool (a specular lobe was picked) and eta (N,) (relative index crossed, 1 for reflection)."""
    n = len(slot)
    wo, weight, pdf = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    delta, eta = np.zeros(n, bool), np.ones(n)
    P, T, tex = t.packed()
    sample_kernel(P, T, tex, _i64(slot), _uv(uv, n), _f64(wi), _f64(u1), _f64(u2), wo, weight, pdf, delta, eta)
    return wo, weight, pdf, delta, eta


def _uv(uv, n: int) -> np.ndarray:
    return np.zeros((n, 2)) if uv is None else _f64(np.broadcast_to(uv, (n, 2)))


def _i64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def _f64(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)
