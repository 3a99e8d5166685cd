"""One path-traced pixel, explained: every sample's path, bounce by bounce, replayed through the renderer's own code.

The samples are those the path tracer's units splat onto the pixel (its own, and with a tent or gaussian filter the
neighbours'), at the same film points (the Sobol pair 0 of each pixel's stream). Each sample's path is traced by
PathTracer._trace_unfused (the same kernels as the renderer's fused bounce, the same numbers to the bit), whose
`record` hook hands over every bounce's arrays. Each path becomes a chain of nodes:
* a `camera` node (the camera ray) and one `bounce` node per BSDF-sampled ray after it, each with what it hit
  (vertex: point, geometric normal, material slot and its BSDF) and, as `contribution`, the emission that ray
  found (throughput x radiance x MIS weight against light sampling, x the sample's filter weight);
* below each vertex, a `shadow` node for next-event estimation: the light sample's direction, its emitter pdf,
  the BSDF's value and pdf there (in the kernel's shading frame: textures, normal maps, anisotropic tangents), its
  MIS weight, whether it was blocked, and what it adds;
* the next `bounce` node below it, with the BSDF sample's pdf, whether it was a delta lobe, the new throughput
  (Russian roulette included).
A node's contribution is what it adds to the pixel, so the pixel is the sum of all contributions (PixelTree.color),
equal to the pixel of render() with the same options and seed up to float rounding.
"""

from __future__ import annotations

import numpy as np

from ..accel.hits import object_kind
from ..kernels.common import MISS
from ..kernels.path.bounce import dim1, dim2
from ..kernels.path.replay import light_sample_frame
from ..kernels.path.warps import power_heuristic1
from ..scene.cameras import image_camera
from . import film
from .bsdfs import TEXTURED_PARAMS, eval_pdf
from .path import PIXEL_KEY, PathTracer
from .raycaster import RenderContext
from .sampling import key, sobol_pair, uniform
from .textures import mean

EMISSION_TEX = TEXTURED_PARAMS.index("emission")  # the BSDF table's column naming an area light's radiance texture


def _vec(a) -> list[float]:
    return [float(x) for x in np.asarray(a, dtype=np.float64).reshape(-1)]


def _num(x: float) -> float | None:
    """A float for JSON: None for infinities (a delta light's pdf; JSON has none)."""
    return float(x) if np.isfinite(x) else None


def path_samples(width: int, height: int, x: int, y: int, options) -> tuple[np.ndarray, ...]:
    """The path tracer's samples that weigh on pixel (x, y): film points (K,2), owner pixel indices (K,), sample
    indices (K,) and normalised filter weights (K,), as the render's units place and splat them."""
    radius = film.support_radius(options)
    n = options.samples
    rows = np.arange(max(0, y - radius), min(height, y + radius + 1))
    cols = np.arange(max(0, x - radius), min(width, x + radius + 1))
    row, col, sidx = (a.ravel() for a in np.meshgrid(rows, cols, np.arange(n), indexing="ij"))
    pix = row * width + col
    off = sobol_pair(key(options.seed, pix, np.full(len(pix), PIXEL_KEY)), sidx, 0)
    pts = np.column_stack([col + off[:, 0], height - 1 - row + off[:, 1]])
    w = film.filter_weight(options, pts[:, 0] - (x + 0.5), pts[:, 1] - (height - y - 0.5))
    keep = w != 0.0
    total = w[keep].sum()
    return pts[keep], pix[keep], sidx[keep], (w[keep] / total if total > 0 else w[keep])


