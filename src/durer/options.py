"""RenderOptions: every switch of a render. The course's flags and the modern ones both map onto these."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

SAMPLERS = ("uniform", "random", "jittered")
COURSE_FILTERS = ("box", "tent", "gaussian")  # the course's (radial tent, gaussian cut at 2 sigma): -box_filter ...
# Mitsuba 3's, separable (rendering/film.py)
FILTERS = COURSE_FILTERS + ("mitchell", "catmullrom", "lanczos", "mitsuba_gaussian")
# how far each filter reaches, in multiples of filter_radius
_REACH = {"gaussian": 2.0, "mitsuba_gaussian": 4.0}
ACCELERATORS = ("bvh", "brute")
INTEGRATORS = ("auto", "raycast", "whitted", "path")
# Sizes checked before any work starts (issue 25): a filter's reach in pixels (box/tent radius, gaussian 2 sigma:
# the film visits (2 reach + 1)^2 pixels per sample, and gaussian:200 ran for minutes on a 32 x 32 image; the
# course's widest is 2.3), and the uniform grid's cells (a few int64 arrays of that length; 1000^3 took 16.7 GB)
MAX_FILTER_REACH = 16.0
MAX_GRID_CELLS = 1 << 24
DENOISE_QUALITIES = ("high", "balanced", "fast")  # Open Image Denoise's presets, slowest and best first


@dataclass
class RenderOptions:
    """Options of one render; defaults give the lecture's ray caster (one centred ray per pixel, no shadows)."""

    shade_back: bool = False      # light both sides of surfaces (-shade_back); else back faces are black
    shadows: bool = False         # cast shadow rays to every light (-shadows)
    bounces: int = 0              # maximum depth of reflection/refraction rays (-bounces)
    weight: float = 0.01          # stop rays whose contribution falls below this (-weight)
    samples: int = 1              # samples per pixel
    sampler: str = "uniform"      # uniform | random | jittered (one centred sample when samples == 1 and uniform)
    filter: str = "box"           # box | tent | gaussian | mitchell | catmullrom | lanczos | mitsuba_gaussian (film.py)
    filter_radius: float = 0.5    # box/tent/mitchell/catmullrom radius, lanczos lobes, or gaussian sigma, in pixels
    filter_b: float = 1.0 / 3.0   # mitchell: Mitsuba's B and C of the Mitchell-Netravali cubic (defaults 1/3 each)
    filter_c: float = 1.0 / 3.0
    seed: int = 0                 # seed of the random and jittered samplers: same seed, same image
    course_random: bool = False   # random/jittered offsets from the course's drand48 stream instead (film.py)
    course_edges: bool = False    # triangles accept points just outside their edges, as the course's do (compile.py)
    accel: str = "bvh"            # bvh | brute: the bounding volume hierarchy, or the lecture's loop over every object
    grid: tuple[int, int, int] | None = None  # use the course's uniform grid instead of the BVH (-grid)
    visualize_grid: bool = False  # draw the grid's occupied cells instead of the objects (-visualize_grid)
    stats: bool = False           # count rays, intersections and grid cells (-stats)
    # the path tracer (rendering/path.py); "auto" is the ray caster, or Whitted with shadows or bounces
    integrator: str = "auto"      # auto | raycast | whitted | path
    max_depth: int = -1           # path: Mitsuba's max_depth (1 emitters only, 2 direct light, -1 unbounded)
    rr_depth: int = 5             # path: Russian roulette from this depth on
    hide_emitters: bool = False   # path: camera rays do not see emitters (nor the environment)
    # the denoiser's features and Intel Open Image Denoise (rendering/denoise.py)
    aovs: bool = False            # also produce albedo and shading normals (RenderResult.albedo, .shading_normals)
    denoise: bool = False         # denoise the colour with OIDN's RT filter (needs pyoidn; implies aovs)
    denoise_quality: str = "high"  # high | balanced | fast: OIDN's preset (time against error: benchmarks/README.md)
    aov_outputs: tuple[str, ...] = ()  # outputs `durer render` writes beside the image (a Mitsuba aov integrator's)
    hit_aovs: bool = False        # also produce position and uv of each pixel's first hit (RenderResult.position, .uv)
    # the film (Mitsuba's hdrfilm): render only the window (x, y, width, height) of the image, in pixels from its
    # top-left corner (crop_offset_x/y, crop_width/height), and an alpha channel: the filter-weighted share of
    # samples whose camera ray hit something (pixel_format rgba)
    crop: tuple[int, int, int, int] | None = None
    alpha: bool = False

    def filter_reach(self) -> float:
        """How far from a pixel centre the filter weighs samples, in pixels: r (box, tent, mitchell, catmullrom,
        lanczos), 2 sigma (the course's gaussian) or 4 sigma (Mitsuba's)."""
        return self.filter_radius * _REACH.get(self.filter, 1.0)

    def validate(self) -> None:
        """ValueError naming the first option out of its range (sizes included: see MAX_FILTER_REACH)."""
        if self.bounces < 0:
            raise ValueError(f"bounces must not be negative, got {self.bounces}")
        if not self.weight >= 0:
            raise ValueError(f"weight must not be negative, got {self.weight}")
        if self.samples < 1:
            raise ValueError(f"samples must be at least 1, got {self.samples}")
        if self.sampler not in SAMPLERS:
            raise ValueError(f"unknown sampler {self.sampler!r} (use one of {', '.join(SAMPLERS)})")
        if self.filter not in FILTERS:
            raise ValueError(f"unknown filter {self.filter!r} (use one of {', '.join(FILTERS)})")
        if not self.filter_radius > 0:
            raise ValueError(f"filter radius must be positive, got {self.filter_radius}")
        if not (abs(self.filter_b) < float("inf") and abs(self.filter_c) < float("inf")):
            raise ValueError(f"mitchell's B and C must be finite numbers, got {self.filter_b}, {self.filter_c}")
        if not self.filter_reach() <= MAX_FILTER_REACH:
            what = "sigma" if "gaussian" in self.filter else "radius"
            most = MAX_FILTER_REACH / _REACH.get(self.filter, 1.0)
            raise ValueError(f"{self.filter} filter {what} {self.filter_radius:g} is too wide: at most {most:g} "
                             f"pixels (a wider filter is a blur; its cost grows with the square of the width)")
        if self.accel not in ACCELERATORS:
            raise ValueError(f"unknown accelerator {self.accel!r} (use one of {', '.join(ACCELERATORS)})")
        if self.grid is not None and self.accel != "bvh":
            raise ValueError(f"the course's grid replaces the accelerator: give grid or accel={self.accel!r}, not both")
        if self.integrator not in INTEGRATORS:
            raise ValueError(f"unknown integrator {self.integrator!r} (use one of {', '.join(INTEGRATORS)})")
        if int(self.max_depth) != self.max_depth or self.max_depth < -1:
            raise ValueError(f"max_depth must be -1 (unbounded) or a non-negative integer, got {self.max_depth}")
        if int(self.rr_depth) != self.rr_depth or self.rr_depth < 1:
            raise ValueError(f"rr_depth must be a positive integer, got {self.rr_depth}")
        if self.denoise_quality not in DENOISE_QUALITIES:
            raise ValueError(f"unknown denoise quality {self.denoise_quality!r} (use one of "
                             f"{', '.join(DENOISE_QUALITIES)})")
        if self.grid is not None:
            check_grid(self.grid)
        if self.crop is not None and (len(self.crop) != 4 or any(int(v) != v for v in self.crop)
                                      or min(self.crop[:2]) < 0 or min(self.crop[2:]) < 1):
            raise ValueError(f"crop is (x, y, width, height): offsets >= 0 and sizes >= 1, got {self.crop}")


