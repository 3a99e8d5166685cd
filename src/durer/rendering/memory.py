"""The memory check: what a render will allocate at its peak, refused before anything is allocated when the
machine does not have it. A render holds the image's per-pixel sums and a few bounded units of work
(units.py), so the need grows with the pixels and not with the sample count."""

from __future__ import annotations

import os

from ..options import RenderOptions
from .film import support_radius
from .integrators import PATH, RAYCAST, WHITTED, integrator_for
from .units import plan

# measured (peak RSS of `durer render`, spheres.txt and cornell_box.xml): 180 MB at 16 x 16, +122 bytes a pixel
# from 1024^2 to 2048^2 pixels, +50 MB for two path-tracing units of 2^18 samples over one of 2^16
BYTES_PER_PIXEL = 130   # the image's float64 sums (colour, weight), depth, normal and centre distance; the result
BYTES_PER_SAMPLE = 200  # a unit's film points, rays, pixel and sample ids, per-sample colour, t and normal
BASE_BYTES = 200 << 20  # Python, NumPy, Numba and the compiled kernels


def memory_needed(width: int, height: int, samples: int = 1, options: RenderOptions | None = None) -> int:
    """Bytes a render allocates at its peak: the image's accumulators (O(pixels)) and, for each unit traced at
    once, its samples (tile and halo x one pass, units.plan) and one batch of the integrator's working memory. It
    does not grow with the sample count beyond one pass. Without options: the most any integrator needs."""
    radius = support_radius(options) if options is not None else 0
    side, per_pass = plan(samples, radius)
    unit = per_pass * (side + 2 * radius) ** 2
    if options is not None and options.stats and radius:
        unit = per_pass * width * height  # a counted render with a wide filter is one tile (units.job_for)
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
