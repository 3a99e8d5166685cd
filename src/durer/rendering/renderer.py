"""render(): a scene and an image size in, colour, depth and normal arrays out."""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass, fields, replace

import numpy as np

from ..accel.brute import BruteForce
from ..accel.bvh import BVHAccelerator
from ..accel.compile import compile_scene, spheres_under_transform, with_course_edges
from ..accel.grid import GridAccelerator
from ..accel.hits import Accelerator
from ..accel.stats import CountingAccelerator, RayStats
from ..io.images import depth_visualization, encode_srgb, normal_visualization, save_image
from ..kernels.bvh.layout import TILE
from ..options import RenderOptions
from ..scene.bsdfs import BSDF, Surface
from ..scene.cameras import image_camera
from ..scene.graph import Scene
from ..scene.validate import check_scene
from . import film
from .grid_view import visualize_grid
from .raycaster import RenderContext, SampleResult, raycast
from .whitted import whitted

PHYSICAL = (Surface, *BSDF.__args__)  # materials only the path tracer renders
CHUNK = 1 << 13  # rays per batch: enough to keep the kernels busy, few enough for a live progress bar


@dataclass
class RenderResult:
    """The arrays of one render, each (H, W, ...), row 0 at the top.

    color: float32 (H,W,3) linear radiance; depth: float32 (H,W) ray parameter t of the closest hit (inf on a miss);
    normals: float32 (H,W,3) unit world-space normals of the closest hit (0 on a miss). With several samples per
    pixel, depth and normals are those of the sample nearest the pixel's centre.
    With options.aovs or options.denoise (issue 24), the denoiser's features, filtered like the colour: albedo
    float32 (H,W,3), the reflectance of each sample's first non-specular hit (seen through mirrors and glass, tinted
    by them; 0 where the ray escapes), and shading_normals (H,W,3), that hit's normal (not unit after filtering);
    else None. With options.denoise, color is OIDN's output and denoise_seconds its time (included in seconds); the
    samples are then filtered by a one-pixel box whatever the scene's filter (rendering/denoise.PIXEL_FILTER).
    """

    color: np.ndarray
    depth: np.ndarray
    normals: np.ndarray
    seconds: float = 0.0
    stats: RayStats | None = None  # -stats counters (None unless options.stats)
    albedo: np.ndarray | None = None
    shading_normals: np.ndarray | None = None
    denoise_seconds: float = 0.0

    def __repr__(self) -> str:
        h, w = self.depth.shape
        hit = int(np.isfinite(self.depth).sum())
        return (f"<RenderResult {w}x{h}: {hit} of {w * h} pixels hit, colour up to {float(self.color.max()):.3g} "
                f"(linear), {self.seconds:.2f} s>")

    def to_srgb8(self) -> np.ndarray:
        """The colour as an sRGB-encoded uint8 (H, W, 3) array, as `save` writes it and as image viewers and
        `plt.imshow` expect (`color` itself is linear radiance, which looks too dark shown directly)."""
        return encode_srgb(self.color)

    def _repr_png_(self) -> bytes:
        """PNG bytes of `to_srgb8()`: Jupyter shows a RenderResult as its image."""
        import io

        from PIL import Image

        buffer = io.BytesIO()
        Image.fromarray(self.to_srgb8(), mode="RGB").save(buffer, format="PNG")
        return buffer.getvalue()

    def save(self, path: str | os.PathLike, *, course: bool = False) -> None:
        """Write the colour image (8-bit formats sRGB-encoded, or truncated like the course with course=True)."""
        save_image(os.fspath(path), self.color, course=course)

    def save_depth(self, path: str | os.PathLike, near: float | None = None, far: float | None = None) -> None:
        """Write depth: raw t for .npy/.pfm, else grey with near = white and far = black (default: the hit range)."""
        path = os.fspath(path)
        if path.lower().endswith((".npy", ".pfm")):
            save_image(path, self.depth)
            return
        finite = self.depth[np.isfinite(self.depth)]
        if near is None:
            near = float(finite.min()) if finite.size else 0.0
        if far is None:
            far = float(finite.max()) if finite.size else 1.0
        if far == near:
            far = near + 1.0
        save_image(path, depth_visualization(self.depth, near, far), course=True)

    def save_normals(self, path: str | os.PathLike) -> None:
        """Write normals: raw for .npy/.pfm, else |n| per channel."""
        path = os.fspath(path)
        if path.lower().endswith((".npy", ".pfm")):
            save_image(path, self.normals)
            return
        save_image(path, normal_visualization(self.normals), course=True)