def check_grid(dims) -> None:
    """ValueError unless dims are three positive cell counts of at most MAX_GRID_CELLS cells in all."""
    if len(dims) != 3 or min(dims) < 1:
        raise ValueError(f"grid needs three positive cell counts, got {tuple(dims)}")
    cells = int(dims[0]) * int(dims[1]) * int(dims[2])
    if cells > MAX_GRID_CELLS:
        raise ValueError(f"grid {' x '.join(str(int(n)) for n in dims)} has {cells:,} cells: at most "
                         f"{MAX_GRID_CELLS:,} (the course's largest has 52,800)")


@contextmanager
def thread_count(nthreads: int | None) -> Iterator[None]:
    """Run the block on `nthreads` threads (0: every core Numba started with; None: leave it), restored after:
    `--threads N` of every command and `durer.render(nthreads=N)`. numba.set_num_threads holds for the calling
    thread and the kernels it starts (a worker thread takes the count over itself: preview/session.py)."""
    if nthreads is None:
        yield
        return
    if isinstance(nthreads, bool) or int(nthreads) != nthreads or nthreads < 0:
        raise ValueError(f"nthreads must be 0 (all cores) or a positive integer, got {nthreads!r}")
    import numba

    most = numba.config.NUMBA_NUM_THREADS
    old = numba.get_num_threads()
    numba.set_num_threads(min(int(nthreads), most) if nthreads else most)
    try:
        yield
    finally:
        numba.set_num_threads(old)
