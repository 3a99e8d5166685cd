"""The path tracer: unidirectional paths with next-event estimation and BSDF sampling combined by multiple
importance sampling (power heuristic), and Russian roulette, as Mitsuba 3's `path` integrator.

`max_depth` has Mitsuba's meaning: 1 shows emitters seen directly, 2 adds direct light, -1 is unbounded (paths end
by Russian roulette from `rr_depth` on, and at MAX_BOUNCES at the latest). Paths are traced as a wavefront, one
bounce of all live paths of a batch at a time, with no Python loop over rays. When the accelerator offers a
one-level tree to walk (Accelerator.kernel_tree: the default BVH, over instances flattened for path renders by
context.make_context) a bounce is one Numba kernel
(kernels/path/wavefront.py: closest hit, surface, shading, shadow ray, next ray, per path; the camera rays'
closest hits come from the accelerator's batch walk, where a pixel's samples walk together); otherwise (other
accelerators, solid textures) it is one closest_hit and one any_hit query on the
scene's accelerator (accel/hits.py) and between them one Numba pass for the hit surfaces (kernels/path/surface.py)
and one for the shading (kernels/path/bounce.py: emission, light sample, BSDF sample, Russian roulette, next ray).
Both give the same numbers to the bit. Random numbers come from the counter-based stream of sampling.py /
kernels/path/qmc.py keyed by (seed, pixel, sample, dimension), so an image is the same whatever the thread count
and batch size. The renderer drives it like any integrator (integrators.PATH, units.py).
"""

from __future__ import annotations

import threading

import numpy as np

from ..kernels.path.bounce import add_unblocked, dim1, shade_bounce
from ..kernels.path.surface import hit_surfaces
from ..kernels.path.wavefront import PIECES, scratch, start_paths, trace_bounce
from ..kernels.threads import run_pieces
from .bsdfs import TEXTURED_PARAMS
from .context import RenderContext, SampleResult
from .sampling import PIXEL_KEY, key, max3, normalize, seed_key, uniform
from .texturing import leaf_weights

BATCH = 1 << 16        # each thread's wavefront buffers hold this many paths at least (integrators.PATH_BATCH)
MAX_BOUNCES = 1024     # a hard stop for unbounded paths whose throughput never falls (e.g. weights >= 1)


