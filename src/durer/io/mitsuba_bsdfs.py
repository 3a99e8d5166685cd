"""Mitsuba 3 BSDF and texture plugins -> scene/bsdfs.py and scene/textures.py descriptions, and the parameters that
Mitsuba lets be a texture (a colour or a number given as <rgb>, <spectrum>, <float>, or a nested or referenced
<texture>: `bitmap` or `checkerboard`, which the path tracer looks up per hit)."""

from __future__ import annotations

import numpy as np

from ..scene import bsdfs as B
from ..scene.textures import Bitmap, Checker
from .images import read_texture
from .mitsuba_tree import Props, call

BSDFS = ("diffuse", "dielectric", "thindielectric", "roughdielectric", "conductor", "roughconductor", "plastic",
         "roughplastic", "principled", "principledthin", "twosided", "blendbsdf", "mask", "normalmap", "bumpmap")
# the principled BSDFs' number parameters and their defaults: those Mitsuba 3 takes as a texture (measured with
# mi.load_dict: a checkerboard on each loads) and those it takes as a number only (principled's specular and eta, the
# sampling rates), as durer does
PRINCIPLED_TEXTURED = {"anisotropic": 0.0, "metallic": 0.0, "spec_trans": 0.0, "spec_tint": 0.0, "sheen": 0.0,
                       "sheen_tint": 0.0, "clearcoat": 0.0, "clearcoat_gloss": 0.0}
PRINCIPLED_NUMBERS = {"specular": 0.5, "main_specular_sampling_rate": 1.0, "clearcoat_sampling_rate": 1.0,
                      "diffuse_reflectance_sampling_rate": 1.0}
THIN_TEXTURED = {"anisotropic": 0.0, "spec_trans": 0.0, "spec_tint": 0.0, "sheen": 0.0, "sheen_tint": 0.0,
                 "flatness": 0.0, "diff_trans": 0.0, "eta": 1.5}
THIN_NUMBERS = {"specular_reflectance_sampling_rate": 1.0, "specular_transmittance_sampling_rate": 1.0,
                "diffuse_reflectance_sampling_rate": 1.0, "diffuse_transmittance_sampling_rate": 1.0}
TEXTURES = ("bitmap", "checkerboard")


def _texture(builder, node, name: str):
    """The texture given for parameter `name` as a nested or referenced plugin, or None."""
    for child in node.children:
        if child.name == name:
            target = builder.resolve(child)
            if target.tag != "texture":
                raise child.error(f"{name} of {node.tag} '{node.type}' must be a colour or a texture, not a "
                                  f"<{target.tag}>")
            child.used = True
            return build_texture(builder, target)
    return None


def colour(builder, node, p: Props, name: str, default):
    """A colour parameter: a number, rgb or spectrum, or a texture."""
    tex = _texture(builder, node, name)
    return tex if tex is not None else p.get(name, default, "colour")


def scalar(builder, node, p: Props, name: str, default):
    """A number parameter that Mitsuba accepts as a texture (roughness alpha, which Mitsuba's microfacet
    distributions raise to at least 1e-4; a blend's weight; a mask's opacity)."""
    tex = _texture(builder, node, name)
    if tex is not None:
        return tex
    x = p.get(name, default, float)
    if isinstance(x, (Bitmap, Checker)):  # alpha_u and alpha_v default to a textured alpha
        return x
    return max(x, 1e-4) if name.startswith("alpha") and x >= 0 else x


