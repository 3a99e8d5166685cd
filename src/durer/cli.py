"""The `durer` command.

    durer raycast -input SCENE -size W H -output OUT [...]   the MIT 6.837 course's own flags, verbatim
    durer render SCENE -o OUT.png [--size W H] [...]          the modern command

Every user error ends in one line on stderr (`file:line: message` for scene files) and exit status 2,
and no output file is created or truncated: outputs are written only after a successful render, atomically.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

from .cli_args import (
    _add_threads,
    _check_outputs,
    _depth,
    _nonneg_int,
    _number,
    _Parser,
    _positive_int,
    _positive_number,
    _validate,
    _zoom,
)
from .errors import DurerError, UsageError
from .io.layers import aov_files, parse_aovs, save_with_aovs
from .options import (
    ACCELERATORS,
    COURSE_FILTERS,
    DENOISE_QUALITIES,
    FILTERS,
    INTEGRATORS,
    SAMPLERS,
    RenderOptions,
    thread_count,
)

EXIT_USAGE = 2


# --- the course's command -----------------------------------------------------------------------------------
def course_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="durer raycast", allow_abbrev=False,
                usage="durer raycast -input SCENE -size W H -output FILE [options] (see --help)",
                description="Render a MIT 6.837 scene with the course's own command-line flags.")
    p.add_argument("-input", required=True, metavar="SCENE", help="scene file")
    p.add_argument("-size", required=True, nargs=2, type=_positive_int, metavar=("W", "H"), help="image size")
    p.add_argument("-output", metavar="FILE", help="shaded image (.tga, .png, .ppm, .bmp, .npy, .pfm)")
    p.add_argument("-depth", nargs=3, metavar=("NEAR", "FAR", "FILE"), help="depth image: NEAR white, FAR black")
    p.add_argument("-normals", metavar="FILE", help="normal image: |n| per channel")
    p.add_argument("-shade_back", action="store_true", help="light both sides of surfaces")
    p.add_argument("-shadows", action="store_true", help="cast shadow rays")
    p.add_argument("-bounces", type=_nonneg_int, default=0, metavar="N", help="reflection/refraction depth")
    p.add_argument("-weight", type=_number, default=0.01, metavar="W", help="cut off rays weaker than W")
    p.add_argument("-grid", nargs=3, type=_positive_int, metavar=("NX", "NY", "NZ"), help="use a uniform grid")
    p.add_argument("-visualize_grid", action="store_true", help="draw the grid's occupied cells")
    p.add_argument("-stats", action="store_true",
                   help="print ray-tracing statistics (without -grid: of the every-object loop, as the course counted)")
    for kind in SAMPLERS:
        p.add_argument(f"-{kind}_samples", type=_positive_int, metavar="N", help=f"{kind} samples per pixel")
    p.add_argument("-box_filter", type=_positive_number, metavar="R", help="box filter of radius R pixels")
    p.add_argument("-tent_filter", type=_positive_number, metavar="R", help="tent filter of radius R pixels")
    p.add_argument("-gaussian_filter", type=_positive_number, metavar="SIGMA", help="gaussian filter")
    p.add_argument("-render_samples", nargs=2, metavar=("FILE", "ZOOM"), help="debug image of the samples")
    p.add_argument("-render_filter", nargs=2, metavar=("FILE", "ZOOM"), help="debug image of the filter")
    p.add_argument("-gui", action="store_true", help="(OpenGL preview: accepted and ignored)")
    p.add_argument("-tessellation", nargs=2, metavar=("THETA", "PHI"), help="(preview only: ignored)")
    p.add_argument("-gouraud", action="store_true", help="(preview only: ignored)")
    p.add_argument("--mesh-path", action="append", default=[], metavar="DIR",
                   help="also look for mesh files in DIR (repeatable; also $DURER_MESH_PATH)")
    _add_threads(p)
    return p


def _course_options(a: argparse.Namespace) -> RenderOptions:
    samplers = [k for k in SAMPLERS if getattr(a, f"{k}_samples") is not None]
    filters = [k for k in COURSE_FILTERS if getattr(a, f"{k}_filter") is not None]
    if len(samplers) > 1:
        raise UsageError(f"choose one sampler, not {' and '.join('-' + s + '_samples' for s in samplers)}")
    if len(filters) > 1:
        raise UsageError(f"choose one filter, not {' and '.join('-' + f + '_filter' for f in filters)}")
    opts = RenderOptions(shade_back=a.shade_back, shadows=a.shadows, bounces=a.bounces, weight=a.weight,
                         grid=tuple(a.grid) if a.grid else None, visualize_grid=a.visualize_grid, stats=a.stats,
                         course_random=True,  # the course's own random samples (film.py), as its images show
                         course_edges=True)   # and its triangles' edge tolerance (compile.widen_triangles)
    if samplers:
        opts.sampler = samplers[0]
        opts.samples = getattr(a, f"{samplers[0]}_samples")
    if filters:
        opts.filter = filters[0]
        opts.filter_radius = getattr(a, f"{filters[0]}_filter")
    if a.visualize_grid and not a.grid:
        raise UsageError("-visualize_grid needs -grid NX NY NZ")
    return opts


def _run_course(a: argparse.Namespace) -> int:
    opts = _course_options(a)
    _validate(opts)
    width, height = a.size
    depth = _depth(a.depth, "-depth") if a.depth else None
    samples_dbg = _zoom(a.render_samples, "-render_samples", width, height)
    filter_dbg = _zoom(a.render_filter, "-render_filter", width, height)
    outputs = [p for p in (a.output, depth and depth[2], a.normals, samples_dbg and samples_dbg[0],
                           filter_dbg and filter_dbg[0]) if p]
    if not outputs:
        raise UsageError("nothing to write: give -output, -depth, -normals, -render_samples or -render_filter")
    _check_outputs(outputs)
    ignored = [f for f, on in (("-gui", a.gui), ("-tessellation", a.tessellation), ("-gouraud", a.gouraud)) if on]
    if ignored:
        print(f"durer: {', '.join(ignored)} (the course's OpenGL preview) ignored: rendering to files only",
              file=sys.stderr)
    from . import load
    from .rendering.renderer import check_size, render

    check_size(width, height, opts.samples)
    scene = load(a.input, mesh_path=a.mesh_path)
    if samples_dbg or filter_dbg:
        from .rendering.film_images import write_filter_image, write_samples_image

        if samples_dbg:
            write_samples_image(samples_dbg[0], scene, width, height, opts, samples_dbg[1])
        if filter_dbg:
            write_filter_image(filter_dbg[0], width, height, opts, filter_dbg[1])
        if not (a.output or depth or a.normals):
            return 0
    result = render(scene, width, height, options=opts, quiet=False)
    if a.output:
        result.save(a.output, course=True)
    if depth:
        result.save_depth(depth[2], depth[0], depth[1])
    if a.normals:
        result.save_normals(a.normals)
    if a.stats:  # the course's RayTracingStats summary (stats.py); the time alone if nothing was counted
        if result.stats is not None:
            print(result.stats.report(width, height, result.seconds), file=sys.stderr)
        else:
            print(f"rendered {width}x{height} in {result.seconds:.3f} s", file=sys.stderr)
    return 0


# --- the modern command --------------------------------------------------------------------------------------
def add_render_flags(p: argparse.ArgumentParser, size_default: tuple[int, int] | None = (512, 512),
                     size_help: str = "image width and height in pixels (default: 512 512)") -> None:
    """The flags every rendering command shares (render, explain, preview): size, shading, sampling, meshes.
    Flags a scene may set itself (integrator, max depth, samples, filter) default to None: the scene's or durer's."""
    p.add_argument("--size", nargs=2, type=_positive_int, default=size_default, metavar=("W", "H"), help=size_help)
    p.add_argument("--shade-back", action=argparse.BooleanOptionalAction, default=True,
                   help="light back faces too (default; --no-shade-back paints them black, as the course did)")
    p.add_argument("--shadows", action="store_true", help="cast shadow rays to every light")
    p.add_argument("--bounces", type=_nonneg_int, default=0, metavar="N",
                   help="maximum depth of reflection and refraction rays (default: 0)")
    p.add_argument("--weight", type=_number, default=0.01, metavar="W",
                   help="stop rays whose contribution is below W (default: 0.01)")
    p.add_argument("--integrator", choices=INTEGRATORS, default=None,
                   help="auto (ray caster, or Whitted with --shadows/--bounces) or path (path tracer); "
                        "default: the scene's own (Mitsuba scenes: path), else auto")
    p.add_argument("--max-depth", type=int, default=None, metavar="N",
                   help="path tracer: longest path (1 emitters, 2 direct light, -1 unbounded; default: the scene's)")
    p.add_argument("--samples", type=_positive_int, default=None, metavar="N",
                   help="samples per pixel, jittered when N > 1 (default: the scene's sampler, else 1, the pixel "
                        "centre)")
    p.add_argument("--sampler", choices=SAMPLERS, default=None,
                   help="sample pattern when --samples > 1 (default: jittered)")
    p.add_argument("--filter", default=None, metavar="NAME[:WIDTH]",
                   help="reconstruction filter: box, tent or gaussian (the course's), or mitchell, catmullrom, "
                        "lanczos or mitsuba_gaussian (Mitsuba 3's), with an optional radius, lobes or sigma in pixels, "
                        "e.g. gaussian:0.4 (default: the scene's, else box:0.5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random samplers (default: 0)")
    p.add_argument("--accel", choices=ACCELERATORS, default="bvh",
                   help="how rays find their closest hit: bvh, the bounding volume hierarchy (default), or brute, "
                        "the lecture's loop over every object (kernels/brute.py; slow on large scenes)")
    p.add_argument("--mesh-path", action="append", default=[], metavar="DIR",
                   help="also look for mesh files in DIR (repeatable; also $DURER_MESH_PATH)")
    _add_threads(p)


def render_options(a: argparse.Namespace, scene_defaults: dict | None = None) -> RenderOptions:
    """RenderOptions from the flags of add_render_flags over a scene's own defaults (Mitsuba scenes: integrator,
    sampler, film); a flag given wins. UsageError on a bad flag."""
    from .rendering.renderer import parse_filter

    opts = {k: v for k, v in (scene_defaults or {}).items() if k not in ("width", "height")}
    if a.filter is not None:
        try:
            name, radius = parse_filter(a.filter)
        except ValueError as e:
            raise UsageError(f"--filter: {e}") from None
        if name not in FILTERS:
            raise UsageError(f"--filter: unknown filter {name!r} (use one of {', '.join(FILTERS)})")
        if radius is not None and not radius > 0:
            raise UsageError("--filter: the width must be positive")
        opts["filter"], opts["filter_radius"] = name, radius if radius is not None else 0.5
        opts.pop("filter_b", None), opts.pop("filter_c", None)  # a scene's mitchell B and C go with its filter
    if a.max_depth is not None and a.max_depth < -1:
        raise UsageError("--max-depth: must be -1 (unbounded) or a non-negative integer")
    opts.update(shade_back=a.shade_back, shadows=a.shadows, bounces=a.bounces, weight=a.weight, seed=a.seed,
                accel=a.accel)
    given = {"integrator": a.integrator, "max_depth": a.max_depth, "samples": a.samples}
    opts.update({k: v for k, v in given.items() if v is not None})
    samples = opts.setdefault("samples", 1)
    opts["sampler"] = a.sampler or ("jittered" if samples > 1 else "uniform")
    try:
        options = RenderOptions(**opts)
    except ValueError as e:
        raise UsageError(str(e)) from None
    _validate(options)
    return options


def render_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="durer render", allow_abbrev=False,
                usage="durer render SCENE -o OUT [options] (see --help)",
                description="Render a scene file to an image (colour, and optionally depth and normals).",
                epilog="Image formats by extension: .png .tga .ppm .bmp (8-bit), .npy .pfm (raw float arrays: "
                       "linear colour, t, normals), .exr (OpenEXR). Exit status 2 on any user error.")
    p.add_argument("scene", help="scene file: a MIT 6.837 scene, a Mitsuba 3 scene (.xml) or a model (.glb .gltf "
                                 ".obj .ply .stl .off)")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="colour image to write")
    add_render_flags(p, size_default=None, size_help="image width and height in pixels (default: the scene's film, "
                     "else 512 512, or 512 on the longer side in the aspect ratio of a glTF camera)")
    p.add_argument("--camera", metavar="NAME|INDEX",
                   help="which camera of a glTF file to render through (default: its first)")
    p.add_argument("--depth", nargs=3, metavar=("NEAR", "FAR", "FILE"),
                   help="also write depth: t = NEAR white, t = FAR black, misses black (.npy/.pfm: raw t)")
    p.add_argument("--normals", metavar="FILE", help="also write normals as |n| per channel (.npy/.pfm: raw)")
    p.add_argument("--linear", action="store_true",
                   help="write 8-bit colour without the sRGB curve, truncated as the course does")
    p.add_argument("--aov", metavar="LIST",
                   help="also write albedo, normals, depth, position and/or uv (comma-separated): layers of the "
                        "image when OUT is .exr, else files beside it (out.albedo.png, ...)")
    p.add_argument("--denoise", action="store_true",
                   help='denoise the colour with Intel Open Image Denoise (needs pip install "durer[denoise]")')
    p.add_argument("--denoise-quality", choices=DENOISE_QUALITIES, default="high",
                   help="OIDN's preset: high (default, the lowest error; a denoised 16-spp render costs about "
                        "+27%% time), balanced (+15%%) or fast (+9%%; 3-38%% more error)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or timing")
    from .cli_frames import add_arguments

    add_arguments(p, _positive_int)  # --scheduler, --frames, --camera-path
    return p


def _run_render(a: argparse.Namespace) -> int:
    from .rendering.renderer import check_size, render

    render_options(a)  # a bad flag is reported before anything is read
    depth = _depth(a.depth, "--depth") if a.depth else None
    aovs = _aovs(a)
    from . import cli_frames

    if cli_frames.wanted(a):  # a Dask cluster or several frames
        if aovs or a.denoise:
            raise UsageError("--aov and --denoise are not available with --scheduler, --frames or --camera-path yet")
        return cli_frames.run_frames(a, depth, render_options, _default_size)
    _check_outputs([p for p in (a.output, depth and depth[2], a.normals) if p] + aov_files(a.output, aovs))
    from . import load

    if a.size is not None:
        check_size(a.size[0], a.size[1], a.samples or 1)
    scene = load(a.scene, mesh_path=a.mesh_path, camera=a.camera)
    options = render_options(a, scene.render_defaults)
    options.denoise = options.denoise or a.denoise
    options.denoise_quality = a.denoise_quality
    options.aovs = options.aovs or "albedo" in aovs
    if not aovs and options.aov_outputs:  # a Mitsuba `aov` integrator's outputs, unless --aov names others
        aovs = options.aov_outputs
        _check_outputs(aov_files(a.output, aovs))
    options.hit_aovs = options.hit_aovs or "position" in aovs or "uv" in aovs
    size = scene_size(a, scene)
    start = time.perf_counter()
    result = render(scene, size[0], size[1], options=options, quiet=a.quiet)
    layers = {"albedo": result.albedo, "normals": result.normals, "depth": result.depth, "position": result.position,
              "uv": result.uv}
    save_with_aovs(a.output, result.color, {n: layers[n] for n in aovs}, course=a.linear)
    if depth:
        result.save_depth(depth[2], depth[0], depth[1])
    if a.normals:
        result.save_normals(a.normals)
    if not a.quiet:
        print(f"durer: wrote {a.output} ({size[0]}x{size[1]}, {time.perf_counter() - start:.2f} s)",
              file=sys.stderr)
    return 0


def scene_size(a: argparse.Namespace, scene) -> tuple[int, int]:
    """The image size of a rendering command: --size, else the scene's film, else _default_size (the same for
    render, explain and preview, so a pixel and --samples mean the same in all three)."""
    film = scene.render_defaults or {}
    return a.size or ((film["width"], film["height"]) if "width" in film else _default_size(scene.camera))


def _aovs(a: argparse.Namespace) -> tuple[str, ...]:
    """The outputs --aov asks for, after refusing --denoise without pyoidn (both before anything is rendered)."""
    if a.denoise:
        from .rendering.denoise import require_oidn

        require_oidn()
    return parse_aovs(a.aov) if a.aov is not None else ()


def _default_size(camera, longer: int = 512) -> tuple[int, int]:
    """512 x 512, or 512 on the longer side in the aspect ratio a glTF camera asks for (io/gltf_extras.py)."""
    aspect = getattr(camera, "aspect_ratio", None)
    if not aspect:
        return longer, longer
    return (longer, max(1, round(longer / aspect))) if aspect >= 1 else (max(1, round(longer * aspect)), longer)


# --- issue 12: one pixel's ray tree (cli_explain.py) and the live preview (preview/command.py) ---------------
def _subcommand(load, command: str):
    """(run, parser) of a rendering command whose module (load() imports it on first use) gives PARSER (prog,
    usage, ...), add_arguments and the function `command`(args, render_options, scene_size): its parser gets the
    render flags every rendering command shares, and it runs with their thread count."""

    def parser() -> argparse.ArgumentParser:
        module = load()
        p = _Parser(allow_abbrev=False, **module.PARSER)
        module.add_arguments(p)
        add_render_flags(p, size_default=None, size_help="image width and height in pixels (default: as durer "
                         "render: the scene's film, else 512 512)")
        return p

    return _threaded(parser, lambda a: getattr(load(), command)(a, render_options, scene_size)), parser


def _threaded(parser, run):
    """A command line's entry: argv parsed by parser(), then run(args) with --threads threads."""

    def command(argv: list[str]) -> int:
        a = parser().parse_args(argv)
        with thread_count(a.threads):
            return run(a)

    return command


