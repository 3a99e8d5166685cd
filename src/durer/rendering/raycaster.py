"""The ray caster: what colour a camera ray brings back, from its closest hit alone.

`raycast` is the lecture's algorithm: eye rays only, the closest hit shaded from its normal, the lights and the
viewpoint (flat colour when the scene has no lights at all, as in assignment 1). The ray tracer, which adds
secondary rays, builds on the same RenderContext and the surface and shading steps here. (RenderContext and
SampleResult live in context.py; they are re-exported here for existing imports.)
"""

from __future__ import annotations

import numpy as np

from ..accel.compile import TRIANGLE, CompiledScene
from ..accel.hits import Hits, geometric_normals, hit_materials
from .context import RenderContext, SampleResult
from .shading import light_directions, phong
from .texturing import diffuse_colors, leaf_weights

__all__ = ["RenderContext", "SampleResult", "raycast", "shade_local", "surface"]  # the first two: context.py


def _triangle_attribute(hits: Hits, points: np.ndarray, at, fill: float, width: int) -> np.ndarray:
    """A per-corner mesh attribute interpolated at the triangle hits (`at(ids, points)`), `fill` elsewhere."""
    out = np.full((len(points), width), fill)
    m = hits.kind == TRIANGLE
    if m.any():
        out[m] = at(hits.prim[m], points[m])
    return out


def hit_uv(ctx: RenderContext, hits: Hits, points: np.ndarray) -> np.ndarray | None:
    """Texture coordinates (N,2) at the hits (zeros elsewhere), or None when no material needs them."""
    return _triangle_attribute(hits, points, ctx.compiled.uv_at, 0.0, 2) if ctx.textured else None


def hit_tint(ctx: RenderContext, hits: Hits, points: np.ndarray) -> np.ndarray | None:
    """Interpolated vertex colours (N,3) at the hits (ones elsewhere), or None when no mesh has colours."""
    return _triangle_attribute(hits, points, ctx.compiled.colors_at, 1.0, 3) if ctx.compiled.has_colors else None


def surface(ctx: RenderContext, origins: np.ndarray, directions: np.ndarray, hits: Hits):
    """Hit points, normals and material ids of the hits (rows where hits.hit). The normals are geometric, or
    interpolated from the vertex normals of meshes that have them (smooth_normals)."""
    t = np.where(hits.hit, hits.t, 0.0)
    points = origins + t[:, None] * directions
    normals = geometric_normals(ctx.compiled, hits, points)
    if ctx.compiled.has_normals:
        normals = smooth_normals(ctx.compiled, hits, points, directions, normals)
    return points, normals, hit_materials(ctx.compiled, hits)


def smooth_normals(cs: CompiledScene, hits: Hits, points, directions, geometric: np.ndarray) -> np.ndarray:
    """Shading normals: the interpolated vertex normals where a mesh has them, turned to the geometric normal's
    side, and bent just enough that the ray meets them from the same side as the surface itself (else a smooth
    normal near a silhouette would make a front face look like a back face)."""
    m = hits.kind == TRIANGLE
    if not m.any():
        return geometric
    g = geometric[m]
    n = cs.normals_at(hits.prim[m], points[m])
    have = np.linalg.norm(n, axis=1) > 0
    n = np.where(have[:, None], n, g)
    n *= np.where(np.einsum("ij,ij->i", n, g) < 0, -1.0, 1.0)[:, None]
    d = directions[m] / np.linalg.norm(directions[m], axis=1, keepdims=True)
    dn, dg = np.einsum("ij,ij->i", d, n), np.einsum("ij,ij->i", d, g)
    flip = np.sign(dn) != np.sign(dg)
    if flip.any():
        n[flip] -= 1.01 * dn[flip, None] * d[flip]
        n[flip] /= np.linalg.norm(n[flip], axis=1, keepdims=True)
    out = geometric.copy()
    out[m] = n
    return out


