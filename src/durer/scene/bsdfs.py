"""Physically based surface descriptions (Mitsuba 3's BSDF plugins of the same names) and `Surface`, the material
slot that binds a BSDF to a shape together with area emission and a normal flip. Plain data; the maths lives in
rendering/bsdfs.py.

Defaults are Mitsuba 3's. Colours are linear RGB triples (a number means grey); a colour or a roughness that Mitsuba
takes as a texture may also be a scene.textures Bitmap or Checker, looked up per hit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .textures import Bitmap, Checker, TextureValue

# Complex indices of refraction (eta, k) of named metals as Mitsuba 3.5.3's `scalar_rgb` variant uses them: its
# spectral data (data/ior/<name>.{eta,k}.spd) integrated to RGB, read back with mi.traverse(conductor). "none" is
# Mitsuba's default, a perfect mirror (eta 0, k 1: Fresnel reflectance 1 at every angle).
METALS: dict[str, tuple[tuple[float, float, float], tuple[float, float, float]]] = {
    "none": ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),
    "Au": ((0.143036, 0.375307, 1.44205), (3.983, 2.38556, 1.60336)),
    "Ag": ((0.155276, 0.116728, 0.138388), (4.82835, 3.12222, 2.1469)),
    "Cu": ((0.201005, 0.92375, 1.10222), (3.91326, 2.45305, 2.14209)),
    "Al": ((1.6575, 0.880405, 0.521244), (9.22381, 6.2695, 4.837)),
    "Cr": ((4.36967, 2.91651, 1.6549), (5.20655, 4.23131, 3.7547)),
}

# Named indices of refraction Mitsuba accepts for int_ior / ext_ior (its ior.h table, the common subset).
IORS: dict[str, float] = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277, "carbon dioxide": 1.00045,
    "water": 1.3330, "acetone": 1.36, "ethanol": 1.361, "carbon tetrachloride": 1.461, "glycerol": 1.4729,
    "benzene": 1.501, "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31, "fused quartz": 1.458,
    "pyrex": 1.470, "acrylic glass": 1.49, "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544,
    "amber": 1.55, "pet": 1.5750, "diamond": 2.419,
}


def rgb(v, what: str = "colour") -> np.ndarray:
    """A finite float64 RGB triple from a number or three numbers, or a ValueError naming `what`."""
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    if a.size == 1:
        a = np.repeat(a, 3)
    if a.size != 3 or not np.isfinite(a).all():
        raise ValueError(f"{what} must be one or three finite numbers, got {v!r}")
    return a


def ior(v, what: str = "index of refraction") -> float:
    """A positive index of refraction from a number or one of Mitsuba's names (IORS)."""
    if isinstance(v, str):
        if v.lower() not in IORS:
            raise ValueError(f"unknown {what} {v!r} (use a number or one of {', '.join(sorted(IORS))})")
        return IORS[v.lower()]
    x = _number(v, what)
    if not (x > 0 and np.isfinite(x)):
        raise ValueError(f"{what} must be positive, got {v!r}")
    return x