class PathTracer:
    """Everything a path needs, gathered once per render from the compiled scene bundle (its BSDF table and
    emitters, built by compile: bundle.py) and the accelerator (the tree the fused bounce walks)."""

    def __init__(self, ctx: RenderContext):
        self.ctx = ctx
        b = ctx.bundle
        self.table, self.emitters = b.bsdfs, b.emitters
        o = ctx.options
        self.max_depth, self.rr_depth, self.hide = o.max_depth, o.rr_depth, o.hide_emitters
        # course scenes show the background colour to camera rays that escape (the environment only lights)
        self.background = None if b.radiometric else b.background
        self._surfaces = ctx.derived.get("path.surfaces")  # kept with the scene's build (builds.py)
        if self._surfaces is None:
            self._surfaces = ctx.derived["path.surfaces"] = _surface_arrays(ctx)
        # the fused bounce (kernels/path/wavefront.py) needs a one-level tree to walk (Accelerator.kernel_tree) and
        # every piece of shading in Numba (environment maps are: kernels/path/envmap.py): other accelerators
        # and solid textures take the unfused wavefront of closest_hit / any_hit queries
        numba_shading = not self.table.is_texture.any()
        self._bvh = ctx.accel.kernel_tree() if numba_shading else None
        self._fused = self._bvh is not None
        self._local = threading.local()  # each shading thread's wavefront buffers (_state)
        # the denoiser's features: each path's first non-specular hit's albedo and normal, the emission it sees
        self.features = bool(o.aovs or o.denoise)
        # nothing a ray can hit or escape to gives light (only point, spot and directional lights): the last bounce
        # of a bounded path would add exactly zero (it only collects emission), so the fused loop skips its trace
        em, t = self.emitters, self.table
        self._dark = not (self.features or em.envmap is not None or em.has_environment
                          or (np.asarray(t.emission) != 0).any()
                          or (np.asarray(t.tex)[:, TEXTURED_PARAMS.index("emission")] >= 0).any())

    def __getstate__(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "_local"}  # buffers belong to this process's threads

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._local = threading.local()

    def trace(self, origins, directions, t_min: float, pixel: np.ndarray, sample_index: np.ndarray):
        """Radiance (N,3) along camera rays of (pixel, sample index), with t and normal of the first hit, and the
        features: albedo and normal (N,3) of the first non-specular hit and the part of the radiance that is
        emission seen directly or through mirrors and glass, from surface emitters and from the environment (N,3)
        (None unless options.aovs or denoise)."""
        if self._fused:
            return self._trace_fused(origins, directions, t_min, pixel, sample_index)
        return self._trace_unfused(origins, directions, t_min, pixel, sample_index)

    def _trace_fused(self, origins, directions, t_min: float, pixel: np.ndarray, sample_index: np.ndarray):
        """trace with one kernel per bounce (trace_bounce) over the live paths, whose state it updates in place:
        the same numbers as _trace_unfused to the bit."""
        n = len(origins)
        sample_index = np.ascontiguousarray(sample_index, dtype=np.int64)
        o, d, thr, eta, prev, keys, pkeys, alive = self._state(n)
        path = (sample_index, keys, pkeys)
        L, first_t, first_n = np.empty((n, 3)), np.empty(n), np.empty((n, 3))
        aux = self._aux(n, fresh=False)  # start_paths sets them
        start_paths(seed_key(self.ctx.options.seed), np.ascontiguousarray(pixel, dtype=np.int64), sample_index,
                    PIXEL_KEY, np.ascontiguousarray(origins, dtype=np.float64),
                    np.ascontiguousarray(directions, dtype=np.float64), (o, d, thr, eta, prev), path[1:],
                    (L, first_t, first_n), aux)
        live = np.arange(n)
        bsdf, lights, env = self.table.packed(), self.emitters.pack(), self.emitters.env_tables()
        depth, tmin, work = 0, float(t_min), scratch(self._bvh[-1])
        # the camera rays' hits by the accelerator's batch walk (consecutive rays of a pixel's samples walk
        # together: 32-76 ns a ray against ~100 more in the one-ray walk), the same hits to the bit. Several
        # samples of a pixel in a row are not an image's rows, but accel/widths.flat_image_width took a 64-pixel
        # tile row of 16 samples each for a 1024-ray image row and traced 4 x 4 packets of 4 samples of 4 pixel
        # rows: width -1 keeps a pixel's consecutive samples in one packet, 0.47-0.98x the walk's time on the
        # Mitsuba set (sphere grid under an envmap 316 -> 148 ns a ray); one sample per pixel may be an image
        several = len(pixel) > 1 and pixel[0] == pixel[1]
        hits = self.ctx.accel.closest_hit(o, d, t_min=tmin, width=-1 if several else 0)
        given, none = (hits.t, hits.kind, hits.prim), (np.empty(0), np.empty(0, np.int8), np.empty(0, np.int32))
        while len(live) and depth < MAX_BOUNCES:
            last = 0 <= self.max_depth <= depth + 1
            if last and depth and self._dark:  # no light to find at the last vertex: the same L, one trace fewer
                break
            scalars = (depth, depth > 0 or not self.hide, last, self.rr_depth, self.features)
            run_pieces(trace_bounce, PIECES, live, o, d, thr, eta, prev, path, self._bvh, self._surfaces,
                       self._miss_constants(depth), bsdf, lights, env, scalars, tmin, L, aux, (first_t, first_n),
                       alive, given if depth == 0 else none, work)
            if last:
                break
            live = live[alive[:len(live)]]
            tmin = 0.0
            depth += 1
        return L, first_t, first_n, *self._features(aux)

    def _aux(self, n: int, fresh: bool = True) -> tuple[np.ndarray, ...]:
        """The features' per-path arrays (tint, albedo, normal (n, 3), seen emission (n, 6)) for n paths
        (kernels/path/bounce.shade_path), or empty when no features are wanted (the kernels never touch them).
        fresh: tint 1 and the rest 0; else views of this thread's buffers, as _state's (their values are
        start_paths' to set, and trace's caller copies the features out before the thread traces again)."""
        if not self.features:
            return np.ones((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 6))
        if fresh:
            return np.ones((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 6))
        buffers = getattr(self._local, "aux", None)
        if buffers is None or len(buffers[0]) < n:
            size = max(n, BATCH)
            buffers = self._local.aux = (np.empty((size, 3)), np.empty((size, 3)), np.empty((size, 3)),
                                         np.empty((size, 6)))
        return tuple(b[:n] for b in buffers)

    def _features(self, aux: tuple) -> tuple[np.ndarray | None, ...]:
        """(albedo, normal, emission seen from surface emitters, from the environment) of trace's result: aux's,
        or four None when no features are wanted."""
        return (aux[1], aux[2], aux[3][:, :3], aux[3][:, 3:]) if self.features else (None,) * 4

    def _state(self, n: int) -> tuple[np.ndarray, ...]:
        """The fused wavefront's per-path state for n paths (o, d, thr, eta, prev, keys, pixel keys, alive), as
        views of buffers each shading thread allocates once per render: fresh ones per wavefront measured 8% of
        the caustic scene's CPU time, mostly the page faults of their first touch."""
        buffers = getattr(self._local, "state", None)
        if buffers is None or len(buffers[0]) < n:
            size = max(n, BATCH)
            buffers = self._local.state = (np.empty((size, 3)), np.empty((size, 3)), np.empty((size, 3)),
                                           np.empty(size), np.empty((size, 5)), np.empty(size, np.uint64),
                                           np.empty(size, np.uint64), np.empty(size, bool))
        return tuple(b[:n] for b in buffers)

    def _miss_constants(self, depth: int) -> tuple[float, float, float, float, bool]:
        """What _misses gives every escaping ray: (radiance r, g, b, light pdf, is an emitter) of the constant
        environment, or of the background for camera rays of a course scene; an environment map is an emitter whose
        radiance and pdf the kernel looks up."""
        em = self.emitters
        if depth == 0 and self.background is not None:
            r, g, b = (float(c) for c in self.background)
            return r, g, b, 0.0, False
        if em.envmap is not None:
            return 0.0, 0.0, 0.0, 0.0, True
        if em.has_environment:
            r, g, b = (float(c) for c in em.environment)
            return r, g, b, 1.0 / (4.0 * np.pi * em.count), True
        return 0.0, 0.0, 0.0, 0.0, False

    def _trace_unfused(self, origins, directions, t_min: float, pixel: np.ndarray, sample_index: np.ndarray,
                       record=None):
        """trace as a bounce of accelerator queries and shading passes, on any accelerator and scene.

        record (durer explain's hook, rendering/explain_path.py): if given, called after every bounce as
        record(depth, arrays) with that bounce's arrays (a dict of copies, one row per live path), so one pixel's
        paths can be listed step by step by the same code that renders them."""
        ctx, tb, em = self.ctx, self.table, self.emitters
        seed = ctx.options.seed
        n = len(origins)
        sample_index = np.ascontiguousarray(sample_index, dtype=np.int64)
        keys = key(seed, pixel, sample_index)
        pkeys = key(seed, pixel, np.full(n, PIXEL_KEY))
        L = np.zeros((n, 3))
        first_t, first_n = np.full(n, np.inf), np.zeros((n, 3))
        aux = self._aux(n)
        idx = np.arange(n)
        # every bounce works in views of these buffers (first m rows): fresh arrays per bounce measured a quarter
        # of the CPU time in page faults; live paths are gathered from the `nxt` arrays back into the state
        o, d = np.ascontiguousarray(origins, dtype=np.float64).copy(), np.ascontiguousarray(normalize(directions))
        thr, eta = np.ones((n, 3)), np.ones(n)
        prev = np.column_stack([np.ones(n), np.ones(n), origins])  # pdf, delta flag, point of the last bounce
        p, ng, ns, slot_em = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty(n, np.int64)
        uvd = np.empty((n, 8))
        shadow_o, shadow_d, shadow_t, shadow_c, shadow_ok = (np.empty((n, 3)), np.empty((n, 3)), np.empty(n),
                                                             np.empty((n, 3)), np.empty(n, bool))
        sh_o, sh_d, sh_t = np.empty((n, 3)), np.empty((n, 3)), np.empty(n)
        nxt_o, nxt_d, nxt_prev, nxt_thr, nxt_eta = (np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 5)),
                                                    np.empty((n, 3)), np.empty(n))
        tmin: float | np.ndarray = t_min
        depth, m = 0, n
        while m and depth < MAX_BOUNCES:
            # camera rays may be traced as image tiles (width 0: the accelerator looks); later rays are not an image
            hits = ctx.accel.closest_hit(o[:m], d[:m], t_min=tmin, width=0 if depth == 0 else -1)
            hit = hits.hit
            run_pieces(hit_surfaces, m, o, d, hits.t, hits.kind, hits.prim, *self._surfaces, p, ng, ns, uvd, slot_em)
            if depth == 0:
                first_t[idx], first_n[idx] = hits.t, ng[:m]
            last = 0 <= self.max_depth <= depth + 1
            slot = slot_em
            if tb.is_texture.any() and not last:
                slot = self._resolve_textures(slot_em[:m], hit, p[:m], uniform(keys[idx], dim1(depth, 3)),
                                              hits.kind, hits.prim)
            run_pieces(shade_bounce, m, o, d, hits.t, hits.kind, hits.prim, ng, ns, uvd, slot_em, slot,
                       (idx, sample_index, keys, pkeys, thr, eta, prev), self._misses(d[:m], hit, depth),
                       tb.packed(), em.pack(), em.env_tables(), (depth, depth > 0 or not self.hide, last,
                                                                 self.rr_depth, self.features), L, aux,
                       (shadow_o, shadow_d, shadow_t, shadow_c, shadow_ok), (nxt_o, nxt_d, nxt_prev, nxt_thr, nxt_eta))
            shaded = L[idx] if record is not None else None  # (a copy) the light found before the shadow rays
            q = np.flatnonzero(shadow_ok[:m])  # none on the last bounce (shade_path casts none there)
            blocked = np.zeros(0, bool)
            if len(q):
                k = len(q)
                for src, dst in ((shadow_o, sh_o), (shadow_d, sh_d), (shadow_t, sh_t)):
                    np.take(src, q, axis=0, out=dst[:k], mode="clip")
                blocked = ctx.accel.any_hit(sh_o[:k], sh_d[:k], t_min=0.0, t_max=sh_t[:k], width=-1)
                add_unblocked(L, idx, q, blocked, shadow_c)
            if record is not None:
                unblocked = np.zeros(m, bool)
                unblocked[q] = ~blocked
                arrays = dict(idx=idx, o=o, d=d, thr=thr, eta=eta, prev=prev, t=hits.t, kind=hits.kind,
                              prim=hits.prim, point=p, normal=ng, shading_normal=ns, uvd=uvd, slot_em=slot_em,
                              slot=slot, shadow_ok=shadow_ok,
                              shadow_o=shadow_o, shadow_d=shadow_d, shadow_t=shadow_t, shadow_c=shadow_c,
                              next_o=nxt_o, next_d=nxt_d, next_prev=nxt_prev, next_thr=nxt_thr, next_eta=nxt_eta)
                record(depth, {"L_shaded": shaded, "unblocked": unblocked,
                               **{name: np.array(a[:m], copy=True) for name, a in arrays.items()}})
            if last:
                break
            alive = np.flatnonzero(max3(nxt_thr[:m]) > 0)
            m = len(alive)
            idx = idx[alive]
            for src, dst in ((nxt_o, o), (nxt_d, d), (nxt_prev, prev), (nxt_thr, thr), (nxt_eta, eta)):
                np.take(src, alive, axis=0, out=dst[:m], mode="clip")
            tmin = 0.0
            depth += 1
        return L, first_t, first_n, *self._features(aux)

    def _misses(self, d: np.ndarray, hit: np.ndarray, depth: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Radiance (N,3) seen by the rays that escape, its light-sampling pdf (N,) and whether it is an emitter
        (N,) (for MIS): the constant environment, or a course scene's background colour for camera rays; an
        environment map is an emitter whose radiance and pdf the kernel looks up (as _miss_constants)."""
        n, em = len(d), self.emitters
        radiance, pdf, is_emitter = np.zeros((n, 3)), np.zeros(n), np.zeros(n, bool)
        miss = np.flatnonzero(~hit)
        if len(miss) and em.has_environment:
            if em.envmap is None:
                radiance[miss] = em.environment
                pdf[miss] = 1.0 / (4.0 * np.pi * em.count)
            is_emitter[miss] = True
        if len(miss) and depth == 0 and self.background is not None:
            radiance[miss] = self.background
            is_emitter[miss] = False
        return radiance, pdf, is_emitter

    def _resolve_textures(self, slot: np.ndarray, hit: np.ndarray, p: np.ndarray, u: np.ndarray,
                          kind: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """The course's solid textures: pick one blended material per hit,
        with the texture's weight as probability."""
        tex = hit & self.table.is_texture[slot]
        if not tex.any():
            return slot
        t = np.flatnonzero(tex)
        chosen = slot[t].copy()
        acc = np.zeros(len(t))
        done = np.zeros(len(t), bool)
        for leaf, weight in leaf_weights(self.ctx.bundle.materials, slot[t], p[t]):
            acc += weight
            take = ~done & (u[t] < acc) & (weight > 0)
            chosen[take] = leaf[take]
            done |= take
        last = ~done  # rounding: the weights sum to 1 up to float error
        if last.any():
            for leaf, weight in leaf_weights(self.ctx.bundle.materials, slot[t][last], p[t][last]):
                chosen[np.flatnonzero(last)[weight > 0]] = leaf[weight > 0]
        out = slot.copy()
        out[t] = chosen
        return out


def prepare_path(ctx: RenderContext) -> None:
    """Gather the path tracer's inputs (the bundle's BSDFs and emitters, the surfaces' arrays, the tree to walk)
    once for a render."""
    ctx.prepared.setdefault("path", PathTracer(ctx))
def _surface_arrays(ctx: RenderContext) -> tuple[np.ndarray, ...]:
    """What hit_surfaces reads of the scene, from the instances flattened (one array of every triangle): made once
    per build (RenderContext.derived), not per render (the sphere grid's 325k corner normals: 18 ms a render)."""
    flat = ctx.compiled.flat
    return tuple(np.ascontiguousarray(a) for a in (
        flat.triangles.reshape(-1, 3, 3), flat.triangle_material, flat.sphere_world_to_object,
        flat.sphere_center, flat.sphere_radius, flat.sphere_normal_matrix, flat.sphere_material,
        flat.plane_normal, flat.plane_material,
        _unit_corners(flat.triangle_normals) if flat.has_normals else np.zeros((0, 3, 3)),
        np.asarray(flat.triangle_uv, dtype=np.float64).reshape(-1, 3, 2)))


def _unit_corners(normals: np.ndarray) -> np.ndarray:
    """(F, 3, 3) corner normals scaled to unit length (zero rows stay zero: flat triangles)."""
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3, 3)
    length = np.linalg.norm(n, axis=2, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def path_trace(ctx: RenderContext, origins: np.ndarray, directions: np.ndarray, t_min: float,
               pixel: np.ndarray | None = None, sample: np.ndarray | None = None) -> SampleResult:
    """The path tracer as an integrator: radiance (N,3) along camera rays of film samples (pixel, sample index:
    the keys of their random numbers), with t and geometric normal of the first hit. The PathTracer is built once
    per render, at prepare time (prepare_path), and shared by the threads and processes tracing units."""
    if pixel is None or sample is None:
        raise ValueError("the path tracer keys its random numbers by pixel and sample index: give both")
    tracer = ctx.prepared.get("path")
    if tracer is None:  # a context not prepared for the path tracer (explain, tests): build it once here
        prepare_path(ctx)
        tracer = ctx.prepared["path"]
    color, t, normal, albedo, shading, emission, environment = tracer.trace(origins, directions, t_min,
                                                                            np.asarray(pixel), np.asarray(sample))
    return SampleResult(color, t, normal, albedo=albedo, shading_normal=shading, emission=emission,
                        environment=environment)
