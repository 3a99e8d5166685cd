"""render(): a scene and an image size in, colour, depth and normal arrays out."""

from __future__ import annotations

import os
import sys
import time
from dataclasses import fields

from ..options import RenderOptions
from ..scene.bsdfs import BSDF, Surface
from ..scene.graph import Scene
from .integrators import integrator_for
from .raycaster import RenderContext
from .result import RenderResult
from .units import job_for, make_context, plan, run

__all__ = ["RenderResult", "check_size", "make_context", "make_options", "render", "render_in", "resolve"]

PHYSICAL = (Surface, *BSDF.__args__)  # materials only the path tracer renders


def choose_integrator(options: RenderOptions):
    """The integrator function the options choose (integrators.integrator_for): `trace(ctx, origins, directions,
    t_min, pixel=None, sample=None) -> SampleResult`."""
    return integrator_for(options).trace


class _NoBar:
    """The disabled progress bar: tqdm's interface without importing tqdm (27 ms of every CLI start-up)."""

    disable = True

    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> _NoBar:
        return self

    def __exit__(self, *exc) -> None:
        pass


def _progress(total: int, quiet: bool, unit: str = "ray"):
    """A progress bar on stderr that appears only after a second, and never when quiet or not on a terminal."""
    if quiet or not sys.stderr.isatty():
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, unit_scale=unit == "ray", delay=1.0, disable=False, leave=False,
                desc="rendering", file=sys.stderr)


def parse_filter(spec: str) -> tuple[str, float | None]:
    """'gaussian:0.4' -> ('gaussian', 0.4); 'tent' -> ('tent', None)."""
    name, _, width = spec.partition(":")
    if not width:
        return name, None
    try:
        return name, float(width)
    except ValueError:
        raise ValueError(f"filter width is not a number: {spec!r}") from None


def make_options(options: RenderOptions | None = None, **kwargs) -> RenderOptions:
    """RenderOptions from keyword arguments (those of RenderOptions; `filter` may be 'name' or 'name:width')."""
    if options is not None and kwargs:
        raise TypeError("pass either options or keyword arguments, not both")
    if options is None:
        known = {f.name for f in fields(RenderOptions)}
        unknown = set(kwargs) - known
        if unknown:
            raise TypeError(f"unknown render option(s): {', '.join(sorted(unknown))}")
        if isinstance(kwargs.get("filter"), str) and ":" in kwargs["filter"]:
            kwargs["filter"], kwargs["filter_radius"] = parse_filter(kwargs["filter"])
        options = RenderOptions(**kwargs)
    options.validate()
    return options


def render(scene: Scene, width: int | None = None, height: int | None = None, *,
           options: RenderOptions | None = None, quiet: bool = True, **kwargs) -> RenderResult:
    """Render `scene` at width x height; keyword arguments are RenderOptions fields (shade_back, shadows,
    bounces, weight, samples, sampler, filter, seed, integrator, max_depth, ...). Returns colour, depth and normal
    arrays. A scene's own render defaults (Mitsuba scenes: integrator, sampler, film) apply unless given here."""
    width, height, options = resolve(scene, width, height, options, **kwargs)
    start = time.perf_counter()
    if not quiet and kernels_cold():
        print("durer: compiling kernels (first run only) ...", file=sys.stderr, flush=True)
    return render_in(make_context(scene, options), width, height, quiet=quiet, start=start)


def resolve(scene: Scene, width: int | None, height: int | None, options: RenderOptions | None = None,
            **kwargs) -> tuple[int, int, RenderOptions]:
    """render()'s arguments checked, over the scene's own defaults: (width, height, options); ValueError naming
    what is wrong. Shared with durer.dask.render, so both render the same image from the same arguments."""
    defaults = dict(getattr(scene, "render_defaults", None) or {})
    width = width if width is not None else defaults.get("width")
    height = height if height is not None else defaults.get("height")
    if width is None or height is None:
        raise ValueError("give the image size (width, height): the scene does not define one")
    if options is None:
        kwargs = {**{k: v for k, v in defaults.items() if k not in ("width", "height")}, **kwargs}
    if int(width) != width or int(height) != height or width < 1 or height < 1:
        raise ValueError(f"image size must be positive integers, got {width} x {height}")
    width, height = int(width), int(height)
    options = make_options(options, **kwargs)
    check_size(width, height, options.samples, options)
    if options.integrator != "path" and any(isinstance(m, PHYSICAL) for m in scene.materials):
        raise ValueError("the scene has physically based materials (a Mitsuba scene): render it with "
                         "integrator='path'")
    return width, height, options


