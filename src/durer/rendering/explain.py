"""One pixel's ray tree: every ray the renderer casts for a pixel, what it hit and what it brings to the colour.

The tree is built by re-running the integrators' own steps (raycaster.surface, shade_local's Phong terms,
whitted.shadow_visibility, mirror_direction, transmitted_direction, secondary_coefficients) on the pixel's rays,
one ray at a time in the order of the course's recursive traceRay, instead of the renderer's wavefront.

Contributions. A pixel is the filter-weighted average of samples (film.reconstruct): with a box filter of radius
1/2 its own samples, with tent or gaussian filters also the samples of neighbouring pixels. Every sample that
weighs on the pixel is one camera-ray node (its `sample` record says which pixel it belongs to, where on the
film it lies and its normalised filter weight w, the weights summing to 1). Each node's `contribution` is what
that ray alone adds to the pixel, already multiplied by w and by the ray's throughput (the product of the
reflective / transparent colours above it):
* a miss adds the background;
* a hit adds its ambient term, plus every light's diffuse + specular term when no shadow rays are cast;
* a shadow ray adds its light's diffuse + specular term at the parent's hit, or nothing when it is blocked;
* reflection and refraction rays are nodes of their own, so their contributions come in the same way.
So the pixel's colour is the sum of the contributions of all nodes of all samples (`PixelTree.color`), and it
equals the pixel of `render()` with the same options up to float rounding.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..accel.hits import Hits, object_kind
from ..options import RenderOptions
from ..scene.cameras import image_camera
from ..scene.graph import Scene
from ..scene.validate import PHYSICAL
from . import film
from .explain_path import explain_path_pixel
from .integrators import PATH, integrator_for
from .raycaster import RenderContext, raycast, surface
from .renderer import choose_integrator, make_context, make_options
from .shading import light_directions, phong
from .texturing import leaf_weights
from .whitted import (
    RAY_EPSILON,
    mirror_direction,
    secondary_coefficients,
    shadow_visibility,
    transmitted_direction,
    whitted,
)

KINDS = ("camera", "shadow", "reflection", "refraction")


@dataclass
class PixelTree:
    """The ray tree of pixel (x, y) (x from the left, y from the top) of a width x height image.

    rays: one camera-ray node per sample weighing on the pixel, each a JSON-ready dict (see module docstring).
    color: the sum of every node's contribution, the pixel's linear colour."""

    pixel: tuple[int, int]
    size: tuple[int, int]
    rays: list[dict]
    options: RenderOptions = field(default_factory=RenderOptions)

    @property
    def color(self) -> np.ndarray:
        return np.sum([n["contribution"] for n in walk(self.rays)], axis=0) if self.rays else np.zeros(3)

    def to_json(self) -> dict:
        """{"pixel": [x, y], "color": [r, g, b] (linear), "rays": [node, ...]}, as the issue specifies."""
        return {"pixel": list(self.pixel), "color": [float(c) for c in self.color], "rays": self.rays}

    def text(self) -> str:
        """The tree as indented text, one ray per line with its shading terms below it."""
        from .explain_text import tree_text

        return tree_text(self)


def walk(nodes: list[dict]):
    """Every node of the trees, depth first."""
    for node in nodes:
        yield node
        yield from walk(node["children"])


def _vec(a) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=np.float64).reshape(-1)]


def _num(x: float) -> float | None:
    """A float for JSON: None for infinities (JSON has none)."""
    return float(x) if np.isfinite(x) else None


def pixel_samples(width: int, height: int, x: int, y: int, options: RenderOptions):
    """The samples that weigh on pixel (x, y): (film points (K,2), owner pixels (K,2) as (x, y), normalised
    filter weights (K,)), in film.reconstruct's order; the same sample pattern as render() (seeded)."""
    points, pixel = film.sample_points(width, height, options)
    radius = film.support_radius(options)
    if options.samples == 1 and options.sampler == "uniform" and radius == 0:
        q = y * width + x
        return points[q:q + 1], np.array([[x, y]]), np.ones(1)
    n = options.samples
    rows = range(max(0, y - radius), min(height, y + radius + 1))
    cols = range(max(0, x - radius), min(width, x + radius + 1))
    idx = np.array([(r * width + c) * n + k for r in rows for c in cols for k in range(n)], dtype=np.int64)
    pts = points[idx]
    w = film.filter_weight(options, pts[:, 0] - (x + 0.5), pts[:, 1] - (height - y - 0.5))
    keep = w != 0.0
    idx, pts, w = idx[keep], pts[keep], w[keep]
    owner = pixel[idx]
    total = w.sum()
    return pts, np.stack([owner % width, owner // width], axis=-1), (w / total if total > 0 else w)


def local_terms(ctx: RenderContext, p: np.ndarray, n: np.ndarray, d: np.ndarray, m: np.ndarray):
    """shade_local's terms at one hit (arrays of one row): ambient (3,), each light's (diffuse (3,), specular
    (3,)), whether the ray meets the back face, and the Phong leaves [(material id, weight)] of the material.

    The same computation as shade_local, with each light's phong() split into its diffuse and specular halves;
    a back face without shade_back is black (every term zero)."""
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    back = bool(np.einsum("ij,ij->i", d, n)[0] > 0)
    n = -n if back else n
    table = ctx.materials
    ambient = np.zeros(3)
    lights = [(np.zeros(3), np.zeros(3)) for _ in ctx.bundle.lights]
    leaves = []
    dirs = [light_directions(light, p) for light in ctx.bundle.lights]
    zero = np.zeros((1, 3))
    for leaf, weight in leaf_weights(ctx.bundle.materials, m, p):
        kd, ks, e = table.diffuse[leaf], table.specular[leaf], table.exponent[leaf]
        w = float(weight[0])
        leaves.append((int(leaf[0]), w))
        ambient += w * (ctx.bundle.ambient * kd)[0]
        for i, (to_light, color, _) in enumerate(dirs):
            lights[i][0][:] += w * phong(n, -d, to_light, color, kd, zero, e)[0]
            lights[i][1][:] += w * phong(n, -d, to_light, color, zero, ks, e)[0]
    if back and not ctx.options.shade_back:
        ambient[:] = 0.0
        for diffuse, specular in lights:
            diffuse[:] = 0.0
            specular[:] = 0.0
    return ambient, lights, back, leaves


class _Tracer:
    """Builds the nodes of one sample's tree with the integrator the renderer would use."""

    def __init__(self, ctx: RenderContext, integrate):
        self.ctx = ctx
        self.whitted = integrate is whitted
        lo, hi = ctx.compiled.bounds()
        self.far = max(float(np.linalg.norm(hi - lo)) * 2.0, 1.0)  # length drawn for rays that leave the scene

    def _hit(self, o, d, hits: Hits) -> tuple[dict | None, tuple]:
        points, normals, mat = surface(self.ctx, o, d, hits)
        if not hits.hit[0]:
            return None, (points, normals, mat)
        k = int(mat[0])
        materials = self.ctx.bundle.materials
        material = materials[k] if 0 <= k < len(materials) else None
        record = {"point": _vec(points[0]), "normal": _vec(normals[0]), "material": k,
                  "material_type": type(material).__name__,
                  "object": object_kind(self.ctx.compiled, int(hits.kind[0]), int(hits.prim[0])),
                  "primitive": int(hits.prim[0])}
        return record, (points, normals, mat)

    def node(self, kind: str, o: np.ndarray, d: np.ndarray, t_min: float, level: int, throughput: np.ndarray,
             weight: float, fw: float) -> dict:
        ctx = self.ctx
        o, d = o.reshape(1, 3), d.reshape(1, 3)
        if self.whitted and level == 0:  # whitted() normalises the camera rays; raycast() takes them as they are
            d = d / np.linalg.norm(d, axis=1, keepdims=True)
        hits = ctx.accel.closest_hit(o, d, t_min)
        hit, (p, n, m) = self._hit(o, d, hits)
        node = {"kind": kind, "origin": _vec(o), "direction": _vec(d), "t": _num(hits.t[0]) if hit else None,
                "hit": hit, "weight": float(weight), "throughput": _vec(throughput), "contribution": [0.0] * 3,
                "children": []}
        if hit is None:
            node["contribution"] = _vec(fw * throughput * ctx.bundle.background)
            node["end"] = _vec(o[0] + self.far * d[0])
            return node
        node["end"] = hit["point"]
        if ctx.bundle.lights is None:  # assignment 1: the flat colour, straight from the ray caster
            flat = raycast(ctx, o, d, t_min).color[0]
            hit["shading"] = {"flat": _vec(flat)}
            node["contribution"] = _vec(fw * throughput * flat)
            return node
        ambient, lights, back, leaves = local_terms(ctx, p, n, d, m)
        hit["back_face"] = back
        if len(leaves) > 1 or leaves[0][0] != hit["material"]:
            hit["leaves"] = [{"material": leaf, "weight": w} for leaf, w in leaves]
        facing = -n if back else n
        shadows = self.whitted and ctx.options.shadows
        visible = shadow_visibility(ctx, p, facing) if shadows else None
        own = ambient.copy()
        terms = []
        for i, (light, (diffuse, specular)) in enumerate(zip(ctx.bundle.lights, lights, strict=True)):
            term = {"light": i, "type": type(light).__name__, "diffuse": _vec(diffuse), "specular": _vec(specular),
                    "shadowed": None}
            if shadows:
                term["shadowed"] = not bool(visible[i][0])
                shadow = self.shadow(p, facing, i, diffuse + specular if visible[i][0] else np.zeros(3),
                                     throughput, fw)
                if shadow is not None:
                    node["children"].append(shadow)
                else:  # the surface faces away from the light: no shadow ray, and the light adds nothing
                    term["shadowed"], term["faces_away"] = False, True
            else:
                own += diffuse + specular
            terms.append(term)
        hit["shading"] = {"ambient": _vec(ambient), "lights": terms}
        node["contribution"] = _vec(fw * throughput * own)
        if self.whitted and level < ctx.options.bounces:
            self.secondary(node, p, facing, d, m, back, level, throughput, weight, fw)
        return node

    def shadow(self, p, facing, i: int, term: np.ndarray, throughput, fw: float) -> dict | None:
        """The shadow ray from hit point p to light i (None where the surface faces away: none is cast), with
        the closest object between (the blocker) if any."""
        light = self.ctx.bundle.lights[i]
        to_light, _, dist = light_directions(light, p)
        if not np.einsum("ij,ij->i", facing, to_light)[0] > 0:
            return None
        to_light = np.ascontiguousarray(to_light)
        t_max = np.maximum(dist - RAY_EPSILON, RAY_EPSILON)
        hits = self.ctx.accel.closest_hit(p, to_light, RAY_EPSILON, t_max)
        blocker, _ = self._hit(p, to_light, hits)
        length = float(dist[0]) if np.isfinite(dist[0]) else self.far
        return {"kind": "shadow", "origin": _vec(p), "direction": _vec(to_light),
                "t": _num(hits.t[0]) if blocker else None, "hit": blocker, "light": i,
                "blocked": blocker is not None, "distance": _num(dist[0]), "weight": 1.0,
                "throughput": _vec(throughput), "contribution": _vec(fw * throughput * term), "children": [],
                "end": blocker["point"] if blocker else _vec(p[0] + length * to_light[0])}

    def secondary(self, node, p, facing, d, m, back, level, throughput, weight, fw) -> None:
        """Reflection and refraction children, with whitted()'s conditions (alive, colour > 0, weight cut-off)."""
        opts = self.ctx.options
        if back and not opts.shade_back:
            return
        reflective, transparent, ior = secondary_coefficients(self.ctx, m, p)
        w_refl = weight * float(np.linalg.norm(reflective[0]))
        if np.any(reflective[0] > 0) and w_refl >= opts.weight:
            node["children"].append(self.node("reflection", p[0], mirror_direction(facing, d)[0], RAY_EPSILON,
                                              level + 1, throughput * reflective[0], w_refl, fw))
        w_tran = weight * float(np.linalg.norm(transparent[0]))
        if np.any(transparent[0] > 0) and w_tran >= opts.weight:
            index_i, index_t = (ior, 1.0) if back else (1.0, ior)
            dirs, ok = transmitted_direction(facing, d, index_i, index_t)
            if ok[0]:
                node["children"].append(self.node("refraction", p[0], dirs[0], RAY_EPSILON, level + 1,
                                                  throughput * transparent[0], w_tran, fw))
            else:
                node["total_internal_reflection"] = True


def explain(scene: Scene, width: int, height: int, x: int, y: int, *, options: RenderOptions | None = None,
            **kwargs) -> PixelTree:
    """The ray tree of pixel (x, y) (x from the left, y from the top) of render(scene, width, height, ...) with
    the same options: every sample weighing on it, every ray below each. ValueError if the pixel is outside."""
    for name, v in (("x", x), ("y", y), ("width", width), ("height", height)):
        if int(v) != v:
            raise ValueError(f"{name} must be an integer, got {v!r}")
    x, y, width, height = int(x), int(y), int(width), int(height)
    if width < 1 or height < 1:
        raise ValueError(f"image size must be positive integers, got {width} x {height}")
    if not (0 <= x < width and 0 <= y < height):
        raise ValueError(f"pixel ({x}, {y}) is outside the {width}x{height} image "
                         f"(x in 0..{width - 1} from the left, y in 0..{height - 1} from the top)")
    if options is None:  # a scene's own render defaults (Mitsuba: integrator, sampler, film), as render() does
        defaults = dict(getattr(scene, "render_defaults", None) or {})
        kwargs = {**{k: v for k, v in defaults.items() if k not in ("width", "height")}, **kwargs}
    options = make_options(options, **kwargs)
    if options.visualize_grid:
        raise ValueError("explain shows the rays of a render, not the grid's cells: drop visualize_grid")
    check_integrator(scene.materials, options)
    return explain_in(make_context(scene, options), width, height, x, y)


def check_integrator(materials: Sequence, options: RenderOptions) -> None:
    """ValueError, as render() gives, when the options ask for the course's integrators on physically based
    materials (which only the path tracer renders). `materials`: a scene's, or a compiled bundle's."""
    if options.integrator != "path" and any(isinstance(m, PHYSICAL) for m in materials):
        raise ValueError("the scene has physically based materials (a Mitsuba scene): render it with "
                         "integrator='path'")


def explain_in(ctx: RenderContext, width: int, height: int, x: int, y: int) -> PixelTree:
    """explain() with a prepared context (the preview server keeps one per scene and options)."""
    if integrator_for(ctx.options) is PATH:  # each sample's path, replayed by the path tracer (explain_path.py)
        rays = explain_path_pixel(ctx, width, height, x, y)
        return PixelTree(pixel=(x, y), size=(width, height), rays=rays, options=ctx.options)
    camera = image_camera(ctx.camera, width, height)  # the camera render() traces this image through
    tracer = _Tracer(ctx, choose_integrator(ctx.options))
    points, owners, weights = pixel_samples(width, height, x, y, ctx.options)
    origins, directions, valid = camera.generate_rays(points, width, height)
    rays = []
    for i in range(len(points)):
        o, d = origins[i], directions[i]
        if valid[i]:
            node = tracer.node("camera", o, d, camera.t_min, 0, np.ones(3), 1.0, float(weights[i]))
        else:  # outside a fisheye's image circle: no ray, black
            node = {"kind": "camera", "origin": _vec(o), "direction": _vec(d), "t": None, "hit": None,
                    "weight": 1.0, "throughput": [1.0] * 3, "contribution": [0.0] * 3, "children": [],
                    "end": _vec(o), "no_ray": True}
        node["sample"] = {"film": _vec(points[i]), "pixel": [int(v) for v in owners[i]],
                          "filter_weight": float(weights[i])}
        rays.append(node)
    return PixelTree(pixel=(x, y), size=(width, height), rays=rays, options=ctx.options)