def _explain_module():
    from . import cli_explain

    return cli_explain


def _preview_module():
    from .preview import command

    return command


def _warmup(name: str):
    """`durer warmup`'s parser or command (warmup.py, imported on use)."""
    from . import warmup

    return getattr(warmup, name)


run_course = _threaded(course_parser, _run_course)
run_render = _threaded(render_parser, _run_render)
COMMANDS = {"raycast": (run_course, course_parser), "render": (run_render, render_parser),
            "explain": _subcommand(_explain_module, "explain_command"),
            "preview": _subcommand(_preview_module, "preview_command"),
            "warmup": (lambda argv: _warmup("command")(argv), lambda: _warmup("parser")())}
USAGE = ("usage: durer {raycast,render,explain,preview,warmup} ...\n"
         "  durer raycast -input SCENE -size W H -output OUT [...]   the MIT 6.837 course's flags\n"
         "  durer render SCENE -o OUT.png [--size W H] [...]          the modern command\n"
         "  durer explain SCENE --pixel X Y [--json] [--draw OUT]     one pixel's ray tree\n"
         "  durer preview SCENE [--port P] [--no-browser]             live view in the browser\n"
         "  durer warmup [GROUP ...]                                  compile every kernel now\n"
         "`durer COMMAND --help` lists a command's options.")


