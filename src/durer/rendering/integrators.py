"""The integrators a render can use, behind one interface: what colour each camera ray brings back.

Every integrator is `trace(ctx, origins, directions, t_min, pixel=None, sample=None) -> SampleResult` for camera
rays (N,3) of film samples (pixel (N,) flat index, sample (N,) index within the pixel: the path tracer keys its
random numbers by them; the others ignore them). `Integrator` adds what the driver needs to know about it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..options import RenderOptions
from .grid_view import visualize_grid
from .path import path_trace, prepare_path
from .raycaster import raycast
from .whitted import whitted

CHUNK = 1 << 13  # rays per batch: enough to keep the kernels busy, few enough for a live progress bar
PATH_BATCH = 1 << 16  # paths per wavefront: 2^14 -> 2^16 measured 1.5x faster (fewer, longer kernel calls)


@dataclass(frozen=True)
class Integrator:
    """An integrator and how to drive it: `batch` rays per call (its working memory grows with it), `workers`
    units traced at once by the local driver (each with its share of the threads), `bytes_per_ray` of working
    memory per ray of a batch (the memory check, measured), `prepare(ctx)`, run once per render by
    units.prepare, for what it gathers from the compiled bundle and the accelerator (none for the Phong
    integrators, which read the bundle's tables as they are), and `sobol`: its film samples are placed by its own
    Owen-scrambled Sobol pairs, keyed like its other random numbers, whatever the sampler (film.uses_sobol)."""

    name: str
    trace: Callable
    batch: int = CHUNK
    workers: int = 1
    bytes_per_ray: int = 1200
    prepare: Callable | None = None  # gathers what it reads besides the context, once per render (ctx.prepared)
    sobol: bool = False  # film samples from the integrator's Sobol stream (sampling.py), not options.sampler


RAYCAST = Integrator("raycast", raycast, bytes_per_ray=600)
WHITTED = Integrator("whitted", whitted, bytes_per_ray=2000)
GRID = Integrator("grid", visualize_grid, bytes_per_ray=600)
# two wavefronts at once (the kernels free the GIL), each bounce's kernels on the threads left to it: two on two
# cores each splitting its bounces over both threads took 1.35x the wall time (caustic scene, 32 spp)
PATH = Integrator("path", path_trace, batch=PATH_BATCH, workers=2, bytes_per_ray=1200, prepare=prepare_path,
                  sobol=True)


def integrator_for(options: RenderOptions) -> Integrator:
    """The one options.integrator names; "auto": the lecture's ray caster unless the options ask for secondary rays
    (Whitted) or for the course's grid cells (-visualize_grid)."""
    if options.integrator == "path":
        return PATH
    if options.integrator == "raycast":
        return RAYCAST
    if options.integrator == "whitted":
        return WHITTED
    if options.visualize_grid:
        return GRID
    if options.shadows or options.bounces > 0:
        return WHITTED
    return RAYCAST
