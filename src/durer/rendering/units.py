"""The unit of work of a render: (tile, sample range) -> Accumulators, one call that can run anywhere.

    job = prepare(scene, width, height, options)           # compile, accelerator, camera, integrator and its
                                                            # tables: picklable
    acc = Accumulators.empty(job)                           # the whole image's sums
    for tile, samples in job.units():                       # any order across tiles; a tile's ranges ascending
        acc.add(render_unit(job, tile, samples))           # anywhere: a thread, a process, a Dask worker
    result = finish(job, acc)                               # durer.render(scene, ...) to the bit

A unit traces the film samples `samples` (a range of sample indices) of its tile's pixels *and of the halo
around it* (the pixels within the filter's support radius), in batches of the integrator's size, and gathers
them through the reconstruction filter into the tile's per-pixel sums: filter-weighted colour (and every other
per-sample output of the integrator, e.g. albedo), the weights, and the depth and normal of the sample nearest
each pixel's centre (with options.hit_aovs also its first hit's position and UV: hit_aovs.py). Memory is
O(tile x samples of a pass + batch), never O(image x samples).

Why the halo is traced rather than splatted across tiles: a pixel's sums then come from one unit, added in one
fixed order (neighbour pixels row-major, then their samples in order: film.reconstruct's order), so the image is
the same to the bit whatever the tile size, the batch size and the thread count, and the same as reconstructing
all the samples at once. Splatting a tile's samples into its neighbours' pixels would add partial sums of
different tiles, which depends on the tiling (float addition is not associative). The price is tracing each
halo sample once more per tile that needs it: nothing for the default box filter (support radius 0); for a
radius-1 tent or gaussian on the tiles plan() picks, 3% more rays at 16 spp and at most 13% at any count (a
pass holds few enough samples that the tile stays 32 radii wide within a unit's memory bound).

Sample ranges of one tile add (Accumulators.add) in ascending order; the canonical decomposition (Job.units)
uses the passes plan() gives for the sample count and filter: one pass, film.reconstruct's bits, up to 4096
samples with the box filter, 226 with a radius-1 tent or gaussian, 56 with radius 2. Splitting the samples
otherwise (progressive refinement: Job.refinement) gives the same image up to the rounding of the sums'
association. run() is the local driver: the canonical units on threads, added in order.
Every sample is keyed by (pixel, sample index) (film.tile_offsets, the path tracer's random streams), so a halo
pixel's samples are the same in every unit that traces them. A denoised render (options.denoise) films the
denoiser's inputs with a one-pixel box and the part of the colour it adds back with the scene's filter
(_gather_denoised, rendering/denoise.py).
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, fields, replace

import numba as nb
import numpy as np

from ..kernels.bvh.layout import TILE
from ..options import RenderOptions
from ..scene.cameras import image_camera
from ..scene.graph import Scene
from . import film
from .context import RenderContext, SampleResult, make_context
from .denoise import MOMENT, PIXEL_FILTER, SPLIT
from .heap import keep_freed_memory
from .hit_aovs import WIDTH as HIT_WIDTH
from .hit_aovs import hit_points
from .integrators import Integrator, integrator_for
from .result import RenderResult

UNIT_SAMPLES = 1 << 18  # samples a unit traces (halo included) when the tile can be that small: its memory bound
PASS = 4096             # samples per pixel of one pass of the canonical decomposition
MAX_TILE = 256          # tile side at most: enough units for two workers and a live progress bar
UNITS_PER_THREAD = 2    # a box-filtered image is cut into at least this many tiles per thread where it is large enough
MIN_SHARED_SIDE = 32    # ... but not into tiles under this side: a unit's fixed costs would show
HALO_SIDES = 32         # a tile is at least this many filter radii wide: ((32 + 2) / 32)^2 = 1.13x the rays at most
BASE = ("color", "t", "normal")  # SampleResult's own fields; any other non-None (N,k) field is an AOV
SPLIT_WEIGHT = "split_weight"  # a denoised render's channel: the scene filter's weights of the split part's samples
_NO_SPLIT = np.zeros((1, 0))  # film.pack's split when nothing is kept out
UNREAD = ("environment",)  # a denoised render films these only when options.aovs asks: nothing reads them


@dataclass(frozen=True)
class Tile:
    """A rectangle of pixels: top row, left column, rows and columns (row 0 at the top of the image)."""

    row: int
    col: int
    rows: int
    cols: int

    @property
    def rect(self) -> tuple[int, int, int, int]:
        return self.row, self.col, self.rows, self.cols

    @property
    def pixels(self) -> int:
        return self.rows * self.cols

    def grown(self, radius: int, width: int, height: int) -> Tile:
        """The tile with `radius` more pixels on each side, cropped to the image."""
        r0, c0 = max(0, self.row - radius), max(0, self.col - radius)
        r1, c1 = min(height, self.row + self.rows + radius), min(width, self.col + self.cols + radius)
        return Tile(r0, c0, r1 - r0, c1 - c0)

    def inside(self, outer: Tile) -> tuple[slice, slice]:
        """This tile's rows and columns within `outer`'s arrays."""
        r, c = self.row - outer.row, self.col - outer.col
        if r < 0 or c < 0 or r + self.rows > outer.rows or c + self.cols > outer.cols:
            raise ValueError(f"{self} does not lie inside {outer}")
        return slice(r, r + self.rows), slice(c, c + self.cols)


def plan(samples: int, radius: int) -> tuple[int, int]:
    """(tile side, samples per pass). The tile side (a multiple of 4, so 1-spp batches are whole 4 x 4 packets; at
    most MAX_TILE) is the largest whose pixels and halo hold UNIT_SAMPLES samples of a pass: only memory and
    speed depend on it, never the image. Passes hold at most PASS samples, and with a filter halo few enough
    that the tile stays HALO_SIDES halo widths wide (its halo then adds at most 13% rays), split evenly; the
    passes depend on the sample count and filter alone, so the image does too (one pass up to 226 samples for a
    radius-1 filter, 56 for radius 2, 4096 for the box)."""
    limit = PASS if not radius else max(1, UNIT_SAMPLES // ((HALO_SIDES + 2) * radius) ** 2)
    passes = -(-samples // min(samples, PASS, limit))
    per_pass = -(-samples // passes)
    side = (math.isqrt(UNIT_SAMPLES // per_pass) - 2 * radius) // TILE * TILE
    return max(TILE, min(MAX_TILE, side)), per_pass


def tiles(width: int, height: int, side: int) -> list[Tile]:
    """The image cut into tiles at most side x side, row-major: as few per axis as that allows, and as even as
    whole multiples of 4 allow (of 1 where side is not one), so the units threads share are of equal work (a
    128-pixel row cut at 124 would give one thread 124 columns and the other 4)."""
    def step(extent: int) -> int:
        even = -(-extent // -(-extent // side))  # ceil(extent / the fewest pieces of at most side)
        return -(-even // TILE) * TILE if side % TILE == 0 else even
    rows, cols = step(height), step(width)
    return [Tile(r, c, min(rows, height - r), min(cols, width - c))
            for r in range(0, height, rows) for c in range(0, width, cols)]


@dataclass
class Job:
    """A prepared render: everything a unit needs (compiled scene, accelerator, options, camera, integrator) and
    nothing tied to this process, so it pickles to other processes and machines."""

    ctx: RenderContext
    width: int
    height: int
    camera: object
    integrator: Integrator
    tile_side: int
    pass_samples: int

    @property
    def options(self) -> RenderOptions:
        return self.ctx.options

    @property
    def tile(self) -> Tile:
        """What is rendered, as one tile: the whole image, or its crop window (options.crop). The window's pixels
        keep their place in the image (their samples, rays and filter halo), so they are the whole image's."""
        if self.options.crop is None:
            return Tile(0, 0, self.height, self.width)
        x, y, w, h = (int(v) for v in self.options.crop)
        return Tile(y, x, h, w)

    def tiles(self) -> list[Tile]:
        window = self.tile
        return [Tile(t.row + window.row, t.col + window.col, t.rows, t.cols)
                for t in tiles(window.cols, window.rows, self.tile_side)]

    def units(self) -> list[tuple[Tile, range]]:
        """The canonical decomposition: passes of pass_samples samples, each over every tile (row-major)."""
        n = self.options.samples
        passes = [range(s, min(n, s + self.pass_samples)) for s in range(0, n, self.pass_samples)]
        return [(tile, samples) for samples in passes for tile in self.tiles()]

    def refinement(self) -> list[list[tuple[Tile, range]]]:
        """Passes for progressive refinement: samples [0,1), [1,2), [2,4), [4,8), ... (at most pass_samples
        each), every pass over every tile. finish() of the sums after any pass is the image of the samples so
        far; after the last it is durer.render's image up to the rounding of the sums' association."""
        n, passes, start = self.options.samples, [], 0
        while start < n:
            stop = min(n, start + max(1, min(start, self.pass_samples)))
            passes.append([(tile, range(start, stop)) for tile in self.tiles()])
            start = stop
        return passes


