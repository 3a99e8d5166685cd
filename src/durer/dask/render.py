"""Rendering on a `distributed` cluster: the units of work of rendering/units.py (tile x sample pass, for each
frame) as tasks, merged here in a fixed order, so the image is durer.render's to the bit.

    import durer, durer.dask
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster):   # or Client("tcp://H:8786")
        result = durer.dask.render(durer.load("cornell_box.xml"), 512, 512, samples=256)
        frames = durer.dask.render_frames(scene, cameras, 256, 256)   # one RenderResult per camera

The scene is checked and compiled here (a scene that cannot be rendered fails before any task is sent), and the
prepared Job (compiled scene, accelerator, textures) is scattered once to every worker (broadcast); each task
names it and carries only its tile, sample range and, for frames, its camera. Results are added as they arrive,
each tile's sample passes in ascending order (units.Accumulators.add), whichever task finishes first. A worker
that dies costs only its tasks: the scheduler runs them again elsewhere, and the image is the same bytes.
"""

from __future__ import annotations

import dataclasses
import time
import uuid
from collections import defaultdict

import numba as nb

from ..rendering.frames import frame_job
from ..rendering.frames import render_frames as local_frames
from ..rendering.renderer import _progress, denoise_result, resolve
from ..rendering.result import RenderResult
from ..rendering.units import Accumulators, Job, Tile, finish, prepare, render_unit
from ..scene.graph import Scene
from .cluster import active_client, cores

__all__ = ["prepare_job", "render", "render_frames", "results_of", "run_job", "split_for"]

TASKS_PER_THREAD = 4  # at least this many tasks per worker thread (split_for): a late task is a small share


def prepare_job(scene: Scene, width: int | None = None, height: int | None = None, *, samples: int | None = None,
                seed: int = 0, tile: int | None = None, pass_samples: int | None = None, options=None,
                **render_options) -> Job:
    """The Job durer.render would run for the same arguments (rendering/renderer.resolve), with tiles of
    `tile` pixels a side and passes of `pass_samples` samples if given. The tile side never changes the image;
    the pass size does (by the rounding of the sums), as units.py says: durer.render's is the default."""
    kwargs = dict(render_options)
    if options is None:
        kwargs["seed"] = seed
        if samples is not None:
            kwargs["samples"] = samples
    width, height, options = resolve(scene, width, height, options, **kwargs)
    if options.stats:
        raise ValueError("ray statistics are counted in one process: render with stats through durer.render")
    job = prepare(scene, width, height, options)
    for name, value in (("tile_side", tile), ("pass_samples", pass_samples)):
        if value is not None:
            if int(value) != value or value < 1:
                raise ValueError(f"{'tile' if name == 'tile_side' else name} must be a positive integer, got {value}")
            job = dataclasses.replace(job, **{name: int(value)})
    return job


