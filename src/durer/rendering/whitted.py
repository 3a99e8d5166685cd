"""Whitted ray tracing (MIT 6.837 assignment 4): shadow rays, mirror reflection and refraction.

The course's `traceRay` is recursive: shade the closest hit locally (ambient + every light whose shadow ray is
unblocked), then add `reflectiveColor * traceRay(mirror ray)` and `transparentColor * traceRay(refracted ray)`,
stopping after `-bounces` levels or when a ray's weight falls below `-weight`. Here the recursion runs as a
wavefront instead: every bounce level is one batch of rays, each carrying the pixel (row of the chunk) it
contributes to and its RGB throughput (the product of the reflective/transparent colours along its path). Each
level's local shading is multiplied by the throughput and added into its pixels with `np.add.at`, so no Python
loop ever runs over rays.

Self-intersection: secondary and shadow rays start exactly at the hit point and ignore hits closer than
`RAY_EPSILON` (all their directions are unit length, so this is a distance in world units), the course's
"set tmin as epsilon". A shadow ray towards a point light also stops `RAY_EPSILON` short of the light.
"""

from __future__ import annotations

import numpy as np

from .context import RenderContext, SampleResult
from .raycaster import hit_reflectance, hit_tint, hit_uv, raycast, shade_local, surface
from .shading import light_directions
from .texturing import leaf_weights

RAY_EPSILON = 1e-4
"""Distance (world units) that secondary and shadow rays skip before counting a hit, against self-intersection."""

CRITICAL_TOLERANCE = 1e-12
"""Rounding slack at the critical angle: sin^2 of the refracted angle up to 1 + this is still a (grazing)
transmission, so the critical angle itself transmits and only steeper angles reflect totally."""


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def mirror_direction(normals: np.ndarray, incoming: np.ndarray) -> np.ndarray:
    """Mirror reflection of unit `incoming` directions about unit `normals` (either side): d - 2 (d.N) N."""
    return incoming - 2.0 * _dot(incoming, normals)[:, None] * normals