def _shared_side(side: int, width: int, height: int) -> int:
    """A haloless (box-filtered) image's tile side, halved (to multiples of TILE, not below MIN_SHARED_SIDE) until
    the image has UNITS_PER_THREAD tiles per Numba thread: a small image is then several units whose Python and
    NumPy steps overlap on the unit threads instead of one unit whose kernels alone run in parallel (128 x 128
    box-filtered Mitsuba scenes at 16 spp: 0.72-0.89x the wall time; the image is the same to the bit). Haloed
    tiles are left as planned: their halo's extra rays cost what the overlap saves."""
    want = UNITS_PER_THREAD * nb.get_num_threads()
    while side > MIN_SHARED_SIDE and len(tiles(int(width), int(height), side)) < want:
        side = max(MIN_SHARED_SIDE, side // 2 // TILE * TILE)
    return side


def job_for(ctx: RenderContext, width: int, height: int) -> Job:
    """The Job of a context (the preview renders many views of one compiled scene: ctx.camera is the one used):
    plan the units, frame the camera, choose the integrator and gather its inputs (Integrator.prepare)."""
    options = ctx.options
    side, per_pass = plan(options.samples, film.support_radius(options))
    if options.stats and film.support_radius(options):
        # -stats counts the rays cast: halo samples traced again by a neighbouring tile would count twice, so a
        # counted render with a wide filter is one tile (the course's images are small)
        side = max(width, height)
    elif not film.support_radius(options):
        side = _shared_side(side, *(options.crop[2:] if options.crop is not None else (width, height)))
    camera = image_camera(ctx.camera, width, height)  # a model's framed camera fits this image's shape
    integrator = integrator_for(options)
    if integrator.prepare is not None:
        integrator.prepare(ctx)
    return Job(ctx, int(width), int(height), camera, integrator, side, per_pass)


def prepare(scene: Scene, width: int, height: int, options: RenderOptions) -> Job:
    """Check and compile the scene, build its accelerator and choose the integrator: the Job of a render."""
    return job_for(make_context(scene, options), width, height)


@dataclass
class Accumulators:
    """Per-pixel sums of a tile, arrays (rows, cols, ...): `sums` holds the filter-weighted sums of every
    channel (colour first, then each AOV named in `channels`), `weight` the filter weights' sum; `depth` and
    `normal` are those of the sample nearest the pixel centre, `centre` its squared distance (inf: none yet), and
    `surface` its first hit's position and UV (rows, cols, hit_aovs.WIDTH) with options.hit_aovs, else
    (rows, cols, 0)."""

    tile: Tile
    channels: tuple[tuple[str, int], ...]
    sums: np.ndarray
    weight: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    centre: np.ndarray
    surface: np.ndarray

    @classmethod
    def zeros(cls, tile: Tile, channels: tuple[tuple[str, int], ...] = (("color", 3),),
              surface: int = 0) -> Accumulators:
        shape = (tile.rows, tile.cols)
        width = sum(k for _, k in channels)
        return cls(tile, channels, np.zeros(shape + (width,)), np.zeros(shape), np.full(shape, np.inf),
                   np.zeros(shape + (3,)), np.full(shape, np.inf), np.zeros(shape + (surface,)))

    @classmethod
    def empty(cls, job: Job) -> Accumulators:
        """Sums of the whole image, to add units into (its channels follow the first unit added)."""
        return cls.zeros(job.tile, ())

    def channel(self, name: str) -> np.ndarray:
        """The sums of one named channel (rows, cols, k)."""
        lo = 0
        for n, k in self.channels:
            if n == name:
                return self.sums[..., lo:lo + k]
            lo += k
        raise KeyError(name)

    def add(self, other: Accumulators) -> Accumulators:
        """Add a unit's sums (its tile inside this one) in place and return self. Tiles are disjoint, so their
        order does not matter; a tile's sample ranges must come in ascending order for a fixed result (and then
        the depth and normal of the nearest sample, the earlier one on a tie, are the same as in one unit)."""
        at = other.tile.inside(self.tile)
        if other.channels != self.channels:
            self._widen(other.channels)
        if other.channels == self.channels:
            self.sums[at] += other.sums
        else:  # a unit without some AOV (none of its rays reached the integrator, e.g. outside a fisheye's circle)
            lo = 0
            for name, k in other.channels:
                self.channel(name)[at] += other.sums[..., lo:lo + k]
                lo += k
        self.weight[at] += other.weight
        nearer = other.centre < self.centre[at]
        np.copyto(self.depth[at], other.depth, where=nearer)
        np.copyto(self.normal[at], other.normal, where=nearer[..., None])
        if other.surface.shape[-1] > self.surface.shape[-1]:  # the first unit with positions and UVs
            self.surface = np.zeros(self.weight.shape + other.surface.shape[-1:])
        if other.surface.shape[-1]:
            np.copyto(self.surface[at], other.surface, where=nearer[..., None])
        np.copyto(self.centre[at], other.centre, where=nearer)
        return self

    def _widen(self, channels: tuple[tuple[str, int], ...]) -> None:
        """Make room for the channels this sum has not seen yet (zero so far: no sample had them)."""
        have = dict(self.channels)
        for name, k in channels:
            if have.get(name, k) != k:
                raise ValueError(f"channel {name!r} has {k} components here and {have[name]} before")
        new = tuple((name, k) for name, k in channels if name not in have)
        if new:
            extra = np.zeros(self.weight.shape + (sum(k for _, k in new),))
            self.sums = np.concatenate([self.sums, extra], axis=-1)
            self.channels = self.channels + new


def merge(parts) -> Accumulators:
    """Add units' Accumulators in the order given (a tile's sample ranges ascending) into their union's sums."""
    parts = list(parts)
    if not parts:
        raise ValueError("merge needs at least one unit's Accumulators")
    r0, c0 = min(p.tile.row for p in parts), min(p.tile.col for p in parts)
    r1 = max(p.tile.row + p.tile.rows for p in parts)
    c1 = max(p.tile.col + p.tile.cols for p in parts)
    out = Accumulators.zeros(Tile(r0, c0, r1 - r0, c1 - c0), ())
    for p in parts:
        out.add(p)
    return out


def _batch(integrator: Integrator, n_rays: int, halo: Tile) -> int:
    """Rays per integrator call: its batch, rounded to whole bands of 4 halo rows when the rays are the halo's
    pixels row by row (one sample each, every ray valid), so the BVH finds them an image and traces 4 x 4
    packets (accel/widths.flat_image_width)."""
    band = TILE * halo.cols
    if n_rays != halo.pixels or halo.rows % TILE or halo.cols % TILE:
        return integrator.batch
    return max(1, integrator.batch // band) * band


def render_unit(job: Job, tile: Tile, samples: range) -> Accumulators:
    """Trace samples `samples` of the tile's pixels and of its halo and filter them into the tile's sums."""
    keep_freed_memory()  # this process's heap keeps the unit's freed arrays: no page faults per render (heap.py)
    options, width, height = job.options, job.width, job.height
    samples = range(samples.start, samples.stop)
    if not (0 <= samples.start < samples.stop <= options.samples):
        raise ValueError(f"sample range {samples} is not within the {options.samples} samples per pixel")
    halo = tile.grown(film.support_radius(options), width, height)
    rows, cols = range(halo.row, halo.row + halo.rows), range(halo.col, halo.col + halo.cols)
    m = len(samples)
    points, pixel, sample = film.tile_samples(options, width, height, rows, cols, samples)
    origins, directions, valid = film.camera_rays(job.camera, points, width, height, options, pixel, sample)
    n = len(points)
    t, normal = np.full(n, np.inf), np.zeros((n, 3))
    idx = np.flatnonzero(valid)
    every = len(idx) == n
    step = _batch(job.integrator, len(idx), halo)
    out = None
    for lo in range(0, len(idx), step):
        sel = slice(lo, min(n, lo + step)) if every else idx[lo:lo + step]
        res: SampleResult = job.integrator.trace(job.ctx, origins[sel], directions[sel], job.camera.t_min,
                                                 pixel=pixel[sel], sample=sample[sel])
        t[sel], normal[sel] = res.t, res.normal
        out = out or _Values(res, n, every, job.ctx.bundle.background, options)
        out.put(sel, res)
    out = (out or _Values(None, n, every, job.ctx.bundle.background, options)).done(t)
    acc = Accumulators.zeros(tile, out.channels, HIT_WIDTH if options.hit_aovs else 0)
    sums, weight = acc.sums.reshape(tile.pixels, -1), acc.weight.reshape(-1)
    if options.denoise:
        _gather_denoised(points, out.inputs, out.part, m, halo, tile, job, sums, weight)
    else:
        film.gather(points, out.inputs, m, halo.rect, tile.rect, width, height, options, sums, weight)
    centre = _nearest(points, t, normal, m, halo, tile, height, acc)
    if options.hit_aovs:
        acc.surface[:] = hit_points(job.ctx, origins[centre], directions[centre], job.camera.t_min,
                                    t[centre]).reshape(acc.surface.shape)
    return acc


class _Values:
    """A unit's per-sample values as the film reads them, each integrator result copied once, batch by batch, into
    `inputs` (n, C): the colour, then alpha (options.alpha) and each other output of SampleResult in its order (the
    channels of Accumulators); for a denoised render the colour less the split part (SPLIT), the outputs but the
    split ones and UNREAD, the squared norm of that colour (MOMENT), and the split part in `part` (n, k) of its own.
    One array each, no concatenation: copies and channels were most of the features' cost (benchmarks/README.md)."""

    def __init__(self, res: SampleResult | None, n: int, every: bool, background, options: RenderOptions):
        skip = BASE + UNREAD * bool(options.denoise and not options.aovs)
        given = {} if res is None else {f.name: getattr(res, f.name) for f in fields(res) if f.name not in skip}
        found = [(name, np.reshape(v, (len(res.t), -1)).shape[1]) for name, v in given.items() if v is not None]
        self.split = [(s, k) for s in SPLIT for name, k in found if s == name] if options.denoise else []
        own = [("alpha", 1)] * bool(options.alpha) + [a for a in found if a not in self.split]
        own += [(MOMENT, 1)] * bool(options.denoise)
        self.channels = (("color", 3), *own, *self.split) + ((SPLIT_WEIGHT, 1),) * bool(self.split)
        self.at, lo = {}, 3
        for name, k in own:
            self.at[name], lo = slice(lo, lo + k), lo + k
        make = np.empty if every else np.zeros
        self.inputs, self.part = make((n, lo)), make((n, sum(k for _, k in self.split)))
        if not every:
            self.inputs[:, :3] = background  # film points without a ray (outside a fisheye's circle)
        self.alpha, self.moment = options.alpha, options.denoise
        # film.pack's one pass: every ray traced (sel a slice), 3-wide features right after the colour
        self.packed = (every and not options.alpha and len(self.split) <= 1 and len(own) > options.denoise
                       and all(k == 3 for _, k in own[:len(own) - options.denoise] + self.split))

    def put(self, sel, res: SampleResult) -> None:
        """Copy one batch's results (rays `sel` of the unit) into place."""
        if self.packed:
            f64 = np.ascontiguousarray
            # the split part as it is (the seen emission is a column slice of the path tracer's (n, 6)): pack reads
            # any strides, so no copy; the sources stay contiguous (pack iterates them: one array type)
            split = np.asarray(getattr(res, self.split[0][0]), np.float64) if self.split else _NO_SPLIT
            sources = tuple(f64(getattr(res, name), np.float64) for name in self.at if name != MOMENT)
            film.pack(self.inputs, self.part, sel.start, f64(res.color, np.float64), split, sources,
                      self.at[MOMENT].start if self.moment else -1)
            return
        n, lo, split = len(res.t), 0, None
        for name, k in self.split:
            value = np.reshape(getattr(res, name), (n, k))
            self.part[sel, lo:lo + k], lo = value, lo + k
            split = value if split is None else split + value
        if split is not None and isinstance(sel, slice):  # no temporary
            np.subtract(res.color, split, out=self.inputs[sel, :3])
        else:
            self.inputs[sel, :3] = res.color if split is None else res.color - split
        for name, at in self.at.items():
            if name not in ("alpha", MOMENT):
                self.inputs[sel, at] = np.reshape(getattr(res, name), (n, -1))

    def done(self, t: np.ndarray) -> _Values:
        """Fill the channels computed from the others: alpha (coverage: 1 where the camera ray hit something) and
        the squared norm of the colour (the blend's variance, summed over channels, needs no more)."""
        if self.alpha:
            self.inputs[:, self.at["alpha"]] = np.isfinite(t)[:, None]
        if self.moment and not self.packed:
            self.inputs[:, self.at[MOMENT]] = np.einsum("ij,ij->i", self.inputs[:, :3], self.inputs[:, :3])[:, None]
        return self


def _gather_denoised(points, inputs: np.ndarray, part: np.ndarray, m: int, halo: Tile, tile: Tile, job: Job,
                     sums: np.ndarray, weight: np.ndarray) -> None:
    """film.gather for a denoised render: the denoiser's inputs by the one-pixel box, the split part (added back
    after denoising) by the scene's filter, into sums[:, -k-1:-1] with its weights' sum in the last column
    (SPLIT_WEIGHT)."""
    o, width, height, k = job.options, job.width, job.height, part.shape[1]
    box = replace(o, **PIXEL_FILTER)  # sums (zeros) are gathered into in place, column views: no copies
    film.gather(points, inputs, m, halo.rect, tile.rect, width, height, box, sums[:, :inputs.shape[1]], weight)
    if k:
        film.gather(points, part, m, halo.rect, tile.rect, width, height, o, sums[:, -k - 1:-1], sums[:, -1])


def _nearest(points, t, normal, m: int, halo: Tile, tile: Tile, height: int, acc: Accumulators) -> np.ndarray:
    """Depth and normal of each tile pixel's sample nearest its centre (the first such sample on a tie), in acc;
    returns those samples' indices into the unit's rays (tile pixels row-major): film.nearest_samples."""
    index = np.empty(tile.pixels, np.int64)
    film.nearest_samples(np.ascontiguousarray(points, dtype=np.float64), t, normal, m, halo.rect, tile.rect, height,
                         acc.depth.reshape(-1), acc.normal.reshape(-1, 3), acc.centre.reshape(-1), index)
    return index


def finish(job: Job, acc: Accumulators) -> RenderResult:
    """The image of the whole image's sums: each channel's weighted sum over the weights (black where no sample
    weighs), depth and normals of the centre samples (and their position and UV with options.hit_aovs), all
    float32 (H,W,...)."""
    if acc.tile != job.tile:
        raise ValueError(f"finish needs the sums of the whole image {job.tile}, got {acc.tile}")
    if not acc.channels:
        raise ValueError("finish needs the sums of at least one unit (none were added)")
    w = acc.weight[..., None]
    pixels = np.divide(acc.sums, w, out=np.zeros_like(acc.sums), where=w > 0)
    aovs, lo = {}, 3
    split_weight = acc.channel(SPLIT_WEIGHT) if SPLIT_WEIGHT in dict(acc.channels) else None
    # radiance beyond float32 (a light with attenuation 1e-300) is inf in the image, not a warning on stderr
    with np.errstate(over="ignore"):
        for name, k in acc.channels[1:]:
            if split_weight is not None and name in SPLIT:  # filtered by the scene's filter (_gather_denoised)
                sums = acc.channel(name)
                aovs[name] = np.divide(sums, split_weight, out=np.zeros_like(sums),
                                       where=split_weight > 0).astype(np.float32)
            elif name != SPLIT_WEIGHT:
                aovs[name] = pixels[..., lo:lo + k].astype(np.float32)
            lo += k
        surface = acc.surface.astype(np.float32) if acc.surface.shape[-1] else None
        return RenderResult(color=pixels[..., :3].astype(np.float32), depth=acc.depth.astype(np.float32),
                            normals=acc.normal.astype(np.float32), stats=getattr(job.ctx.accel, "stats", None),
                            aovs=aovs, position=None if surface is None else surface[..., :3],
                            uv=None if surface is None else surface[..., 3:])


def run(job: Job, units: list[tuple[Tile, range]] | None = None, bar=None) -> Accumulators:
    """Render `units` (default: job.units()) on this machine and add them up in their order into the sums of the
    whole image. The integrator's `workers` units are traced at once on threads (the kernels free the GIL), each
    with its share of Numba's threads; results are added in the units' order, whichever finishes first, so the
    image does not depend on the thread count. `bar.update(n)` hears each unit's own samples."""
    units = job.units() if units is None else units
    acc = Accumulators.empty(job)
    threads = nb.get_num_threads()
    workers = max(1, min(job.integrator.workers, threads, len(units)))

    def add(unit: tuple[Tile, range], part: Accumulators) -> None:
        acc.add(part)
        if bar is not None:
            bar.update(unit[0].pixels * len(unit[1]))

    if workers == 1:
        for unit in units:
            add(unit, render_unit(job, *unit))
        return acc

    def one(unit: tuple[Tile, range]) -> Accumulators:
        nb.set_num_threads(max(1, threads // workers))  # this thread's kernels (Numba's count is per thread)
        return render_unit(job, *unit)

    with ThreadPoolExecutor(workers, thread_name_prefix="durer-unit") as pool:
        futures = [pool.submit(one, unit) for unit in units]
        try:
            for unit, future in zip(units, futures, strict=True):
                add(unit, future.result())
        except BaseException:  # an error or Ctrl-C: drop the units not started
            for future in futures:
                future.cancel()
            raise
    return acc