def build_texture(builder, node):
    """A Bitmap or Checker for a texture plugin (built once, so references share it)."""
    cached = getattr(node, "_built", None)
    if cached is not None:
        return cached
    p = Props(node)
    m = p.get("to_uv", np.eye(4), "matrix")
    to_uv = m[np.ix_([0, 1, 3], [0, 1, 3])]
    if node.type == "checkerboard":
        out = call(node, Checker, colour(builder, node, p, "color0", 0.4), colour(builder, node, p, "color1", 0.2),
                   to_uv)
        if isinstance(out.color0, (Bitmap, Checker)) or isinstance(out.color1, (Bitmap, Checker)):
            raise node.error("durer's checkerboard takes constant colours")
    elif node.type == "bitmap":
        filename = p.get("filename", None, str)
        if not filename:
            raise node.error("bitmap needs a filename")
        path = builder.file(node, filename, p.where("filename"), "texture image")
        raw = p.get("raw", False, bool)
        try:
            image = read_texture(path, raw)
        except ValueError as e:
            raise node.error(str(e), p.where("filename")) from None
        out = call(node, Bitmap, image, p.get("filter_type", "bilinear", str), p.get("wrap_mode", "repeat", str), to_uv)
        p.get("format", None, str)  # Mitsuba's storage precision (float16/32): durer keeps float32
    else:
        raise node.error(f"unsupported texture '{node.type}' (durer reads {', '.join(TEXTURES)})")
    p.done()
    if node.children and node.type == "bitmap":
        raise node.children[0].error(f"<{node.children[0].tag}> cannot appear in a bitmap")
    for child in node.children:
        if child.name not in ("color0", "color1"):
            raise child.error(f"<{child.tag}> cannot appear in a checkerboard")
    node._built = out
    return out


def textured(bsdf) -> bool:
    """Does a BSDF description (or a Surface) read a texture, so that its shape needs texture coordinates?"""
    if isinstance(bsdf, (Bitmap, Checker)):
        return True
    fields = getattr(bsdf, "__dataclass_fields__", None)
    return fields is not None and any(textured(getattr(bsdf, f)) for f in fields)


def build_bsdf(builder, node, depth: int = 0):
    """A BSDF description (a ref resolved); each node is built once so shared refs share it."""
    node = builder.resolve(node)
    if node.tag != "bsdf":
        raise node.error(f"expected a bsdf, found <{node.tag}>")
    cached = getattr(node, "_built", None)
    if cached is not None:
        return cached
    builder.enter(node, depth)
    out = _bsdf(builder, node, depth)
    builder.leave(node)
    node._built = out
    return out


def _nested(builder, node, depth: int, count: int) -> list:
    """The `count` BSDFs nested in a wrapper plugin (its textures are named parameters, not nested BSDFs)."""
    inner = [c for c in node.children if builder.resolve(c).tag == "bsdf"]
    if len(inner) != count:
        raise node.error(f"{node.type} needs exactly {'one nested bsdf' if count == 1 else 'two nested bsdfs'}")
    for c in node.children:
        if c not in inner and (builder.resolve(c).tag != "texture" or not getattr(c, "used", True)):
            raise c.error(f"<{c.tag}> cannot appear in bsdf '{node.type}'")
    return [build_bsdf(builder, c, depth + 1) for c in inner]


def _map_options(p: Props) -> dict:
    """normalmap's and bumpmap's two booleans, true by default as in Mitsuba 3."""
    return {name: p.get(name, True, bool) for name in ("flip_invalid_normals", "use_shadowing_function")}


def _wrapper(builder, node, p: Props, depth: int):
    """blendbsdf, mask, normalmap, bumpmap and twosided: plugins around nested BSDFs."""
    t = node.type
    if t == "blendbsdf":
        weight = scalar(builder, node, p, "weight", 0.5)
        return call(node, B.Blend, *_nested(builder, node, depth, 2), weight)
    if t == "mask":
        opacity = scalar(builder, node, p, "opacity", 0.5)
        return call(node, B.Mask, _nested(builder, node, depth, 1)[0], opacity)
    if t == "normalmap":
        tex = _texture(builder, node, "normalmap")
        if tex is None:
            raise node.error("normalmap needs a texture named normalmap")
        return call(node, B.NormalMap, _nested(builder, node, depth, 1)[0], tex, **_map_options(p))
    if t == "bumpmap":
        tex = next((build_texture(builder, builder.resolve(c)) for c in node.children
                    if builder.resolve(c).tag == "texture"), None)
        if tex is None:
            raise node.error("bumpmap needs a nested texture")
        return call(node, B.BumpMap, _nested(builder, node, depth, 1)[0], tex, p.get("scale", 1.0, float),
                    **_map_options(p))
    inner = _nested(builder, node, depth, 1)  # twosided
    if len(node.children) != 1:
        raise node.error("twosided needs exactly one nested bsdf (durer has no different back side)")
    return call(node, B.TwoSided, inner[0])