class _Recorder:
    """Collects _trace_unfused's bounce arrays and turns one path's rows into its chain of nodes."""

    def __init__(self, tracer: PathTracer, far: float):
        self.tracer, self.far = tracer, far
        self.bounces: list[dict] = []

    def __call__(self, depth: int, arrays: dict) -> None:
        self.bounces.append(arrays)

    def path(self, j: int, fw: float, sample: int, pixel: int) -> dict:
        """The node chain of path j (row j of the traced batch) with filter weight fw."""
        after = np.zeros(3)  # L of the path after the previous bounce (emission and unblocked light sample)
        root: dict | None = None
        parent: dict | None = None
        for depth, b in enumerate(self.bounces):
            rows = np.flatnonzero(b["idx"] == j)
            if not len(rows):
                break
            i = int(rows[0])
            node = self._vertex(b, i, depth, "camera" if depth == 0 else "bounce", fw)
            found = b["L_shaded"][i] - after
            node["contribution"] = _vec(fw * found)
            node["emission"] = self._emission(b, i, depth, found)
            after = b["L_shaded"][i].copy()
            if b["shadow_ok"][i]:
                shadow = self._shadow(b, i, depth, fw, sample, pixel)
                node["children"].append(shadow)
                if b["unblocked"][i]:
                    after = after + b["shadow_c"][i]
            thr = b["next_thr"][i]
            if thr.max() > 0:  # (the kernel writes the next ray's other arrays only for paths that go on)
                node["next"] = {"throughput": _vec(thr), "pdf": _num(b["next_prev"][i, 0]),
                                "delta": bool(b["next_prev"][i, 1]), "eta": float(b["next_eta"][i])}
            else:
                node["path_ends"] = self._end_reason(b, i, depth)
            if parent is None:
                root = node
            else:
                parent["children"].append(node)
            parent = node
        return root

    def _vertex(self, b: dict, i: int, depth: int, kind: str, fw: float) -> dict:
        """The ray of bounce `depth` and what it hit."""
        o, d = b["o"][i], b["d"][i]
        hit = None
        if b["kind"][i] != MISS:
            slot = int(b["slot"][i])
            materials = self.tracer.ctx.bundle.materials
            material = materials[slot] if 0 <= slot < len(materials) else None
            hit = {"point": _vec(b["point"][i]), "normal": _vec(b["normal"][i]), "material": slot,
                   "material_type": _bsdf_name(material),
                   "object": object_kind(self.tracer.ctx.compiled, int(b["kind"][i]), int(b["prim"][i])),
                   "primitive": int(b["prim"][i])}
        return {"kind": kind, "origin": _vec(o), "direction": _vec(d), "t": _num(b["t"][i]) if hit else None,
                "hit": hit, "depth": depth, "weight": 1.0, "throughput": _vec(b["thr"][i]),
                "contribution": [0.0] * 3, "children": [], "filter_weight": fw,
                "end": hit["point"] if hit else _vec(o + self.far * d)}

    def _emission(self, b: dict, i: int, depth: int, found: np.ndarray) -> dict | None:
        """The radiance the ray found and the MIS weight it came with (found = throughput x radiance x weight)."""
        tracer = self.tracer
        if b["kind"][i] != MISS:
            slot = int(b["slot_em"][i])
            radiance = tracer.table.emission[slot] if slot >= 0 else np.zeros(3)
            tex = int(tracer.table.tex[slot, EMISSION_TEX]) if slot >= 0 else -1
            if tex >= 0:  # a textured area light: its radiance at the hit's UV, as the kernel looked it up
                radiance = tracer.table.textures.eval3(tex, b["uvd"][i, :2])[0]
        else:  # the environment, or a course scene's background for camera rays
            radiance = tracer._misses(b["d"][i:i + 1], np.zeros(1, bool), depth)[0][0]
        if not np.any(radiance > 0):
            return None
        scale = b["thr"][i] * radiance
        c = int(np.argmax(scale))
        if not np.any(found != 0):  # the kernel added nothing: the emitter's back side, or hidden (hide_emitters)
            return {"radiance": _vec(radiance), "mis_weight": 0.0, "counted": False}
        mis = float(found[c] / scale[c]) if scale[c] > 0 else 0.0
        return {"radiance": _vec(radiance), "mis_weight": mis, "counted": True}

    def _shadow(self, b: dict, i: int, depth: int, fw: float, sample: int, pixel: int) -> dict:
        """The light sample of next-event estimation, replayed with the emitters' and BSDFs' array calls."""
        tracer, opts = self.tracer, self.tracer.ctx.options
        p = b["point"][i:i + 1]
        pkey = key(opts.seed, np.array([pixel]), np.array([PIXEL_KEY]))
        skey = key(opts.seed, np.array([pixel]), np.array([sample]))
        u = sobol_pair(pkey, np.array([sample]), dim2(depth, 0))
        ld, dist, lw, lpdf = tracer.emitters.sample(p, uniform(skey, dim1(depth, 0)), u)
        P, _, tex = tracer.table.packed()
        slot = int(b["slot"][i])
        wi, wo, k = light_sample_frame(P, tex, slot, b["normal"][i], b["shading_normal"][i], b["uvd"][i], b["d"][i],
                                       ld[0])
        f, pdf = eval_pdf(tracer.table, np.array([slot]), wi[None], wo[None], uv=b["uvd"][i:i + 1, :2])
        f, bpdf = f[0] * k, float(pdf[0]) if k > 0 else 0.0
        mis = power_heuristic1(float(lpdf[0]), bpdf)
        c = b["shadow_c"][i]
        reaches = bool(b["unblocked"][i])
        length = float(dist[0]) if np.isfinite(dist[0]) else self.far
        return {"kind": "shadow", "origin": _vec(b["shadow_o"][i]), "direction": _vec(b["shadow_d"][i]),
                "t": None, "hit": None, "blocked": not reaches, "distance": float(dist[0]) if np.isfinite(dist[0])
                else None, "light_sample": {"emitter_weight": _vec(lw[0]), "pdf": _num(lpdf[0]),
                                            "bsdf": _vec(f), "bsdf_pdf": _num(bpdf), "mis_weight": mis},
                "weight": 1.0, "throughput": _vec(b["thr"][i]), "contribution": _vec(fw * c) if reaches else [0.0] * 3,
                "children": [], "end": _vec(b["shadow_o"][i] + length * b["shadow_d"][i])}

    def _end_reason(self, b: dict, i: int, depth: int) -> str:
        if b["kind"][i] == MISS:
            return "escaped the scene"
        max_depth = self.tracer.max_depth
        if 0 <= max_depth <= depth + 1:
            return f"max_depth {max_depth} reached"
        if self.tracer.rr_depth <= depth + 1:
            return "absorbed (BSDF sample of weight 0, or Russian roulette)"
        return "absorbed (BSDF sample of weight 0)"


