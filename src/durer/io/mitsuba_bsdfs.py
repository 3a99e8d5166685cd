"""Mitsuba 3 BSDF plugins -> scene/bsdfs.py descriptions, and the parameters that Mitsuba lets be a texture
(a colour or a number given as <rgb>, <spectrum>, <float>, or a nested or referenced <texture>).

A `checkerboard` texture on one parameter of a BSDF becomes `Checkered`: the BSDF built twice, with color0 and
with color1, which the shape turns into a UVCheckerboard blend of the two (scene/textures.py). Other textures are
a SceneError naming them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import bsdfs as B
from .mitsuba_tree import Node, Props, call

BSDFS = ("diffuse", "dielectric", "thindielectric", "roughdielectric", "conductor", "roughconductor", "plastic",
         "roughplastic", "twosided")


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
    """A number parameter that Mitsuba accepts as a texture (roughness alpha, which Mitsuba's microfacet
    distributions raise to at least 1e-4)."""
    _texture(builder, node, name)
    x = p.get(name, default, float)
    return max(x, 1e-4) if name.startswith("alpha") and x >= 0 else x


@dataclass
class Checkered:
    """A BSDF with a checkerboard on one parameter: the BSDF with color0 (bsdf0) and with color1 (bsdf1), and the
    checkerboard's to_uv (3x3)."""

    bsdf0: object
    bsdf1: object
    to_uv: np.ndarray


def build_bsdf(builder, node, depth: int = 0):
    """A BSDF description or a Checkered pair (a ref resolved); each node is built once so shared refs share it."""
    node = builder.resolve(node)
    if node.tag != "bsdf":
        raise node.error(f"expected a bsdf, found <{node.tag}>")
    cached = getattr(node, "_built", None)
    if cached is not None:
        return cached
    builder.enter(node, depth)
    textured = [c for c in node.children if c.name is not None and builder.resolve(c).tag == "texture"]
    if not textured:
        out = _bsdf(builder, node, depth)
    else:
        if len(textured) > 1:
            raise textured[1].error(f"bsdf '{node.type}': durer renders one textured parameter per bsdf")
        child = textured[0]
        to_uv, colours = _checkerboard(builder, builder.resolve(child), child.name, node)
        rest = [c for c in node.children if c is not child]
        variants = [_bsdf(builder, Node(node.tag, node.type, node.where, None, node.name,
                                        {**node.props, child.name: (c, child.where)}, rest), depth)
                    for c in colours]
        out = Checkered(variants[0], variants[1], to_uv)
    builder.leave(node)
    node._built = out
    return out


def _checkerboard(builder, tex, name: str, bsdf) -> tuple[np.ndarray, list]:
    """A checkerboard texture's to_uv (the 2D affine part of its 4x4) and its two values for parameter `name`."""
    if tex.type != "checkerboard":
        raise tex.error(f"unsupported texture '{tex.type}' for {name} of bsdf '{bsdf.type}' (durer renders "
                        "checkerboard textures)")
    p = Props(tex)
    colours = [colour(builder, tex, p, "color0", 0.4), colour(builder, tex, p, "color1", 0.2)]
    m = p.get("to_uv", np.eye(4), "matrix")
    p.done()
    if tex.children:
        raise tex.children[0].error(f"<{tex.children[0].tag}> cannot appear in a checkerboard")
    if name in ("alpha", "alpha_u", "alpha_v"):  # a number: the texture must be grey
        if any(not np.allclose(c, c.flat[0]) for c in colours):
            raise tex.error(f"{name} takes a grey checkerboard (one number per colour)")
        colours = [float(c.flat[0]) for c in colours]
    return m[np.ix_([0, 1, 3], [0, 1, 3])], colours


def _bsdf(builder, node, depth: int):
    p = Props(node)
    t = node.type
    if t not in BSDFS:
        raise node.error(f"unsupported bsdf '{t}' (durer renders {', '.join(BSDFS)})")
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
    elif t in ("plastic", "roughplastic"):
        args = (colour(builder, node, p, "diffuse_reflectance", 0.5),
                colour(builder, node, p, "specular_reflectance", 1.0),
                p.get("int_ior", 1.49, "ior"), p.get("ext_ior", 1.000277, "ior"), p.get("nonlinear", False, bool))
        out = call(node, B.RoughPlastic, *args, alpha, dist) if rough else call(node, B.Plastic, *args)
    else:  # twosided
        if len(node.children) != 1:
            raise node.error("twosided needs exactly one nested bsdf (durer has no different back side)")
        inner = build_bsdf(builder, node.children[0], depth + 1)
        if isinstance(inner, Checkered):
            out = Checkered(call(node, B.TwoSided, inner.bsdf0), call(node, B.TwoSided, inner.bsdf1), inner.to_uv)
        else:
            out = call(node, B.TwoSided, inner)
    if t != "twosided" and node.children:
        raise node.children[0].error(f"<{node.children[0].tag}> cannot appear in bsdf '{t}'")
    p.done()
    return out