def _unit(job: Job, camera, tile: Tile, samples: range) -> Accumulators:
    """One task: the unit on a worker, its Numba threads shared among the worker's task threads."""
    try:
        from distributed import get_worker

        worker = get_worker()
        threads = getattr(getattr(worker, "state", worker), "nthreads", 1)
    except (ImportError, ValueError):
        threads = 1
    nb.set_num_threads(max(1, min(nb.config.NUMBA_NUM_THREADS, cores() // max(1, threads))))
    return render_unit(job if camera is None else dataclasses.replace(job, camera=camera), tile, samples)


def split_for(job: Job, threads: int, frames: int = 1, per_thread: int = TASKS_PER_THREAD) -> Job:
    """The job with tiles halved (down to 4 pixels) until there are `per_thread` tasks for each of the cluster's
    `threads` (a small image's tiles are few: units.job_for cuts for the local threads). Never changes the image."""
    while len(job.units()) * frames < per_thread * threads and job.tile_side > 4:
        job = dataclasses.replace(job, tile_side=max(4, job.tile_side // 2 // 4 * 4))
    return job


def run_job(job: Job, cameras: list | None = None, client=None, bar=None) -> list[Accumulators]:
    """The whole image's sums of `job` through each camera (None: the job's own) on the cluster: every (frame,
    pass, tile) a task, results added in a fixed order as they arrive. `bar.update(1)` per finished task."""
    from distributed import as_completed

    client = client or active_client()
    if client is None:
        raise ValueError("no distributed client: pass client= or start one (distributed.Client(...))")
    framed = [None] if cameras is None else [frame_job(job, c).camera for c in cameras]
    units = job.units()
    n_tiles = len(job.tiles())
    handle = client.scatter(job, broadcast=True, hash=False)  # once per worker, not per task
    tag = uuid.uuid4().hex[:12]
    order = [(f, i) for f in range(len(framed)) for i in range(len(units))]
    futures = client.map(_unit, [handle] * len(order), [framed[f] for f, _ in order],
                         [units[i][0] for _, i in order], [units[i][1] for _, i in order],
                         key=[f"durer-unit-{tag}-{f}-{i}" for f, i in order], pure=False)
    where = {fut.key: k for k, fut in enumerate(futures)}
    sums = [Accumulators.empty(job) for _ in framed]
    waiting: dict[tuple[int, int], dict[int, Accumulators]] = defaultdict(dict)  # (frame, tile) -> pass -> sums
    next_pass: dict[tuple[int, int], int] = defaultdict(int)
    try:
        for fut in as_completed(futures):
            f, i = order[where[fut.key]]
            part = fut.result()
            fut.release()
            p, t = divmod(i, n_tiles)  # units are passes (ascending) over tiles
            key = (f, t)
            waiting[key][p] = part
            while next_pass[key] in waiting[key]:  # a tile's passes in ascending order: the same bytes
                sums[f].add(waiting[key].pop(next_pass[key]))
                next_pass[key] += 1
            if bar is not None:
                bar.update(1)
    finally:
        client.cancel(futures)
        client.cancel([handle])
    if any(waiting.values()):
        raise RuntimeError("some units' sums were never added")  # a bug, not a user error
    return sums


def results_of(job: Job, cameras: list | None, client, quiet: bool, fit: bool = True) -> list[RenderResult]:
    """Run the job (through each camera) on the client's cluster, or here without a distributed client; `fit`:
    smaller tiles if there are too few tasks for the cluster's threads (split_for)."""
    start = time.perf_counter()
    client = client or active_client()
    if client is None:
        return _denoised(job, local_frames(job, [job.camera] if cameras is None else cameras), start)
    if fit:
        threads = sum(client.nthreads().values())
        job = split_for(job, threads, 1 if cameras is None else len(cameras))
    tasks = len(job.units()) * (1 if cameras is None else len(cameras))
    with _progress(tasks, quiet, unit="task") as bar:
        sums = run_job(job, cameras, client, bar)
    jobs = [job] if cameras is None else [frame_job(job, c) for c in cameras]
    return _denoised(job, [finish(j, acc) for j, acc in zip(jobs, sums, strict=True)], start)


def _denoised(job: Job, results: list[RenderResult], start: float) -> list[RenderResult]:
    """The results, denoised here when the options ask for it (as durer.render does after its units), timed."""
    for r in results:
        if job.options.denoise:
            denoise_result(r, job.ctx.bundle.materials, job.options)
        r.seconds = time.perf_counter() - start
    return results


def render(scene: Scene, width: int | None = None, height: int | None = None, *, samples: int | None = None,
           seed: int = 0, client=None, tile: int | None = None, pass_samples: int | None = None, options=None,
           quiet: bool = True, **render_options) -> RenderResult:
    """durer.render(scene, width, height, samples=samples, seed=seed, **render_options) computed on the active
    (or given) distributed client as tasks of tiles x sample passes: the same bytes in colour, depth and
    normals. `tile`: tile side in pixels (default: units.plan's, halved until every worker thread has
    TASKS_PER_THREAD tasks); `pass_samples`: samples per task (default:
    durer.render's passes; another size changes the image by the rounding of the sums). Without a distributed
    client it renders here."""
    job = prepare_job(scene, width, height, samples=samples, seed=seed, tile=tile, pass_samples=pass_samples,
                      options=options, **render_options)
    return results_of(job, None, client, quiet, fit=tile is None)[0]


def render_frames(scene: Scene, cameras: list, width: int | None = None, height: int | None = None, *,
                  samples: int | None = None, seed: int = 0, client=None, tile: int | None = None,
                  pass_samples: int | None = None, options=None, quiet: bool = True,
                  **render_options) -> list[RenderResult]:
    """The scene through each camera (rendering/frames.py makes turntables and camera paths), every frame's
    units tasks on the cluster at once: frame k is durer.render of the scene with camera cameras[k], to the
    bit. The scene is compiled and sent to the workers once for all frames. Without a distributed client the
    frames render here, one after another."""
    if not cameras:
        raise ValueError("render_frames needs at least one camera")
    job = prepare_job(scene, width, height, samples=samples, seed=seed, tile=tile, pass_samples=pass_samples,
                      options=options, **render_options)
    return results_of(job, list(cameras), client, quiet, fit=tile is None)
