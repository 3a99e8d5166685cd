"""The preview's model: one scene, its current view and options, and the worker thread that renders them.

All rendering (and every `explain`) runs on the one worker thread, in order: the event loop never waits for a
render, and Numba's thread pool is never entered from two threads at once. The worker renders each view
progressively, a coarse image first (1/8 of the size, one sample per pixel), then 1/4, 1/2, the full size, and
last the full render with the requested samples, which is exactly what `durer render` writes for the same view
and flags; a change of view or options starts again from the coarse level. It also polls the scene file's
modification time and reloads it; a malformed file is reported as its `FILE:LINE: message` and the last good
scene stays on screen until the file is fixed. With the denoise toggle on (path tracer only, pyoidn installed),
every level is rendered with the denoiser's features and shown denoised by OIDN, as `durer render --denoise`.
"""

from __future__ import annotations

import base64
import dataclasses
import io
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from pathlib import Path

import numpy as np
from PIL import Image

from ..errors import DurerError, MissingDependency
from ..io.images import depth_visualization, encode_srgb, normal_visualization, quantize_course
from ..io.loaders import load_scene
from ..options import RenderOptions
from ..rendering.denoise import require_oidn
from ..rendering.explain import check_integrator, explain_in
from ..rendering.explain_draw import segments
from ..rendering.raycaster import RenderContext
from ..rendering.renderer import RenderResult, denoise_result, make_context, render_in
from ..scene.graph import Scene
from .navigation import View, home_view, orbit, pan, zoom

MODES = ("color", "depth", "normals")
COARSE = (8, 4, 2, 1)  # the progressive levels' downscale factors, before the final full-quality render
MAX_SAMPLES, MAX_BOUNCES = 64, 16  # the page's limits: a preview must stay interactive


def render_view(ctx: RenderContext, width: int, height: int) -> RenderResult:
    """render_in, path tracer included: the image `durer render` writes for ctx's scene, camera and options
    (denoised when they say so, as render() does)."""
    check_integrator(ctx.bundle.materials, ctx.options)  # physically based materials need the path tracer: say so
    result = render_in(ctx, width, height)
    return denoise_result(result, ctx.bundle.materials, ctx.options) if ctx.options.denoise else result


def denoise_unavailable(options: RenderOptions) -> str | None:
    """Why the page's denoise toggle is off limits (its tooltip), or None: it needs the path tracer's noisy images
    and pyoidn."""
    if options.integrator != "path":
        return "denoising is for the path tracer's noisy images (the course's integrators have no noise to remove)"
    try:
        require_oidn()
    except MissingDependency as e:
        return str(e)
    return None


def denoised_levels(options: RenderOptions) -> list[tuple[int, RenderOptions]]:
    """levels_for with the denoiser: every level denoised as `durer render --denoise` denoises (the last level is
    its image); the levels before the last at OIDN's `fast` preset, as they are soon replaced."""
    levels = levels_for(dataclasses.replace(options, denoise=True))
    return [(f, o if i == len(levels) - 1 else dataclasses.replace(o, denoise_quality="fast"))
            for i, (f, o) in enumerate(levels)]


def levels_for(options: RenderOptions) -> list[tuple[int, RenderOptions]]:
    """The progressive levels of one view: (downscale factor, options). Coarse images of one centred sample at
    1/8, 1/4, 1/2 and the full size, then the requested options. The path tracer's full-size images instead take
    1, 2, 4, ... samples per pixel up to the requested count (each exactly `durer render --samples k`), so the
    image refines while the camera stands still."""
    if options.integrator == "path":
        one = dataclasses.replace(options, samples=1)
        levels = [(f, one) for f in COARSE[:-1]]
        k = 1
        while k < options.samples:
            levels.append((1, dataclasses.replace(options, samples=k)))
            k *= 2
        return levels + [(1, options)]
    coarse = dataclasses.replace(options, samples=1, sampler="uniform", filter="box", filter_radius=0.5)
    levels = [(f, coarse) for f in COARSE]
    if options.samples > 1 or options.filter != "box" or options.filter_radius != 0.5:
        levels.append((1, options))
    else:
        levels[-1] = (1, options)
    return levels


