"""The path tracer: unidirectional paths with next-event estimation and BSDF sampling combined by multiple
importance sampling (power heuristic), and Russian roulette, as Mitsuba 3's `path` integrator.

`max_depth` has Mitsuba's meaning: 1 shows emitters seen directly, 2 adds direct light, -1 is unbounded (paths end
by Russian roulette from `rr_depth` on, and at MAX_BOUNCES at the latest). Paths are traced as a wavefront: every
bounce is one closest_hit and one any_hit query on the scene's accelerator (accel/hits.py) for all live paths of a
batch, with NumPy doing the shading; there is no Python loop over rays. Random numbers come from the
counter-based stream of sampling.py keyed by (seed, pixel, sample, dimension), so an image is the same whatever
the thread count and batch size.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..accel.hits import geometric_normals, hit_materials
from ..kernels.layout import SPHERE, TRIANGLE
from ..scene.cameras import image_camera
from . import film
from .bsdfs import BSDFTable, eval_pdf, sample
from .emitters import Emitters
from .raycaster import RenderContext
from .sampling import dot, frame, key, max3, normalize, power_heuristic, sobol_pair, to_local, to_world, uniform
from .texturing import leaf_weights

BATCH = 1 << 16        # paths per wavefront: whole passes of small images together (2^14 -> 2^16: 1.5x faster)
MAX_BOUNCES = 1024     # a hard stop for unbounded paths whose throughput never falls (e.g. weights >= 1)
WORKERS = 2            # wavefronts shaded at once (NumPy frees the GIL)
DIMS = 8               # random dimensions per bounce (see _dim)
PIXEL_KEY = 0xFFFFFFFF  # the sample index of a pixel's own key (Sobol scrambles), never a real sample index


def _dim(depth: int, k: int) -> int:
    """1-D dimension k of bounce `depth`: 0 light pick, 1 lobe pick, 2 Russian roulette, 3 texture pick."""
    return 1 + depth * DIMS + k


def _pair(depth: int, k: int) -> int:
    """2-D Sobol pair k of bounce `depth` (pair 0 is the pixel position): 0 light position, 1 BSDF direction."""
    return 1 + 2 * depth + k


class PathTracer:
    """Everything a path needs from the scene, built once per render: BSDF table and emitters."""

    def __init__(self, ctx: RenderContext):
        self.ctx = ctx
        scene = ctx.scene
        self.table = BSDFTable.from_materials(scene.materials)
        self.emitters = Emitters.build(scene, ctx.compiled, self.table)
        o = ctx.options
        self.max_depth, self.rr_depth, self.hide = o.max_depth, o.rr_depth, o.hide_emitters
        # course scenes show the background colour to camera rays that escape (the environment only lights)
        self.background = None if scene.radiometric_lights else scene.background_color
        self._tri_em, self._sph_em = self.emitters.triangle_emitter, self.emitters.sphere_emitter

    def trace(self, origins, directions, t_min: float, pixel: np.ndarray, sample_index: np.ndarray):
        """Radiance (N,3) along camera rays of (pixel, sample index), with t and normal of the first hit."""
        ctx, tb, em = self.ctx, self.table, self.emitters
        seed = ctx.options.seed
        n = len(origins)
        keys = key(seed, pixel, sample_index)
        pkeys = key(seed, pixel, np.full(n, PIXEL_KEY))
        L = np.zeros((n, 3))
        first_t, first_n = np.full(n, np.inf), np.zeros((n, 3))
        idx = np.arange(n)
        o, d = origins.copy(), normalize(directions)
        thr, eta = np.ones((n, 3)), np.ones(n)
        prev_pdf, prev_delta, prev_p = np.ones(n), np.ones(n, bool), origins.copy()
        tmin: float | np.ndarray = t_min
        depth = 0
        while len(idx) and depth < MAX_BOUNCES:
            hits = ctx.accel.closest_hit(o, d, t_min=tmin)
            hit = hits.hit
            p = o + np.where(hit, hits.t, 0.0)[:, None] * d
            ng = geometric_normals(ctx.compiled, hits, p)
            slot = hit_materials(ctx.compiled, hits)
            if depth == 0:
                first_t[idx], first_n[idx] = hits.t, ng
            # --- emission seen by this ray (BSDF sampling's share of MIS)
            emitted = np.zeros((len(idx), 3))
            em_id = np.full(len(idx), -1, np.int64)
            if hit.any():
                h = np.flatnonzero(hit)
                ns = ng[h] * np.where(tb.flip[slot[h]], -1.0, 1.0)[:, None]
                front = dot(ns, d[h]) < 0
                emitted[h] = tb.emission[slot[h]] * front[:, None]
                eid = np.full(len(h), -1, np.int64)
                tri = hits.kind[h] == TRIANGLE
                eid[tri] = self._tri_em[hits.prim[h][tri]]
                sph = hits.kind[h] == SPHERE
                eid[sph] = self._sph_em[hits.prim[h][sph]]
                em_id[h] = np.where(front, eid, -1)
            miss = ~hit
            if miss.any() and em.has_environment:
                emitted[miss] = em.environment_radiance(d[miss])
                em_id[miss] = em.environment_id
            if depth == 0 and self.background is not None:
                emitted[miss] = self.background
                em_id[miss] = -1
            if depth > 0 or not self.hide:
                w = np.ones(len(idx))
                mis = (~prev_delta) & (em_id >= 0)
                if mis.any():
                    s = np.flatnonzero(mis)
                    y = np.where(hit[s, None], p[s], prev_p[s] + d[s])
                    nrm = ng[s] * np.where(tb.flip[np.maximum(slot[s], 0)], -1.0, 1.0)[:, None]
                    pdf_l = em.pdf_hit(em_id[s], prev_p[s], y, nrm)
                    w[s] = power_heuristic(prev_pdf[s], pdf_l)
                L[idx] += thr * emitted * w[:, None]
            if 0 <= self.max_depth <= depth + 1:
                break
            # --- continue on hits only
            keep = np.flatnonzero(hit)
            idx, o, d, p, ng, slot = idx[keep], o[keep], d[keep], p[keep], ng[keep], slot[keep]
            thr, eta = thr[keep], eta[keep]
            if not len(idx):
                break
            if tb.is_texture.any():
                slot = self._resolve_textures(slot, p, uniform(keys[idx], _dim(depth, 3)))
            ns = ng * np.where(tb.flip[slot], -1.0, 1.0)[:, None]
            ts, tt = frame(ns)
            wi = to_local(-d, ts, tt, ns)
            scale = 1e-7 * (1.0 + max3(np.abs(p))[:, None])
            # --- next-event estimation (light sampling's share of MIS)
            smooth = tb.smooth(slot)
            if em.count and smooth.any():
                s = slice(None) if smooth.all() else np.flatnonzero(smooth)  # a slice copies nothing
                ld, ldist, lw, lpdf = em.sample(p[s], uniform(keys[idx[s]], _dim(depth, 0)),
                                                sobol_pair(pkeys[idx[s]], sample_index[idx[s]], _pair(depth, 0)))
                wo = to_local(ld, ts[s], tt[s], ns[s])
                f, bpdf = eval_pdf(tb, slot[s], wi[s], wo)
                contrib = thr[s] * f * lw * np.where(np.isinf(lpdf), 1.0, power_heuristic(lpdf, bpdf))[:, None]
                live = np.flatnonzero((max3(contrib) > 0) & (lpdf > 0))
                if len(live):
                    q = live if isinstance(s, slice) else s[live]
                    so = p[q] + scale[q] * ng[q] * np.sign(dot(ld[live], ng[q]))[:, None]
                    tmax = np.where(np.isinf(ldist[live]), np.inf, ldist[live] * (1.0 - 1e-6) - scale[q, 0])
                    blocked = ctx.accel.any_hit(so, ld[live], t_min=0.0, t_max=tmax)
                    L[idx[q]] += contrib[live] * ~blocked[:, None]
            # --- BSDF sampling
            u1 = uniform(keys[idx], _dim(depth, 1))
            u2 = sobol_pair(pkeys[idx], sample_index[idx], _pair(depth, 1))
            wo_l, bw, bpdf, delta, beta = sample(tb, slot, wi, u1, u2)
            wo = to_world(wo_l, ts, tt, ns)
            thr = thr * bw
            eta = eta * beta
            depth += 1
            if self.rr_depth <= depth:
                q = np.minimum(max3(thr) * eta * eta, 0.95)
                survive = uniform(keys[idx], _dim(depth - 1, 2)) < q
                thr = np.where(survive[:, None], thr / np.maximum(q, 1e-300)[:, None], 0.0)
            alive = np.flatnonzero(max3(thr) > 0)
            idx, p, ng, wo, thr, eta = idx[alive], p[alive], ng[alive], wo[alive], thr[alive], eta[alive]
            prev_pdf, prev_delta, prev_p = bpdf[alive], delta[alive], p
            o = p + scale[alive] * ng * np.sign(dot(wo, ng))[:, None]
            d = normalize(wo)
            tmin = 0.0
        return L, first_t, first_n

    def _resolve_textures(self, slot: np.ndarray, p: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Course solid textures: pick one blended material per hit, with the texture's weight as probability."""
        tex = self.table.is_texture[slot]
        if not tex.any():
            return slot
        t = np.flatnonzero(tex)
        chosen = slot[t].copy()
        acc = np.zeros(len(t))
        done = np.zeros(len(t), bool)
        for leaf, weight in leaf_weights(self.ctx.scene.materials, slot[t], p[t]):
            acc += weight
            take = ~done & (u[t] < acc) & (weight > 0)
            chosen[take] = leaf[take]
            done |= take
        last = ~done  # rounding: the weights sum to 1 up to float error
        if last.any():
            for leaf, weight in leaf_weights(self.ctx.scene.materials, slot[t][last], p[t][last]):
                chosen[np.flatnonzero(last)[weight > 0]] = leaf[weight > 0]
        out = slot.copy()
        out[t] = chosen
        return out


