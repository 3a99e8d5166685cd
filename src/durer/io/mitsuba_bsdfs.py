"""Mitsuba 3 BSDF plugins -> scene/bsdfs.py descriptions, and the parameters that Mitsuba lets be a texture
(a colour or a number given as <rgb>, <spectrum>, <float>, or a nested or referenced <texture>)."""

from __future__ import annotations

from ..scene import bsdfs as B
from .mitsuba_tree import Props, call

BSDFS = ("diffuse", "dielectric", "conductor", "roughconductor", "plastic", "roughplastic", "twosided")


def _texture(builder, node, name: str):
    """A nested or referenced plugin given for parameter `name`: a texture, which durer does not render yet."""
    for child in node.children:
        if child.name == name:
            target = builder.resolve(child)
            if target.tag != "texture":
                raise child.error(f"{name} of {node.tag} '{node.type}' must be a colour or a texture, not a "
                                  f"<{target.tag}>")
            raise target.error(f"unsupported texture '{target.type}' for {name} of {node.tag} '{node.type}' "
                               "(durer's path tracer has no textures yet)")


def colour(builder, node, p: Props, name: str, default):
    """A colour parameter (a number, rgb or spectrum); a texture in its place is a SceneError."""
    _texture(builder, node, name)
    return p.get(name, default, "colour")


def scalar(builder, node, p: Props, name: str, default):
    """A number parameter that Mitsuba accepts as a texture (roughness alpha)."""
    _texture(builder, node, name)
    return p.get(name, default, float)


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


def _bsdf(builder, node, depth: int):
    p = Props(node)
    t = node.type
    if t not in BSDFS:
        raise node.error(f"unsupported bsdf '{t}' (durer renders {', '.join(BSDFS)})")
    rough = t in ("roughconductor", "roughplastic")
    if rough:
        dist = p.get("distribution", "beckmann", str)
        if dist != "ggx":
            raise node.error(f"{t}: only distribution 'ggx' is supported (Mitsuba's default is beckmann; "
                             "set it explicitly)", p.where("distribution"))
        if not p.get("sample_visible", True, bool):
            raise node.error(f"{t}: sample_visible must be true")
        alpha = scalar(builder, node, p, "alpha", 0.1)
    if t == "diffuse":
        out = call(node, B.Diffuse, colour(builder, node, p, "reflectance", 0.5))
    elif t == "dielectric":
        out = call(node, B.Dielectric, p.get("int_ior", 1.5046, "ior"), p.get("ext_ior", 1.000277, "ior"),
                   colour(builder, node, p, "specular_reflectance", 1.0),
                   colour(builder, node, p, "specular_transmittance", 1.0))
    elif t in ("conductor", "roughconductor"):
        material = p.get("material", None, str)
        eta, k = colour(builder, node, p, "eta", None), colour(builder, node, p, "k", None)
        kw = dict(specular_reflectance=colour(builder, node, p, "specular_reflectance", 1.0))
        if t == "roughconductor":
            kw.update(alpha_u=scalar(builder, node, p, "alpha_u", alpha),
                      alpha_v=scalar(builder, node, p, "alpha_v", alpha))
        cls = B.RoughConductor if t == "roughconductor" else B.Conductor
        if material is not None and (eta is not None or k is not None):
            raise node.error(f"{t}: give either material or eta and k")
        if eta is None and k is None:
            out = call(node, cls.named, material or "none", **kw)
        else:
            out = call(node, cls, 0.0 if eta is None else eta, 1.0 if k is None else k, **kw)
    elif t in ("plastic", "roughplastic"):
        args = (colour(builder, node, p, "diffuse_reflectance", 0.5),
                colour(builder, node, p, "specular_reflectance", 1.0),
                p.get("int_ior", 1.49, "ior"), p.get("ext_ior", 1.000277, "ior"), p.get("nonlinear", False, bool))
        out = call(node, B.RoughPlastic, *args, alpha) if rough else call(node, B.Plastic, *args)
    else:  # twosided
        if len(node.children) != 1:
            raise node.error("twosided needs exactly one nested bsdf (durer has no different back side)")
        out = call(node, B.TwoSided, build_bsdf(builder, node.children[0], depth + 1))
    if t != "twosided" and node.children:
        raise node.children[0].error(f"<{node.children[0].tag}> cannot appear in bsdf '{t}'")
    p.done()
    return out
