"""`durer render` with `--scheduler` (a Dask cluster), `--frames N` (a turntable) or `--camera-path FILE` (an
animation): the frames and cluster side of the render command. cli.py registers the flags (add_arguments) and
hands over here; a plain `durer render` never imports this module's dependencies.

    durer render scene.xml -o out.png --scheduler tcp://HOST:8786     # the same bytes, on the cluster
    durer render scene.xml -o out.png --scheduler local:2              # 2 worker processes on 127.0.0.1
    durer render scene.txt --frames 36 -o out/frame_%04d.png           # a turntable, one turn in 36 frames
    durer render scene.txt --camera-path path.json --frames 60 -o out/f_%03d.png

Outputs of several frames are printf patterns (`%04d`: the frame number from 0). Every mistake (a pattern without
a number, a bad scheduler address, a cluster that cannot be reached, a bad camera path) ends in one line, exit 2,
before any task is sent.
"""

from __future__ import annotations

import argparse
import sys
import time

from .errors import UsageError


def add_arguments(p: argparse.ArgumentParser, positive_int) -> None:
    """The --scheduler, --frames and --camera-path flags of `durer render`."""
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="render on a Dask cluster: its scheduler's address (tcp://HOST:8786), or local:N for N "
                        "worker processes on this machine (needs durer[dask]); the image is the same bytes")
    p.add_argument("--frames", type=positive_int, metavar="N",
                   help="render N frames: a turntable (the camera orbiting its look-at point, one turn in N "
                        "frames), or N frames along --camera-path; -o is then a pattern like out/frame_%%04d.png")
    p.add_argument("--camera-path", metavar="FILE",
                   help='animate along a JSON list of camera keys {"eye": [x,y,z], "look_at": [x,y,z], "up": '
                        '[x,y,z], "fov": degrees}, interpolated (one frame per key unless --frames)')


def wanted(a: argparse.Namespace) -> bool:
    """Does this render need this module (a cluster or several frames)?"""
    return bool(a.scheduler or a.frames or a.camera_path)


def frame_name(pattern: str, frame: int, flag: str = "-o") -> str:
    """The file of frame `frame`: pattern % frame; UsageError if the pattern does not hold one integer field."""
    try:
        name = pattern % frame
    except (TypeError, ValueError):
        name = None
    if name is None or name == pattern:
        raise UsageError(f"{flag}: several frames need a file name pattern with a frame number, such as "
                         f"out/frame_%04d.png (got {pattern!r})")
    return name


def run_frames(a: argparse.Namespace, depth, render_options, default_size) -> int:
    """`durer render` on a cluster and/or over frames; `depth` is (near, far, file) or None, render_options and
    default_size are cli.py's."""
    from .io.images import check_writable
    from .rendering.renderer import check_size

    spec = a.scheduler
    if spec is not None:
        from .dask.cluster import parse_scheduler

        try:
            parse_scheduler(spec)
        except ValueError as e:
            raise UsageError(str(e)) from None
    animated = bool(a.frames or a.camera_path)
    outputs = [(a.output, "-o"), *([(depth[2], "--depth")] if depth else []), *([(a.normals, "--normals")]
                                                                             if a.normals else [])]
    several = a.camera_path is not None or (a.frames or 1) > 1
    for path, flag in outputs:
        check_writable(frame_name(path, 0, flag) if several else path)
    from . import load

    if a.size is not None:
        check_size(a.size[0], a.size[1], a.samples or 1)
    scene = load(a.scene, mesh_path=a.mesh_path, camera=a.camera)
    options = render_options(a, scene.render_defaults)
    film = scene.render_defaults
    width, height = a.size or ((film["width"], film["height"]) if "width" in film else default_size(scene.camera))
    start = time.perf_counter()
    results = _render(scene, width, height, options, a, animated, spec)
    for k, result in enumerate(results):
        result.save(frame_name(a.output, k, "-o") if several else a.output, course=a.linear)
        if depth:
            result.save_depth(frame_name(depth[2], k, "--depth") if several else depth[2], depth[0], depth[1])
        if a.normals:
            result.save_normals(frame_name(a.normals, k, "--normals") if several else a.normals)
    if not a.quiet:
        what = f"{len(results)} frames {frame_name(a.output, 0)} ..." if several else a.output
        where = f" on {spec}" if spec else ""
        print(f"durer: wrote {what} ({width}x{height}{where}, {time.perf_counter() - start:.2f} s)",
              file=sys.stderr)
    return 0


def _render(scene, width: int, height: int, options, a: argparse.Namespace, animated: bool, spec: str | None):
    """The frames' RenderResults (one without --frames/--camera-path), on the cluster of `spec` or here."""
    from .rendering.kernel_cache import compile_notice
    from .rendering.renderer import _progress, resolve
    from .rendering.units import prepare

    width, height, options = resolve(scene, width, height, options)
    job = prepare(scene, width, height, options)  # checks and compiles the scene: fails before any task is sent
    cameras = None
    if animated:
        from .rendering.frames import camera_path, turntable

        if a.camera_path:
            cameras = camera_path(a.camera_path, a.frames, getattr(scene.camera, "angle", None))
        else:
            cameras = turntable(scene, a.frames, width, height, bounds=job.ctx.bundle.given.bounds())
    if spec is None:
        from .rendering.frames import render_frames

        if not a.quiet:  # what compiles and for how long, when Numba's cache lacks it
            compile_notice(options, scene)
        with _progress(width * height * options.samples * len(cameras), a.quiet) as bar:
            return render_frames(job, cameras, bar)
    from concurrent.futures import CancelledError

    from distributed import KilledWorker

    from .dask.cluster import connect
    from .dask.render import results_of

    try:
        with connect(spec) as client:
            return results_of(job, cameras, client, a.quiet)
    except (KilledWorker, CancelledError, OSError, TimeoutError) as e:  # the cluster, not the scene
        reason = (str(e).splitlines() or [type(e).__name__])[0]
        raise ValueError(f"--scheduler {spec}: the cluster failed ({type(e).__name__}: {reason})") from None