def _number(v, what: str) -> float:
    """One real number (a Python or NumPy scalar, or a size-1 array), or a ValueError naming `what`."""
    try:
        a = np.asarray(v, dtype=np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.size != 1 or isinstance(v, (bool, np.bool_)):
        got = f"{a.size} numbers" if a is not None else repr(v)
        raise ValueError(f"{what} must be one number, got {got}")
    return float(a.reshape(-1)[0])


def _alpha(v):
    return _or_texture(v, _alpha_number)


def _alpha_number(v) -> float:
    x = _number(v, "roughness alpha")
    if not (0 < x <= 4):
        raise ValueError(f"roughness alpha must be in (0, 4], got {v!r}")
    return x


def _distribution(v) -> str:
    if v not in ("ggx", "beckmann"):
        raise ValueError(f"microfacet distribution must be 'ggx' or 'beckmann', got {v!r}")
    return v


def _or_texture(v, check, *args):
    """A texture as given (a parameter Mitsuba takes as a texture), anything else through check(v, *args)."""
    return v if isinstance(v, (Bitmap, Checker)) else check(v, *args)


def _albedo(v, what: str):
    return _or_texture(v, _albedo_rgb, what)


def _albedo_rgb(v, what: str) -> np.ndarray:
    a = rgb(v, what)
    if a.min() < 0:
        raise ValueError(f"{what} must not be negative, got {a.tolist()}")
    return a


@dataclass
class Diffuse:
    """Lambertian reflection, one-sided (black from behind, as in Mitsuba; wrap it in TwoSided)."""

    reflectance: np.ndarray = 0.5

    def __post_init__(self):
        self.reflectance = _albedo(self.reflectance, "diffuse reflectance")


@dataclass
class Dielectric:
    """Smooth glass: Fresnel-weighted specular reflection and refraction (the caustic maker)."""

    int_ior: float = 1.5046
    ext_ior: float = 1.000277
    specular_reflectance: np.ndarray = 1.0
    specular_transmittance: np.ndarray = 1.0

    def __post_init__(self):
        self.int_ior, self.ext_ior = ior(self.int_ior, "int_ior"), ior(self.ext_ior, "ext_ior")
        self.specular_reflectance = _albedo(self.specular_reflectance, "specular reflectance")
        self.specular_transmittance = _albedo(self.specular_transmittance, "specular transmittance")


@dataclass
class ThinDielectric(Dielectric):
    """A thin glass pane (Mitsuba's `thindielectric`): light reflects with the slab's summed Fresnel reflectance
    or passes straight through, unbent; seen alike from both sides."""


@dataclass
class Microfacet:
    """What the rough conductor and the rough dielectric share: anisotropic roughness (a number or a texture) and the
    microfacet distribution, checked once here after the smooth BSDF's own checks (a base listed first: the smooth
    BSDF's fields come first, its __post_init__ is next in the MRO)."""

    alpha_u: float = 0.1
    alpha_v: float = 0.1
    distribution: str = "ggx"

    def __post_init__(self):
        super().__post_init__()
        self.alpha_u, self.alpha_v = _alpha(self.alpha_u), _alpha(self.alpha_v)
        self.distribution = _distribution(self.distribution)


@dataclass
class RoughDielectric(Microfacet, Dielectric):
    """Rough glass (Mitsuba's `roughdielectric`): GGX or Beckmann microfacets reflecting and refracting (Walter et
    al. 2007), sampled from the visible normals."""


@dataclass
class Conductor:
    """A smooth metal mirror with the Fresnel reflectance of the complex index eta + i k (per RGB channel)."""

    eta: np.ndarray = 0.0
    k: np.ndarray = 1.0
    specular_reflectance: np.ndarray = 1.0

    def __post_init__(self):
        self.eta, self.k = _albedo(_constant(self.eta, "eta"), "eta"), _albedo(_constant(self.k, "k"), "k")
        self.specular_reflectance = _albedo(self.specular_reflectance, "specular reflectance")

    @classmethod
    def named(cls, material: str, **kw) -> Conductor:
        if material not in METALS:
            raise ValueError(f"unknown conductor material {material!r} (use one of {', '.join(METALS)})")
        eta, k = METALS[material]
        return cls(eta=eta, k=k, **kw)


@dataclass
class RoughConductor(Microfacet, Conductor):
    """A rough metal: GGX (or Beckmann, Mitsuba's default) microfacets, anisotropic with alpha_u != alpha_v, Smith
    shadowing, sampled from the visible normals."""


@dataclass
class Plastic:
    """A diffuse base under a smooth dielectric coating (Mitsuba's `plastic`)."""

    diffuse_reflectance: np.ndarray = 0.5
    specular_reflectance: np.ndarray = 1.0
    int_ior: float = 1.49
    ext_ior: float = 1.000277
    nonlinear: bool = False

    def __post_init__(self):
        self.diffuse_reflectance = _albedo(self.diffuse_reflectance, "diffuse reflectance")
        self.specular_reflectance = _albedo(self.specular_reflectance, "specular reflectance")
        self.int_ior, self.ext_ior = ior(self.int_ior, "int_ior"), ior(self.ext_ior, "ext_ior")
        self.nonlinear = bool(self.nonlinear)


@dataclass
class RoughPlastic(Plastic):
    """A diffuse base under a rough (GGX or Beckmann) dielectric coating (Mitsuba's `roughplastic`)."""

    alpha: float = 0.1
    distribution: str = "ggx"

    def __post_init__(self):
        super().__post_init__()
        self.alpha = _alpha(self.alpha)
        if not isinstance(self.alpha, float):
            raise ValueError("a rough plastic's alpha cannot be a texture (its transmittance tables are per alpha)")
        self.distribution = _distribution(self.distribution)


@dataclass
class _Disney:
    """The inputs Mitsuba's principled and principledthin share, with its defaults (base_color and roughness first,
    as the reader passes them)."""

    base_color: np.ndarray | TextureValue = 0.5
    roughness: float | TextureValue = 0.5
    anisotropic: float | TextureValue = 0.0
    spec_trans: float | TextureValue = 0.0
    spec_tint: float | TextureValue = 0.0
    sheen: float | TextureValue = 0.0
    sheen_tint: float | TextureValue = 0.0

    def _check(self, kind: str, weights: tuple[str, ...]) -> None:
        """base_color a colour, roughness and the shared and named weights in [0, 1] (each a number or a
        texture); errors name the plugin and the parameter."""
        self.base_color = _albedo(self.base_color, f"{kind} base_color")
        for name in ("roughness", "anisotropic", "spec_trans", "spec_tint", "sheen", "sheen_tint") + weights:
            setattr(self, name, _fraction(getattr(self, name), f"{kind} {name}"))


@dataclass
class Principled(_Disney):
    """Mitsuba's `principled`: the Disney principled BSDF (a diffuse base with retro-reflection and sheen, a GGX
    specular lobe towards the base colour as `metallic` grows, rough transmission by `spec_trans`, a clearcoat).
    base_color, roughness and the eight weights from anisotropic to clearcoat_gloss may be textures (as in Mitsuba),
    else numbers in [0, 1]. The index is `eta`, else Mitsuba's 2 / (1 - sqrt(0.08 specular)) - 1 (specular 0.5: eta
    1.5), and the three rates weigh the lobes' sampling: numbers, as Mitsuba takes them."""

    metallic: float | TextureValue = 0.0
    clearcoat: float | TextureValue = 0.0
    clearcoat_gloss: float | TextureValue = 0.0
    specular: float = 0.5
    eta: float | None = None
    main_specular_sampling_rate: float = 1.0
    clearcoat_sampling_rate: float = 1.0
    diffuse_reflectance_sampling_rate: float = 1.0

    def __post_init__(self):
        self._check("principled", ("metallic", "clearcoat", "clearcoat_gloss"))
        self.specular = _number(self.specular, "principled specular")
        if not 0 <= self.specular < 12.5:
            raise ValueError(f"principled specular must be in [0, 12.5) (eta from it), got {self.specular!r}")
        if self.eta is not None:
            self.eta = ior(self.eta, "principled eta")
        _rates(self, ("main_specular_sampling_rate", "clearcoat_sampling_rate", "diffuse_reflectance_sampling_rate"))

    @property
    def relative_eta(self) -> float:
        """The index of refraction inside over outside."""
        if self.eta is not None:
            return self.eta
        return 2.0 / (1.0 - float(np.sqrt(0.08 * self.specular))) - 1.0


@dataclass
class PrincipledThin(_Disney):
    """Mitsuba's `principledthin`: the Disney BSDF of a thin two-sided sheet (leaves, paper, cloth): diffuse
    reflection with `flatness` towards a subsurface look, `diff_trans` passing diffusely, `spec_trans` passing as a
    rough glossy sheet. Every parameter but the four sampling rates may be a texture (as in Mitsuba), else a number
    (eta a positive index)."""

    flatness: float | TextureValue = 0.0
    diff_trans: float | TextureValue = 0.0
    eta: float | TextureValue = 1.5
    specular_reflectance_sampling_rate: float = 1.0
    specular_transmittance_sampling_rate: float = 1.0
    diffuse_reflectance_sampling_rate: float = 1.0
    diffuse_transmittance_sampling_rate: float = 1.0

    def __post_init__(self):
        self._check("principledthin", ("flatness",))
        self.diff_trans = _or_texture(self.diff_trans, _diff_trans, "principledthin diff_trans")
        self.eta = _or_texture(self.eta, ior, "principledthin eta")
        _rates(self, ("specular_reflectance_sampling_rate", "specular_transmittance_sampling_rate",
                      "diffuse_reflectance_sampling_rate", "diffuse_transmittance_sampling_rate"))


def _diff_trans(v, what: str) -> float:
    """principledthin's diff_trans: a number in [0, 2] (Mitsuba's range: its diffuse transmission is diff_trans / 2)."""
    x = _number(v, what)
    if not 0 <= x <= 2:
        raise ValueError(f"{what} must be in [0, 2], got {v!r}")
    return x


def _rates(bsdf, names: tuple[str, ...]) -> None:
    """Check a principled BSDF's lobe sampling rates: numbers, none negative, not all zero."""
    for name in names:
        x = _number(getattr(bsdf, name), name)
        if not x >= 0:
            raise ValueError(f"{name} must not be negative, got {x!r}")
        setattr(bsdf, name, x)
    if not any(getattr(bsdf, name) > 0 for name in names):
        raise ValueError(f"{type(bsdf).__name__.lower()} needs a sampling rate above zero")


@dataclass
class TwoSided:
    """The same BSDF on both sides of the surface."""

    bsdf: object

    def __post_init__(self):
        if isinstance(self.bsdf, (TwoSided, Dielectric)):
            raise ValueError(f"twosided cannot wrap a {type(self.bsdf).__name__}")


@dataclass
class Blend:
    """Mitsuba's `blendbsdf`: (1 - weight) bsdf0 + weight bsdf1, weight in [0, 1] a number or a texture."""

    bsdf0: object
    bsdf1: object
    weight: float = 0.5

    def __post_init__(self):
        for b in (self.bsdf0, self.bsdf1):
            if isinstance(b, (Blend, Mask, NormalMap, BumpMap)):
                raise ValueError(f"durer blends plain BSDFs (twosided or not), not a {type(b).__name__}")
        self.weight = _fraction(self.weight, "blend weight")


@dataclass
class Mask:
    """Mitsuba's `mask`: the surface is there with probability `opacity` (a number or a texture in [0, 1]); elsewhere
    the ray passes straight through (a delta lobe)."""

    bsdf: object
    opacity: float = 0.5

    def __post_init__(self):
        if isinstance(self.bsdf, Mask):
            raise ValueError("a mask cannot wrap another mask")
        self.opacity = _fraction(self.opacity, "mask opacity")


@dataclass
class NormalMap:
    """Mitsuba's `normalmap`: the shading frame's normal read from a raw RGB texture (2 rgb - 1, in the frame of the
    surface's tangent dp/du and shading normal). Mitsuba's two options, on by default as there:
    flip_invalid_normals mirrors a map normal on the other side of the viewer than the surface's normal about it, and
    use_shadowing_function dims the nested BSDF towards the terminator (Conty Estevez et al. 2019)."""

    bsdf: object
    normalmap: Bitmap
    flip_invalid_normals: bool = True
    use_shadowing_function: bool = True

    def __post_init__(self):
        if not isinstance(self.normalmap, (Bitmap, Checker)):
            raise ValueError("a normal map is a texture")
        _map_options(self)


@dataclass
class BumpMap:
    """Mitsuba's `bumpmap`: the shading frame tilted by the gradient of a height texture times `scale`."""

    bsdf: object
    texture: Bitmap
    scale: float = 1.0
    flip_invalid_normals: bool = True  # as NormalMap's
    use_shadowing_function: bool = True

    def __post_init__(self):
        if not isinstance(self.texture, (Bitmap, Checker)):
            raise ValueError("a bump map is a texture")
        self.scale = _number(self.scale, "bump map scale")
        _map_options(self)


def _map_options(m) -> None:
    for name in ("flip_invalid_normals", "use_shadowing_function"):
        if not isinstance(getattr(m, name), (bool, np.bool_)):
            raise ValueError(f"{name} must be true or false, got {getattr(m, name)!r}")
        setattr(m, name, bool(getattr(m, name)))


def _constant(v, what: str):
    if isinstance(v, (Bitmap, Checker)):
        raise ValueError(f"durer cannot texture {what} (a number or a colour here)")
    return v


def _fraction(v, what: str):
    return _or_texture(v, _unit_number, what)


def _unit_number(v, what: str) -> float:
    x = _number(v, what)
    if not 0 <= x <= 1:
        raise ValueError(f"{what} must be in [0, 1], got {v!r}")
    return x


BSDF = (Diffuse | Dielectric | ThinDielectric | RoughDielectric | Conductor | RoughConductor | Plastic | RoughPlastic
        | Principled | PrincipledThin | TwoSided | Blend | Mask | NormalMap | BumpMap)


@dataclass
class Surface:
    """What a shape's material index names under the path tracer: a BSDF (or a course PhongMaterial), the radiance
    it emits from its front side (None: not a light; a colour, or a Bitmap or Checker looked up at the surface's
    UV) and whether its normals are flipped (Mitsuba's flip_normals)."""

    bsdf: object
    radiance: np.ndarray | None = None
    flip_normals: bool = False

    def __post_init__(self):
        if self.radiance is not None:
            self.radiance = _albedo(self.radiance, "radiance")
        self.flip_normals = bool(self.flip_normals)