def _bsdf_name(material) -> str:
    """The BSDF's class name (a Surface's own BSDF, with 'emitter' when it glows)."""
    if material is None:
        return "none"
    bsdf = getattr(material, "bsdf", None)
    name = type(bsdf if bsdf is not None else material).__name__
    radiance = getattr(material, "radiance", None)
    glows = radiance is not None and np.any(mean(radiance) > 0)  # a colour, or a texture's mean
    return name + (" + area emitter" if glows else "")


def explain_path_pixel(ctx: RenderContext, width: int, height: int, x: int, y: int) -> list[dict]:
    """One chain of nodes per sample weighing on pixel (x, y) of the path-traced image (module docstring)."""
    options = ctx.options
    tracer = PathTracer(ctx)
    camera = image_camera(ctx.camera, width, height)
    pts, pix, sidx, weights = path_samples(width, height, x, y, options)
    origins, directions, valid = film.camera_rays(camera, pts, width, height, options, pix, sidx)
    lo, hi = ctx.compiled.bounds()
    recorder = _Recorder(tracer, max(float(np.linalg.norm(hi - lo)) * 2.0, 1.0))
    v = np.flatnonzero(valid)
    if len(v):
        tracer._trace_unfused(origins[v], directions[v], camera.t_min, pix[v], sidx[v], record=recorder)
    rays, row = [], {int(k): j for j, k in enumerate(v)}
    for k in range(len(pts)):
        fw = float(weights[k])
        if k in row:
            node = recorder.path(row[k], fw, int(sidx[k]), int(pix[k]))
        else:  # outside a fisheye's image circle: no ray; the film shows the background there, as render does
            background = fw * np.asarray(ctx.bundle.background, dtype=np.float64)
            node = {"kind": "camera", "origin": _vec(origins[k]), "direction": _vec(directions[k]), "t": None,
                    "hit": None, "weight": 1.0, "throughput": [1.0] * 3, "contribution": _vec(background),
                    "children": [], "end": _vec(origins[k]), "no_ray": True}
        node["sample"] = {"film": _vec(pts[k]), "pixel": [int(pix[k] % width), int(pix[k] // width)],
                          "index": int(sidx[k]), "filter_weight": fw}
        rays.append(node)
    return rays