def render_path(ctx: RenderContext, width: int, height: int, bar) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Path-trace the image: options.samples passes over all pixels (the progress bar counts them), each sample
    splatted through the reconstruction filter. Returns pixel colours (H*W,3), depth (H*W,) and normals (H*W,3) of
    each pixel's first sample."""
    options = ctx.options
    tracer = PathTracer(ctx)
    camera = image_camera(ctx.scene.camera, width, height)  # a model's framed camera fits this image's shape
    count = width * height
    acc, wsum = np.zeros((count, 3)), np.zeros(count)
    depth, normals = np.full(count, np.inf), np.zeros((count, 3))
    radius = film.support_radius(options)
    row_all, col_all = np.divmod(np.arange(count), width)
    # a wavefront holds BATCH paths: whole passes (all pixels, several samples each) when the image is small
    per_pass = max(1, min(options.samples, BATCH // max(count, 1)))
    jobs = []
    for first in range(0, options.samples, per_pass):
        total = count * min(per_pass, options.samples - first)
        jobs += [(first, lo, min(total, lo + BATCH)) for lo in range(0, total, BATCH)]

    def run(job):
        first, lo, hi = job
        sidx, pix = np.divmod(np.arange(lo, hi), count)
        sidx = sidx + first
        off = sobol_pair(key(options.seed, pix, np.full(len(pix), PIXEL_KEY)), sidx, 0)
        row, col = row_all[pix], col_all[pix]
        pts = np.column_stack([col + off[:, 0], height - 1 - row + off[:, 1]])
        o, d, valid = camera.generate_rays(pts, width, height)
        color = np.zeros((len(pix), 3))
        v = np.flatnonzero(valid)
        t_first, n_first = np.full(len(pix), np.inf), np.zeros((len(pix), 3))
        if len(v):
            color[v], t_first[v], n_first[v] = tracer.trace(o[v], d[v], camera.t_min, pix[v], sidx[v])
        return pts, row, col, pix, sidx, color, t_first, n_first

    # NumPy releases the GIL in its loops: WORKERS wavefronts shade at once; results are splatted in job order, so
    # the image does not depend on which finishes first
    with ThreadPoolExecutor(WORKERS, thread_name_prefix="durer-path") as pool:
        for pts, row, col, pix, sidx, color, t_first, n_first in pool.map(run, jobs):
            s0 = sidx == 0
            depth[pix[s0]], normals[pix[s0]] = t_first[s0], n_first[s0]
            _splat(options, pts, row, col, color, width, height, radius, acc, wsum)
            bar.update(len(pix) / count)
    out = np.divide(acc, wsum[:, None], out=np.zeros_like(acc), where=wsum[:, None] > 0)
    return out, depth, normals


def _splat(options, pts, row, col, color, width, height, radius, acc, wsum) -> None:
    """Add each sample, weighted by the filter, to every pixel within the filter's support."""
    for dr in range(-radius, radius + 1):
        for dc in range(-radius, radius + 1):
            r, c = row + dr, col + dc
            ok = (r >= 0) & (r < height) & (c >= 0) & (c < width)
            w = film.filter_weight(options, pts[:, 0] - (c + 0.5), pts[:, 1] - (height - r - 0.5)) * ok
            target = np.where(ok, r * width + c, 0)
            wsum += np.bincount(target, weights=w, minlength=len(wsum))
            for ch in range(3):
                acc[:, ch] += np.bincount(target, weights=w * color[:, ch], minlength=len(wsum))