def render_in(ctx: RenderContext, width: int, height: int, *, quiet: bool = True,
              start: float | None = None) -> RenderResult:
    """render() with a prepared context: the preview renders many views of one compiled scene (ctx.scene's camera
    is the one used, so a view is RenderContext(scene with another camera, the same compiled scene and accel)).
    It is the units of work of units.py run here: prepare, every unit, finish."""
    from .units import finish

    start = time.perf_counter() if start is None else start
    job = job_for(ctx, width, height)
    with _progress(width * height * ctx.options.samples, quiet) as bar:
        acc = run(job, bar=bar)
    result = finish(job, acc)
    result.seconds = time.perf_counter() - start
    return result


# measured (peak RSS of `durer render`, spheres.txt and cornell_box.xml): 180 MB at 16 x 16, +122 bytes a pixel
# from 1024^2 to 2048^2 pixels, +50 MB for two path-tracing units of 2^18 samples over one of 2^16
BYTES_PER_PIXEL = 130   # the image's float64 sums (colour, weight), depth, normal and centre distance; the result
BYTES_PER_SAMPLE = 200  # a unit's film points, rays, pixel and sample ids, per-sample colour, t and normal
BASE_BYTES = 200 << 20  # Python, NumPy, Numba and the compiled kernels


def memory_needed(width: int, height: int, samples: int = 1, options: RenderOptions | None = None) -> int:
    """Bytes a render allocates at its peak: the image's accumulators (O(pixels)) and, for each unit traced at
    once, its samples (tile and halo x one pass, units.plan) and one batch of the integrator's working memory. It
    does not grow with the sample count beyond one pass. Without options: the most any integrator needs."""
    from .film import support_radius
    from .integrators import PATH, RAYCAST, WHITTED

    radius = support_radius(options) if options is not None else 0
    side, per_pass = plan(samples, radius)
    unit = per_pass * (side + 2 * radius) ** 2
    chosen = [integrator_for(options)] if options is not None else [RAYCAST, WHITTED, PATH]
    units = max(i.workers * (unit * BYTES_PER_SAMPLE + i.batch * i.bytes_per_ray) for i in chosen)
    return BASE_BYTES + width * height * BYTES_PER_PIXEL + units


def check_size(width: int, height: int, samples: int = 1, options: RenderOptions | None = None) -> None:
    """ValueError before anything is allocated if the render would need more memory than the machine has."""
    need = memory_needed(width, height, samples, options)
    have = physical_memory()
    if have and need > have:
        raise ValueError(f"a {width} x {height} image with {samples} sample(s) per pixel would need about "
                         f"{_human(need)} of memory; this machine has {_human(have)}")


def physical_memory() -> int:
    """Bytes of physical memory (0 if the platform does not say)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        return 0


def _human(n: float) -> str:
    for unit in ("bytes", "KB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "bytes" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} PB"


COLD_CHECK = ("build", "trace")  # kernel modules every render compiles and caches


def kernels_cold(folder: str | None = None) -> bool:
    """Is Numba's on-disk cache of the kernels still empty (the first render will compile for many seconds)?
    Cheap: looks for the cache's index files (*.nbi) beside the kernels, in kernels/bvh/__pycache__."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False  # a cache elsewhere: cannot tell cheaply, stay quiet
    if folder is None:
        from ..kernels import bvh

        folder = os.path.join(os.path.dirname(bvh.__file__), "__pycache__")
    try:
        names = os.listdir(folder)
    except OSError:
        return True
    return not all(any(n.startswith(m + ".") and n.endswith(".nbi") for n in names) for m in COLD_CHECK)