def transmitted_direction(normals: np.ndarray, incoming: np.ndarray, index_i: np.ndarray | float,
                          index_t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Refracted directions by Snell's law, and a mask of the rays that refract (False: total internal reflection).

    `normals` are unit and face the incoming side (incoming . N <= 0), `incoming` is unit, and the ray passes from
    index `index_i` into `index_t`. With eta = index_i / index_t and cos_i = -incoming . N:
    T = eta * incoming + (eta * cos_i - sqrt(1 - eta^2 (1 - cos_i^2))) * N, unit length. Where the root's
    argument is negative the light is totally reflected; those rows of T are zero.
    """
    eta = np.broadcast_to(np.asarray(index_i, dtype=np.float64) / np.asarray(index_t, dtype=np.float64),
                          (len(incoming),))
    cos_i = -_dot(incoming, normals)
    k = 1.0 - eta * eta * (1.0 - cos_i * cos_i)
    ok = k >= -CRITICAL_TOLERANCE
    root = np.sqrt(np.maximum(k, 0.0))
    t = eta[:, None] * incoming + (eta * cos_i - root)[:, None] * normals
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    t[~ok] = 0.0
    return t, ok


def shadow_visibility(ctx: RenderContext, points: np.ndarray, normals: np.ndarray) -> list[np.ndarray]:
    """For each light, a mask of the points it reaches: no object between the point and the light (a point
    light's segment ends at the light). Every object casts an opaque shadow, transparent ones included, as in
    the course. Points facing away from a light get no shadow ray: that light adds nothing there anyway."""
    visible = []
    for light in ctx.bundle.lights:
        to_light, _, dist = light_directions(light, points)
        mask = _dot(normals, to_light) > 0
        seen = np.zeros(len(points), dtype=bool)
        if mask.any():
            t_max = np.maximum(dist[mask] - RAY_EPSILON, RAY_EPSILON)
            seen[mask] = ~ctx.accel.any_hit(points[mask], np.ascontiguousarray(to_light[mask]), RAY_EPSILON, t_max)
        visible.append(seen)
    return visible


def secondary_coefficients(ctx: RenderContext, mat: np.ndarray,
                           points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """reflectiveColor (N,3), transparentColor (N,3) and indexOfRefraction (N,) at the hits.

    Solid-texture materials (assignment 6) blend their leaf materials with the same weights as local shading,
    through `texturing.leaf_weights`; plain Phong materials are their own single leaf.
    """
    table = ctx.materials
    reflective = np.zeros((len(mat), 3))
    transparent = np.zeros((len(mat), 3))
    ior = np.zeros(len(mat))
    for leaf, weight in leaf_weights(ctx.bundle.materials, mat, points):
        reflective += weight[:, None] * table.reflective[leaf]
        transparent += weight[:, None] * table.transparent[leaf]
        ior += weight * table.ior[leaf]
    return reflective, transparent, ior


def whitted(ctx: RenderContext, origins: np.ndarray, directions: np.ndarray, t_min: float,
            pixel: np.ndarray | None = None, sample: np.ndarray | None = None) -> SampleResult:
    """Trace camera rays with shadows (if ctx.options.shadows), reflection and refraction up to
    ctx.options.bounces levels; returns linear colour and the camera rays' closest t and normal (deterministic:
    pixel and sample, the integrators' common signature, are not needed).

    A scene without a Lights block is drawn in flat colour (assignment 1): with no lights there is nothing to cast
    shadow rays to and no shading to reflect, so it is the ray caster's image."""
    if ctx.bundle.lights is None:
        return raycast(ctx, origins, directions, t_min)
    opts = ctx.options
    n = len(origins)
    color = np.zeros((n, 3))
    background = ctx.bundle.background
    first_t = np.full(n, np.inf)
    first_normal = np.zeros((n, 3))

    # One wavefront: ray origins and unit directions, their t_min, pixel row, RGB throughput and scalar weight.
    ray_o = np.asarray(origins, dtype=np.float64)
    ray_d = np.asarray(directions, dtype=np.float64)
    ray_d = ray_d / np.linalg.norm(ray_d, axis=1, keepdims=True)
    ray_tmin: float | np.ndarray = t_min
    pixel = np.arange(n)
    throughput = np.ones((n, 3))
    weight = np.ones(n)
    # the denoiser's features (issue 24): albedo and normal of the first surface with a kd or ks lobe along each
    # branch, seen through mirrors and refraction with the branch's throughput; `seek`: the ray is still looking
    features = (np.zeros((n, 3)), np.zeros((n, 3))) if opts.aovs or opts.denoise else None
    seek = np.ones(n, dtype=bool)

    for level in range(opts.bounces + 1):
        if len(ray_o) == 0:
            break
        hits = ctx.accel.closest_hit(ray_o, ray_d, ray_tmin)
        points, geo_normals, mat = surface(ctx, ray_o, ray_d, hits)
        if level == 0:
            first_t, first_normal = hits.t, geo_normals
        hit = hits.hit
        miss = ~hit
        if miss.any():
            np.add.at(color, pixel[miss], throughput[miss] * background)
        if not hit.any():
            break
        sel = np.flatnonzero(hit)
        p, d, m = points[sel], ray_d[sel], mat[sel]
        cos = _dot(d, geo_normals[sel])
        back = cos > 0
        facing = np.where(back[:, None], -geo_normals[sel], geo_normals[sel])  # normal on the ray's side
        visible = shadow_visibility(ctx, p, facing) if opts.shadows else None
        uv, tint = (None if a is None else a[sel] for a in (hit_uv(ctx, hits, points), hit_tint(ctx, hits, points)))
        local = shade_local(ctx, p, geo_normals[sel], d, m, light_visible=visible, uv=uv, tint=tint)
        np.add.at(color, pixel[sel], throughput[sel] * local)
        if features is not None:
            seek[sel] &= ~_record_features(ctx, features, pixel[sel], throughput[sel], seek[sel], p, m, uv, tint,
                                           geo_normals[sel], back)
        if level == opts.bounces:
            break

        # Secondary rays. Without -shade_back a back face is black, and so is everything seen through it.
        alive = np.ones(len(sel), dtype=bool) if opts.shade_back else ~back
        reflective, transparent, ior = secondary_coefficients(ctx, m, p)
        new_o, new_d, new_pix, new_tp, new_w, new_seek = [], [], [], [], [], []

        w_refl = weight[sel] * np.linalg.norm(reflective, axis=1)
        r = alive & np.any(reflective > 0, axis=1) & (w_refl >= opts.weight)
        if r.any():
            new_o.append(p[r])
            new_d.append(mirror_direction(facing[r], d[r]))
            new_pix.append(pixel[sel][r])
            new_tp.append(throughput[sel][r] * reflective[r])
            new_w.append(w_refl[r])
            new_seek.append(seek[sel][r])

        w_tran = weight[sel] * np.linalg.norm(transparent, axis=1)
        t = alive & np.any(transparent > 0, axis=1) & (w_tran >= opts.weight)
        if t.any():
            # Outside (d.N < 0) the ray enters the material from vacuum; inside (d.N > 0) it leaves into vacuum.
            entering = ~back[t]
            index_i = np.where(entering, 1.0, ior[t])
            index_t = np.where(entering, ior[t], 1.0)
            dirs, ok = transmitted_direction(facing[t], d[t], index_i, index_t)
            # Total internal reflection: no transmitted ray, the transparent contribution is lost (the course's
            # transmittedDirection returns false and traceRay adds nothing).
            new_o.append(p[t][ok])
            new_d.append(dirs[ok])
            new_pix.append(pixel[sel][t][ok])
            new_tp.append(throughput[sel][t][ok] * transparent[t][ok])
            new_w.append(w_tran[t][ok])
            new_seek.append(seek[sel][t][ok])

        if not new_o:
            break
        ray_o = np.concatenate(new_o)
        ray_d = np.concatenate(new_d)
        pixel = np.concatenate(new_pix)
        throughput = np.concatenate(new_tp)
        weight = np.concatenate(new_w)
        seek = np.concatenate(new_seek)
        ray_tmin = RAY_EPSILON

    if features is None:
        return SampleResult(color, first_t, first_normal)
    albedo, normal = features
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    return SampleResult(color, first_t, first_normal, albedo=albedo, shading_normal=normal)


def _record_features(ctx: RenderContext, features: tuple[np.ndarray, np.ndarray], pixel: np.ndarray,
                     throughput: np.ndarray, seek: np.ndarray, points: np.ndarray, mat: np.ndarray, uv, tint,
                     normals: np.ndarray, back: np.ndarray) -> np.ndarray:
    """Add the albedo (throughput x hit_reflectance) and the normal (weighted by the throughput's mean; the
    branches' normals are blended and made unit at the end) of the hits still seeking features whose surface has
    a kd or ks lobe, or is a back face that shade_back leaves black (albedo 0). Returns the mask of hits that
    found theirs; the others (mirrors, clear glass) hand the search on to their reflected and refracted rays."""
    reflectance, smooth = hit_reflectance(ctx, mat, points, uv, tint)
    black = back & (not ctx.options.shade_back)
    found = seek & (smooth | black)
    lit = found & ~black
    albedo, normal = features
    np.add.at(albedo, pixel[lit], throughput[lit] * reflectance[lit])
    np.add.at(normal, pixel[found], throughput[found].mean(axis=1, keepdims=True) * normals[found])
    return found
