"""render(): a scene and an image size in, colour, depth and normal arrays out: the arguments resolved
(arguments.py), the memory checked (memory.py), the scene prepared and its units of work run and finished
(units.py) under a progress bar (progress.py)."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from ..options import RenderOptions
from ..scene.graph import Scene
from .arguments import make_options, parse_filter
from .arguments import resolve as resolve_arguments
from .context import RenderContext, make_context
from .integrators import integrator_for
from .kernel_cache import compile_notice
from .memory import BYTES_PER_PIXEL, check_size, memory_needed
from .progress import progress as _progress
from .result import RenderResult
from .units import finish, job_for, run

# the names the command line, the preview and the tests take from here (each lives in its own module)
__all__ = ["BYTES_PER_PIXEL", "RenderResult", "check_size", "choose_integrator", "denoise_result", "make_context",
           "make_options", "memory_needed", "parse_filter", "render", "render_in", "resolve"]


def choose_integrator(options: RenderOptions):
    """The integrator function the options choose (integrators.integrator_for): `trace(ctx, origins, directions,
    t_min, pixel=None, sample=None) -> SampleResult`."""
    return integrator_for(options).trace


def render(scene: Scene, width: int | None = None, height: int | None = None, *,
           options: RenderOptions | None = None, quiet: bool = True, **kwargs) -> RenderResult:
    """Render `scene` at width x height; keyword arguments are RenderOptions fields (shade_back, shadows,
    bounces, weight, samples, sampler, filter, seed, integrator, max_depth, ...). Returns colour, depth and normal
    arrays. A scene's own render defaults (Mitsuba scenes: integrator, sampler, film) apply unless given here."""
    width, height, options = resolve(scene, width, height, options, **kwargs)
    start = time.perf_counter()
    if not quiet:  # one line saying what compiles and for how long, when Numba's cache lacks it (kernel_cache.py)
        compile_notice(options, scene)
    ctx = make_context(scene, options)
    result = render_in(ctx, width, height, quiet=quiet, start=start)
    if options.denoise:
        denoise_result(result, ctx.bundle.materials, options)
        result.seconds = time.perf_counter() - start
    return result


def resolve(scene: Scene, width: int | None = None, height: int | None = None, options: RenderOptions | None = None,
            **kwargs) -> tuple[int, int, RenderOptions]:
    """render()'s arguments checked over the scene's own defaults, memory included: (width, height, options);
    ValueError naming what is wrong. With denoise, pyoidn is required here (before anything is rendered). Shared
    with durer.dask.render and the frames command, so they render what render() renders."""
    width, height, options = resolve_arguments(scene, width, height, options, kwargs)
    check_size(width, height, options.samples, options)
    if options.denoise:
        from .denoise import require_oidn

        require_oidn()
    return width, height, options


def denoise_result(result: RenderResult, materials: Sequence, options: RenderOptions) -> RenderResult:
    """Replace the colour of a render with options.denoise (box-filtered, the directly seen emission left out:
    rendering/denoise.py) by OIDN's output (with the albedo and normal features), blended with the noisy colour
    where it strays beyond the noise (denoise.blend), filtered by the scene's filter, plus that emission (filmed by
    the scene's filter); in place. `materials`: the scene's (a compiled bundle's), which say whether the features
    are clean."""
    from .denoise import MOMENT, blend, clean_features, denoise, refilter, split_part

    done = denoise(result.color, result.albedo, result.shading_normals,
                   clean=clean_features(materials, options.integrator == "path"), quality=options.denoise_quality)
    start = time.perf_counter()
    color = done.color
    if result.aovs.get(MOMENT) is not None:
        color = blend(color, result.color, result.aovs[MOMENT], options.samples)
    color, direct = refilter(color, options), split_part(result.aovs)
    result.color = color if direct is None else color + np.nan_to_num(direct, posinf=0.0)
    result.denoise_seconds = done.seconds + time.perf_counter() - start
    return result


def render_in(ctx: RenderContext, width: int, height: int, *, quiet: bool = True,
              start: float | None = None) -> RenderResult:
    """render() with a prepared context: the preview renders many views of one compiled scene (ctx.camera is the
    one used, so a view is RenderContext(the same bundle and accel, another camera)).
    It is the units of work of units.py run here: prepare, every unit, finish."""
    start = time.perf_counter() if start is None else start
    job = job_for(ctx, width, height)
    with _progress(width * height * ctx.options.samples, quiet) as bar:
        acc = run(job, bar=bar)
    result = finish(job, acc)
    result.seconds = time.perf_counter() - start
    return result