def encode_png(result: RenderResult, mode: str) -> bytes:
    """A render as the PNG the page shows: colour sRGB-encoded as `durer render` writes it, depth grey (near
    white, over the frame's range of hits), normals |n| per channel."""
    if mode == "color":
        pixels = encode_srgb(result.color)
    elif mode == "depth":
        finite = result.depth[np.isfinite(result.depth)]
        near, far = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        grey = quantize_course(depth_visualization(result.depth, near, far if far > near else near + 1.0))
        pixels = np.repeat(grey[:, :, None], 3, axis=2)
    elif mode == "normals":
        pixels = quantize_course(normal_visualization(result.normals))
    else:
        raise ValueError(f"unknown mode {mode!r} (use one of {', '.join(MODES)})")
    buffer = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(pixels), mode="RGB").save(buffer, format="PNG")
    return buffer.getvalue()


class PreviewSession:
    """A scene file (reloaded when it changes) or a Scene object, shown at width x height with `options`.

    Listeners (callables taking one JSON-ready dict) receive every message: frames, errors, ray trees, state.
    Control methods may be called from any thread; they only record the request and wake the worker."""

    def __init__(self, source: str | os.PathLike | Scene, width: int, height: int,
                 options: RenderOptions | None = None, mesh_path: list[str] | None = None, poll: float = 0.5):
        self.path = None if isinstance(source, Scene) else Path(source)
        self.width, self.height = int(width), int(height)
        self.options = dataclasses.replace(options) if options is not None else RenderOptions()
        self.options.validate()
        self.mesh_path, self.poll = mesh_path, poll
        self.mode = "color"
        self.denoise = False  # the page's toggle: show the path tracer's levels denoised (denoised_levels)
        self.scene: Scene | None = source if isinstance(source, Scene) else None
        self.error: str | None = None  # the scene file's FILE:LINE message while it does not load
        self.failure: str | None = None  # the last render's one-line failure, until a render works again
        self.view: View | None = None
        self.home: View | None = None
        self.tree = None
        self._context: RenderContext | None = None
        self._mtime: float | None = None
        self._generation = 0
        self._last: tuple[dict, RenderResult] | None = None
        self._jobs: list[tuple[Callable, Future]] = []
        self._listeners: list[Callable[[dict], None]] = []
        self._cond = threading.Condition()
        self._stop = False
        self._thread: threading.Thread | None = None
        if self.scene is not None:
            self._set_scene(self.scene)
        else:  # load (and compile) now, before any worker runs: the state has a camera, the terminal the error
            self._reload_if_changed()

    # --- listeners and state -----------------------------------------------------------------------------
    def subscribe(self, listener: Callable[[dict], None]) -> Callable[[], None]:
        """Add a listener; it first gets the state, then the current error or frame and tree. Returns the
        function that removes it."""
        with self._cond:
            self._listeners.append(listener)
            listener(self.state())
            if self.error is not None or self.failure is not None:
                listener({"type": "error", "message": self.error or self.failure})
            if self._last is not None:
                listener(self._last[0])
            if self.tree is not None:
                listener(self._tree_message())
        return lambda: self._unsubscribe(listener)

    def _unsubscribe(self, listener) -> None:
        with self._cond:
            if listener in self._listeners:
                self._listeners.remove(listener)

    def _send(self, message: dict) -> None:
        for listener in list(self._listeners):
            listener(message)

    def state(self) -> dict:
        """What the page's controls show: size, mode, options, the camera."""
        o = self.options
        return {"type": "state", "width": self.width, "height": self.height, "mode": self.mode,
                "samples": o.samples, "integrator": o.integrator, "bounces": o.bounces, "shadows": o.shadows,
                "shade_back": o.shade_back, "denoise": self.denoise, "denoise_unavailable": denoise_unavailable(o),
                "scene": str(self.path) if self.path else "(scene object)", "generation": self._generation,
                "camera": self.view.describe() if self.view else None}

    # --- control, from any thread ------------------------------------------------------------------------
    def _changed(self, view: View | None = None) -> None:
        with self._cond:
            if view is not None:
                self.view = view
            self._generation += 1
            self._send(self.state())
            self._cond.notify_all()

    def orbit(self, dx: float, dy: float) -> None:
        """Orbit by a drag of (dx, dy) image pixels: half a turn across the image's longer side."""
        if self.view is not None:
            scale = np.pi / max(self.width, self.height)
            self._changed(orbit(self.view, dx * scale, dy * scale, self.home.camera.up))

    def pan(self, dx: float, dy: float) -> None:
        if self.view is not None:
            self._changed(pan(self.view, dx, dy, self.width, self.height))

    def zoom(self, factor: float) -> None:
        if self.view is not None:
            self._changed(zoom(self.view, factor))

    def reset(self) -> None:
        """Back to the scene's own camera."""
        if self.home is not None:
            self._changed(self.home)

    def configure(self, mode: str | None = None, samples: int | None = None, bounces: int | None = None,
                  shadows: bool | None = None, denoise: bool | None = None) -> None:
        """Change what is shown (ValueError on a bad value, or denoise asked for where denoise_unavailable says
        why not); a mode change re-encodes the last frame."""
        if mode is not None and mode not in MODES:
            raise ValueError(f"unknown mode {mode!r} (use one of {', '.join(MODES)})")
        if samples is not None and not (isinstance(samples, int) and 1 <= samples <= MAX_SAMPLES):
            raise ValueError(f"samples must be an integer from 1 to {MAX_SAMPLES}, got {samples!r}")
        if bounces is not None and not (isinstance(bounces, int) and 0 <= bounces <= MAX_BOUNCES):
            raise ValueError(f"bounces must be an integer from 0 to {MAX_BOUNCES}, got {bounces!r}")
        if denoise and denoise_unavailable(self.options):
            raise ValueError(f"cannot denoise: {denoise_unavailable(self.options)}")
        with self._cond:
            if denoise is not None:
                self.denoise = bool(denoise)
            if samples is not None:
                self.options.samples = samples
                if self.options.sampler == "uniform" and samples > 1:
                    self.options.sampler = "jittered"  # as `durer render --samples N` does
                elif samples == 1:
                    self.options.sampler = "uniform"
            if bounces is not None:
                self.options.bounces = bounces
            if shadows is not None:
                self.options.shadows = bool(shadows)
            if mode is not None and mode != self.mode:
                self.mode = mode
                if all(v is None for v in (samples, bounces, shadows, denoise)) and self._last is not None:
                    self._send(self.state())
                    self._submit(self._reencode)
                    return
        self._changed()

    def explain(self, x: int, y: int) -> Future:
        """The ray tree of image pixel (x, y) in the current view, computed on the worker: a Future of the
        tree message (also sent to every listener)."""
        if not (0 <= x < self.width and 0 <= y < self.height):
            raise ValueError(f"pixel ({x}, {y}) is outside the {self.width}x{self.height} image")
        return self._submit(lambda: self._explain(x, y))

    def clear_tree(self) -> None:
        with self._cond:
            self.tree = None
            self._send({"type": "tree", "tree": None, "text": "", "overlay": []})

    def _submit(self, job: Callable) -> Future:
        future: Future = Future()
        with self._cond:
            self._jobs.append((job, future))
            self._cond.notify_all()
        return future

    # --- the worker --------------------------------------------------------------------------------------
    def start(self) -> PreviewSession:
        if self._thread is None:
            import numba

            # Numba's thread count is per thread: the worker renders with the caller's (`--threads N`)
            threads = numba.get_num_threads()
            self._thread = threading.Thread(target=self._run, args=(threads,), name="durer-preview-render",
                                            daemon=True)
            self._thread.start()
        return self

    def stop(self, timeout: float = 10.0) -> None:
        with self._cond:
            self._stop = True
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join(timeout)

    def _run(self, threads: int | None = None) -> None:
        if threads is not None:
            import numba

            numba.set_num_threads(threads)
        rendered = -1
        last_poll = 0.0
        while True:
            with self._cond:
                while not (self._stop or self._jobs or (rendered != self._generation and self.scene is not None)):
                    if self.path is not None and time.monotonic() - last_poll >= self.poll:
                        break
                    self._cond.wait(self.poll if self.path is not None else None)
                if self._stop:
                    return
            if self.path is not None and time.monotonic() - last_poll >= self.poll:
                last_poll = time.monotonic()
                try:
                    self._reload_if_changed()
                except Exception as e:  # a scene that loads but does not compile: say so, keep the last one
                    self._fail(e, "cannot show the scene")
            self._run_jobs()
            if self.scene is not None and rendered != self._generation:
                try:
                    rendered = self._render_progressively()
                except Exception as e:  # keep serving: say what failed (to every page, also later ones), wait
                    rendered = self._generation
                    self._fail(e)

    def _fail(self, e: Exception, what: str = "render failed") -> None:
        """A render failed: keep its one-line message, shown as an error on every page until a render works."""
        first = (str(e).strip().splitlines() or [""])[0]
        with self._cond:
            self.failure = f"{what}: {type(e).__name__}" + (f": {first}" if first else "")
            self._send({"type": "error", "message": self.failure})

    def _run_jobs(self) -> None:
        while True:
            with self._cond:
                if not self._jobs:
                    return
                job, future = self._jobs.pop(0)
            try:
                future.set_result(job())
            except Exception as e:  # reported to whoever waits on the future (the page gets a notice)
                future.set_exception(e)

    def _reload_if_changed(self) -> None:
        try:
            mtime = self.path.stat().st_mtime_ns
        except OSError as e:
            mtime, message = None, f"{self.path}: cannot read the scene file ({e.strerror or e})"
        else:
            message = None
        if mtime == self._mtime and mtime is not None:
            return
        self._mtime = mtime
        if message is None:
            try:
                scene = load_scene(self.path, self.mesh_path)
            except (DurerError, ValueError, OSError) as e:
                message = str(e)
        with self._cond:
            if message is not None:
                self.error = message
                self._send({"type": "error", "message": message})
                return
            was = self.error
            self.error = None
            if was is not None:
                self._send({"type": "error", "message": self.failure})
            self._set_scene(scene)
            if self.tree is not None:  # a tree of the old scene would mislead
                self.clear_tree()
            self._changed()

    def _set_scene(self, scene: Scene) -> None:
        """Compile the scene; keep the current view unless the file's camera changed (or there was none)."""
        old_home = self.home
        self._context = make_context(scene, self.options)
        self.scene = scene
        self.home = home_view(scene.camera, self._context.compiled.bounds())
        if self.view is None or old_home is None or old_home.describe() != self.home.describe():
            self.view = self.home

    def _context_for(self, options: RenderOptions) -> RenderContext:
        # the same compiled bundle and accelerator through the view's camera; prepared afresh for these options
        ctx = self._context
        return RenderContext(bundle=ctx.bundle, camera=self.view.camera, accel=ctx.accel, options=options,
                             derived=ctx.derived)

    def _render_progressively(self) -> int:
        """Render the levels of the current generation; stop early when it changes. Returns the generation the
        last level belonged to (the current one when all were rendered)."""
        with self._cond:
            generation = self._generation
            options = dataclasses.replace(self.options)
            denoise = self.denoise and not denoise_unavailable(options)
        levels = denoised_levels(options) if denoise else levels_for(options)
        for i, (factor, opts) in enumerate(levels):
            w, h = max(1, -(-self.width // factor)), max(1, -(-self.height // factor))
            start = time.perf_counter()
            result = render_view(self._context_for(opts), w, h)
            final = i == len(levels) - 1
            with self._cond:
                if generation != self._generation:
                    return -1
                if self.failure is not None:  # rendering works again: take the message away
                    self.failure = None
                    if self.error is None:
                        self._send({"type": "error", "message": None})
                message = {"type": "frame", "generation": generation, "level": i, "levels": len(levels),
                           "final": final, "samples": opts.samples, "frame_width": w, "frame_height": h,
                           "width": self.width, "height": self.height, "seconds": time.perf_counter() - start,
                           "denoised": opts.denoise, "denoise_seconds": result.denoise_seconds}
                self._last = (message, result)
                self._send(self._encoded(message, result))
                if self.tree is not None and i == 0:
                    self._send(self._tree_message())  # the tree is 3D: redraw it through the new camera
            self._run_jobs()
        return generation

    def _encoded(self, message: dict, result: RenderResult) -> dict:
        message = dict(message, mode=self.mode, camera=self.view.describe())
        message["png"] = base64.b64encode(encode_png(result, self.mode)).decode("ascii")
        self._last = (message, result)
        return message

    def _reencode(self) -> None:
        with self._cond:
            if self._last is not None:
                self._send(self._encoded(*self._last))

    def _explain(self, x: int, y: int) -> dict:
        if self.scene is None:
            raise ValueError(self.error or "no scene loaded")
        tree = explain_in(self._context_for(dataclasses.replace(self.options)), self.width, self.height, x, y)
        with self._cond:
            self.tree = tree
            message = self._tree_message()
            self._send(message)
        return message

    def _tree_message(self) -> dict:
        overlay = [[key, [[(round(x, 2), round(y, 2)) for x, y in line] for line in lines]]
                   for key, lines in segments(self.tree, self.view.camera)]
        return {"type": "tree", "tree": self.tree.to_json(), "text": self.tree.text(), "overlay": overlay}