def make_context(scene: Scene, options: RenderOptions) -> RenderContext:
    """Check the scene (ValueError naming a wrong object), compile it and build its accelerator."""
    check_scene(scene)
    cs = compile_scene(scene)
    # the course command: triangles accept points just outside their edges, as the course's (compile.py)
    hit_cs = with_course_edges(cs) if options.course_edges else cs
    # the lecture's loop over every object (--accel brute), or the bounding volume hierarchy (the default)
    accel: Accelerator = BruteForce(hit_cs) if options.accel == "brute" else BVHAccelerator(hit_cs)
    # -grid / -stats (issue 4, item 5; grid.py, stats.py): the course's uniform grid instead of the default
    # accelerator, and counters of rays, ray-primitive tests and grid cells, read back as RenderResult.stats
    stats = RayStats(bounds=cs.bounds()) if options.stats else None
    if options.grid is not None:
        accel = GridAccelerator(cs, options.grid, sphere_as_box=spheres_under_transform(scene), stats=stats)
        accel.cs = hit_cs  # cells hold the triangles' boxes as given (the course's insertion); tests use hit_cs
    elif stats is not None:
        # the course's -stats without a grid counts its loop over every object; measure that same loop, so the
        # counts are real and compare with the course's (the image is the same as the BVH's, as tests check)
        accel = CountingAccelerator(BruteForce(hit_cs), stats, sum(cs.counts))
    return RenderContext(scene=scene, compiled=hit_cs, accel=accel, options=options)


def choose_integrator(options: RenderOptions):
    """The lecture's ray caster unless the options ask for secondary rays (or for the grid's cells), or the one
    options.integrator names (the path tracer is driven by render() itself: rendering/path.py)."""
    if options.integrator == "raycast":
        return raycast
    if options.integrator == "whitted":
        return whitted
    if options.visualize_grid:  # -visualize_grid (grid.py): draw the occupied grid cells instead
        return visualize_grid
    if options.shadows or options.bounces > 0:
        return whitted
    return raycast


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
    check_size(width, height, options.samples)
    if options.integrator != "path" and any(isinstance(m, PHYSICAL) for m in scene.materials):
        raise ValueError("the scene has physically based materials (a Mitsuba scene): render it with "
                         "integrator='path'")
    start = time.perf_counter()
    if options.denoise:  # refused before anything is rendered when pyoidn is missing
        from .denoise import PIXEL_FILTER, require_oidn

        require_oidn()
        options = replace(options, **PIXEL_FILTER)
    if not quiet and kernels_cold():
        print("durer: compiling kernels (first run only) ...", file=sys.stderr, flush=True)
    ctx = make_context(scene, options)
    if options.integrator == "path":  # issue 10: rendering/path.py drives its own passes, one per sample
        from .path import render_path

        with _progress(options.samples, quiet, unit="spp") as bar:
            color, depth, normals, albedo, shading = render_path(ctx, width, height, bar)
        result = RenderResult(color=color.reshape(height, width, 3).astype(np.float32),
                              depth=depth.reshape(height, width).astype(np.float32),
                              normals=normals.reshape(height, width, 3).astype(np.float32),
                              albedo=_image(albedo, height, width), shading_normals=_image(shading, height, width))
    else:
        result = render_in(ctx, width, height, quiet=quiet, start=start)
    if options.denoise:
        from .denoise import clean_features, denoise

        done = denoise(result.color, result.albedo, result.shading_normals,
                       clean=clean_features(scene.materials, options.integrator == "path"),
                       quality=options.denoise_quality)
        result.color, result.denoise_seconds = done.color, done.seconds
    result.seconds = time.perf_counter() - start
    return result


def _image(values: np.ndarray | None, height: int, width: int) -> np.ndarray | None:
    """Per-pixel values (H*W, 3) as a float32 (H, W, 3) image; None stays None."""
    return None if values is None else values.reshape(height, width, 3).astype(np.float32)