def _principled(builder, node, p: Props):
    """Mitsuba's principled and principledthin: base_color a colour or a texture, every parameter Mitsuba takes as a
    texture a number or a texture, the rest numbers; principled's eta or specular, not both (as Mitsuba)."""
    thin = node.type == "principledthin"
    numbers = THIN_NUMBERS if thin else {**PRINCIPLED_NUMBERS, "eta": None}
    for c in node.children:
        if c.name in numbers:
            raise c.error(f"{node.type}'s {c.name} is a number, not a texture (as in Mitsuba)")
    if not thin and "eta" in node.props and "specular" in node.props:
        raise node.error("principled: give eta or specular, not both (as Mitsuba)", p.where("specular"))
    kw = {name: p.get(name, default, float) for name, default in numbers.items()}
    kw.update({name: scalar(builder, node, p, name, default)
               for name, default in (THIN_TEXTURED if thin else PRINCIPLED_TEXTURED).items()})
    return call(node, B.PrincipledThin if thin else B.Principled, colour(builder, node, p, "base_color", 0.5),
                scalar(builder, node, p, "roughness", 0.5), **kw)


def _bsdf(builder, node, depth: int):
    p = Props(node)
    t = node.type
    if t not in BSDFS:
        raise node.error(f"unsupported bsdf '{t}' (durer renders {', '.join(BSDFS)})")
    if t in ("twosided", "blendbsdf", "mask", "normalmap", "bumpmap"):
        out = _wrapper(builder, node, p, depth)
        p.done()
        return out
    rough = t in ("roughconductor", "roughplastic", "roughdielectric")
    if rough:
        dist = p.get("distribution", "beckmann", str)
        if dist not in ("ggx", "beckmann"):
            raise node.error(f"{t}: unknown distribution '{dist}' (use beckmann or ggx)", p.where("distribution"))
        if not p.get("sample_visible", True, bool):
            raise node.error(f"{t}: sample_visible must be true")
        alpha = scalar(builder, node, p, "alpha", 0.1)
    if t == "diffuse":
        out = call(node, B.Diffuse, colour(builder, node, p, "reflectance", 0.5))
    elif t in ("dielectric", "thindielectric", "roughdielectric"):
        args = (p.get("int_ior", 1.5046, "ior"), p.get("ext_ior", 1.000277, "ior"),
                colour(builder, node, p, "specular_reflectance", 1.0),
                colour(builder, node, p, "specular_transmittance", 1.0))
        if rough:
            out = call(node, B.RoughDielectric, *args, scalar(builder, node, p, "alpha_u", alpha),
                       scalar(builder, node, p, "alpha_v", alpha), dist)
        else:
            out = call(node, B.ThinDielectric if t == "thindielectric" else B.Dielectric, *args)
    elif t in ("conductor", "roughconductor"):
        material = p.get("material", None, str)
        eta, k = colour(builder, node, p, "eta", None), colour(builder, node, p, "k", None)
        kw = dict(specular_reflectance=colour(builder, node, p, "specular_reflectance", 1.0))
        if t == "roughconductor":
            kw.update(alpha_u=scalar(builder, node, p, "alpha_u", alpha),
                      alpha_v=scalar(builder, node, p, "alpha_v", alpha), distribution=dist)
        cls = B.RoughConductor if t == "roughconductor" else B.Conductor
        if material is not None and (eta is not None or k is not None):
            raise node.error(f"{t}: give either material or eta and k")
        if eta is None and k is None:
            out = call(node, cls.named, material or "none", **kw)
        else:
            out = call(node, cls, 0.0 if eta is None else eta, 1.0 if k is None else k, **kw)
    elif t in ("principled", "principledthin"):
        out = _principled(builder, node, p)
    elif t in ("plastic", "roughplastic"):
        args = (colour(builder, node, p, "diffuse_reflectance", 0.5),
                colour(builder, node, p, "specular_reflectance", 1.0),
                p.get("int_ior", 1.49, "ior"), p.get("ext_ior", 1.000277, "ior"), p.get("nonlinear", False, bool))
        out = call(node, B.RoughPlastic, *args, alpha, dist) if rough else call(node, B.Plastic, *args)
    for c in node.children:
        if builder.resolve(c).tag != "texture" or not getattr(c, "used", False):
            raise c.error(f"<{c.tag}> '{c.name}' cannot appear in bsdf '{t}'")
    p.done()
    return out