def raycast(ctx: RenderContext, origins: np.ndarray, directions: np.ndarray, t_min: float,
            pixel: np.ndarray | None = None, sample: np.ndarray | None = None) -> SampleResult:
    """Eye rays only: background on a miss; flat colour or ambient + diffuse + specular on a hit (no random
    numbers: pixel and sample, the integrators' common signature, are not needed)."""
    b = ctx.bundle
    hits = ctx.accel.closest_hit(origins, directions, t_min=t_min)
    n = len(origins)
    color = np.broadcast_to(b.background, (n, 3)).copy()
    points, normals, mat = surface(ctx, origins, directions, hits)
    m = hits.hit
    uv, tint = hit_uv(ctx, hits, points), hit_tint(ctx, hits, points)
    uv, tint = (None if a is None else a[m] for a in (uv, tint))
    albedo = np.zeros((n, 3)) if ctx.options.aovs or ctx.options.denoise else None
    if b.lights is None:  # assignment 1: the object's own colour (blended through any solid textures)
        flat = np.zeros((int(m.sum()), 3))
        for leaf, weight in leaf_weights(b.materials, mat[m], points[m]):
            flat += weight[:, None] * diffuse_colors(b.materials, b.phong.diffuse, leaf, uv, tint)
        color[m] = flat
        if albedo is not None:
            albedo[m] = np.clip(flat, 0.0, 1.0)
    elif m.any():
        color[m] = shade_local(ctx, points[m], normals[m], directions[m], mat[m], uv=uv, tint=tint)
        if albedo is not None:
            albedo[m] = hit_reflectance(ctx, mat[m], points[m], uv, tint)[0]
            if not ctx.options.shade_back:  # back faces are black, and so is their albedo
                albedo[m & (np.einsum("ij,ij->i", directions, normals) > 0)] = 0.0
    if albedo is None:
        return SampleResult(color, hits.t, normals)
    return SampleResult(color, hits.t, normals, albedo=albedo, shading_normal=normals)


def hit_reflectance(ctx: RenderContext, mat: np.ndarray, points: np.ndarray, uv: np.ndarray | None,
                    tint: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The denoiser's albedo of course materials at hits (issue 24): the sum of the material's colours kd
    (textured and tinted) + ks + kr + kt, blended through solid textures and clamped to [0, 1], and whether the
    surface has a lobe that is not a perfect mirror or refraction (kd or ks), where the integrators stop following
    mirror and refraction rays for it. The path tracer's PHONG albedo (kernels/path/bsdf.bsdf_albedo) is the same
    sum."""
    table, materials = ctx.bundle.phong, ctx.bundle.materials
    reflectance = np.zeros((len(mat), 3))
    smooth = np.zeros(len(mat), bool)
    for leaf, weight in leaf_weights(materials, mat, points):
        kd = diffuse_colors(materials, table.diffuse, leaf, uv, tint)
        ks = table.specular[leaf]
        reflectance += weight[:, None] * (kd + ks + table.reflective[leaf] + table.transparent[leaf])
        smooth |= (weight > 0) & ((kd.max(axis=1) > 0) | (ks.max(axis=1) > 0))
    return np.clip(reflectance, 0.0, 1.0), smooth


def shade_local(ctx: RenderContext, points, normals, directions, mat, light_visible=None, uv=None,
                tint=None) -> np.ndarray:
    """Ambient + each light's diffuse and specular term at the hits.

    A back face (the ray arrives from the side the normal points away from) is flipped and lit when
    shade_back is on; otherwise it is black, as the course's reference images show it.
    `light_visible`, if given, is a list of (N,) masks, one per light (shadow rays).
    Solid textures shade each Phong material they blend and sum the results with the texture's weights
    (the handout's UPDATE 11/2: interpolate the shaded colours, ambient term included).
    `uv` (N,2), if given, looks up image textures and `tint` (N,3), if given, multiplies the diffuse colour
    (vertex colours; texturing.diffuse_colors); PBR materials add their emission.
    """
    b = ctx.bundle
    table = b.phong
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    back = np.einsum("ij,ij->i", d, normals) > 0
    normals = np.where(back[:, None], -normals, normals)
    lights = [light_directions(light, points) for light in b.lights]
    color = np.zeros((len(points), 3))
    for leaf, weight in leaf_weights(b.materials, mat, points):
        kd = diffuse_colors(b.materials, table.diffuse, leaf, uv, tint)
        ks, e = table.specular[leaf], table.exponent[leaf]
        shaded = b.ambient * kd
        if table.emission is not None:
            shaded = shaded + table.emission[leaf]
        for i, (to_light, light_color, _) in enumerate(lights):
            contribution = phong(normals, -d, to_light, light_color, kd, ks, e)
            if light_visible is not None:
                contribution = contribution * light_visible[i][:, None]
            shaded = shaded + contribution
        color += weight[:, None] * shaded
    if not ctx.options.shade_back:
        color[back] = 0.0
    return color