def render_in(ctx: RenderContext, width: int, height: int, *, quiet: bool = True,
              start: float | None = None) -> RenderResult:
    """render() with a prepared context: the preview renders many views of one compiled scene (ctx.scene's camera
    is the one used, so a view is RenderContext(scene with another camera, the same compiled scene and accel))."""
    start = time.perf_counter() if start is None else start
    scene, options = ctx.scene, ctx.options
    integrate = choose_integrator(options)
    camera = image_camera(scene.camera, width, height)  # a model's framed camera fits this image's shape
    points, pixel = film.sample_points(width, height, options)
    origins, directions, valid = camera.generate_rays(points, width, height)
    n = len(points)
    color = np.broadcast_to(np.zeros(3), (n, 3)).copy()
    color[~valid] = scene.background_color  # film points without a ray (outside a fisheye's circle)
    depth = np.full(n, np.inf)
    normals = np.zeros((n, 3))
    features = np.zeros((n, 6)) if options.aovs or options.denoise else None  # albedo, shading normal
    idx = np.flatnonzero(valid)
    step = _chunk(len(idx), width, height)
    with _progress(len(idx), quiet) as bar:
        for lo in range(0, len(idx), step):
            sel = idx[lo:lo + step]
            r: SampleResult = integrate(ctx, origins[sel], directions[sel], camera.t_min)
            color[sel], depth[sel], normals[sel] = r.color, r.t, r.normal
            _keep_features(features, sel, r)
            bar.update(len(sel))
    pixels = film.reconstruct(points, pixel, color, width, height, options)
    centre = _nearest_to_centre(points, pixel, width, height)
    albedo, shading = _film_features(features, points, pixel, width, height, options)
    return RenderResult(
        color=pixels.reshape(height, width, 3).astype(np.float32),
        depth=depth[centre].reshape(height, width).astype(np.float32),
        normals=normals[centre].reshape(height, width, 3).astype(np.float32),
        seconds=time.perf_counter() - start,
        stats=getattr(ctx.accel, "stats", None),
        albedo=albedo, shading_normals=shading,
    )


# --- issue 24: the features on today's film (to move onto the accumulating film: it filters every non-None extra
# field of SampleResult with the colour's weights) -------------------------------------------------------------------
def _keep_features(features: np.ndarray | None, sel: np.ndarray, r: SampleResult) -> None:
    """Store a batch's per-sample albedo and shading normal (rows sel) when features are wanted."""
    if features is None:
        return
    if r.albedo is None or r.shading_normal is None:
        raise ValueError("this integrator does not produce the denoiser's features (albedo, shading normal)")
    features[sel, :3], features[sel, 3:] = r.albedo, r.shading_normal


def _film_features(features: np.ndarray | None, points: np.ndarray, pixel: np.ndarray, width: int, height: int,
                   options: RenderOptions) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The per-sample features filtered into pixels like the colour: albedo and shading normal (H, W, 3)."""
    if features is None:
        return None, None
    f = film.reconstruct(points, pixel, features, width, height, options)
    return _image(f[:, :3], height, width), _image(f[:, 3:], height, width)


BYTES_PER_SAMPLE = 200  # film points, rays, colour, depth, normals, pixel ids and the filter's buffers (float64)
BYTES_PER_PIXEL = 60    # the float32 colour, depth and normal images of the result


def check_size(width: int, height: int, samples: int = 1) -> None:
    """ValueError before anything is allocated if the render would need more memory than the machine has."""
    need = width * height * (samples * BYTES_PER_SAMPLE + BYTES_PER_PIXEL)
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


def _chunk(n_rays: int, width: int, height: int) -> int:
    """Rays per batch: CHUNK, rounded to whole bands of TILE image rows when the rays are the pixels' own, row
    by row (one sample per pixel, every ray valid), so each batch is whole 4 x 4 tiles, which the BVH finds
    (accel/bvh.flat_image_width) and traces as packets."""
    band = TILE * width
    if n_rays != width * height or height % TILE or width % TILE:
        return CHUNK
    return max(1, CHUNK // band) * band


def _nearest_to_centre(points: np.ndarray, pixel: np.ndarray, width: int, height: int) -> np.ndarray:
    """For each pixel (row-major), the index of its sample nearest the pixel's centre."""
    if len(pixel) == width * height and np.array_equal(pixel, np.arange(width * height)):
        return pixel
    row, col = np.divmod(pixel, width)
    d2 = (points[:, 0] - (col + 0.5)) ** 2 + (points[:, 1] - (height - row - 0.5)) ** 2
    order = np.lexsort((d2, pixel))
    first = np.ones(len(order), dtype=bool)
    first[1:] = pixel[order[1:]] != pixel[order[:-1]]
    return order[first]