def main(argv: list[str] | None = None) -> int:
    """The `durer` command; a closed output pipe (`durer -h | head -2`) ends it quietly."""
    try:
        code = _main(argv)
        sys.stdout.flush()
        return code
    except BrokenPipeError:
        # the reader went away: send whatever Python still wants to flush to /dev/null, then stop quietly
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


def _main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE, file=sys.stdout if argv else sys.stderr)
        return 0 if argv else EXIT_USAGE
    if argv[0] in ("-V", "--version"):
        from . import __version__

        print(f"durer {__version__}")
        return 0
    if argv[0] not in COMMANDS:
        print(f"{USAGE}\ndurer: error: unknown command {argv[0]!r}", file=sys.stderr)
        return EXIT_USAGE
    command, parser = COMMANDS[argv[0]]
    try:
        return command(argv[1:])
    except UsageError as e:
        text = str(e)
        if not text.startswith("usage:"):  # a check made after parsing: give it the same usage line
            p = parser()
            text = f"{p.format_usage().strip()}\n{p.prog}: error: {text}"
        print(text, file=sys.stderr)
        return EXIT_USAGE
    except DurerError as e:
        print(str(e), file=sys.stderr)
        return EXIT_USAGE
    except BrokenPipeError:
        raise  # main() ends quietly
    except (ValueError, OSError) as e:
        print(f"durer: {e}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:
        print("durer: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
