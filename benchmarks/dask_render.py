"""durer.dask.render on a LocalCluster of 2 single-thread worker processes against durer.render in one process,
on the path-traced Cornell box (examples/cornell_box.xml) at 512 x 512, 256 samples per pixel; and the cluster's
overhead per task.

Timed after a warm-up render on each side (kernels compiled and loaded from Numba's cache in every worker); the
cluster's start-up is reported apart. One process runs with Numba's default threads (all cores) and with 1 thread;
each worker with 1 (NUMBA_NUM_THREADS=1, as `--scheduler local:N` gives cores // N). The images must be the same
bytes. Overhead per task: many tiny units (a 4 x 4 tile, 1 sample) on the cluster against the same units one after
another in this process with 1 thread: (cluster wall x workers - local wall) / tasks.

    PYTHONPATH=src python benchmarks/dask_render.py [--quick] [--size 512] [--spp 256] [--workers 2]

`--quick`: 128 x 128, 16 spp (a sanity check on a busy machine).
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numba
import numpy as np

import durer
import durer.dask
from durer.rendering import units as U

ROOT = Path(__file__).resolve().parents[1]


def _timed(fn):
    start = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - start


def _same(a, b) -> bool:
    return all(np.array_equal(getattr(a, k), getattr(b, k)) for k in ("color", "depth", "normals"))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="128 x 128, 16 spp")
    p.add_argument("--size", type=int, default=512)
    p.add_argument("--spp", type=int, default=256)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--tiny-tasks", type=int, default=400, help="tasks of the overhead measure")
    a = p.parse_args()
    size, spp = (128, 16) if a.quick else (a.size, a.spp)
    scene = durer.load(ROOT / "examples" / "cornell_box.xml")
    print(f"cornell_box.xml {size}x{size}, {spp} spp, load {os.getloadavg()[0]:.2f}, {numba.get_num_threads()} "
          f"Numba threads here")
    durer.render(scene, 16, 16, samples=2)  # warm: compile or load the kernels
    local, t_local = _timed(lambda: durer.render(scene, size, size, samples=spp))
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    one, t_one = _timed(lambda: durer.render(scene, size, size, samples=spp))
    job = durer.dask.prepare_job(scene, size, size, samples=spp)
    tiny = durer.dask.prepare_job(scene, 4 * a.tiny_tasks, 4, samples=1, tile=4)
    _, t_tiny_local = _timed(lambda: U.run(tiny))
    numba.set_num_threads(threads)
    start = time.perf_counter()
    with durer.dask.connect(f"local:{a.workers}") as client:
        t_start = time.perf_counter() - start
        durer.dask.render(scene, 16, 16, samples=2, client=client)  # warm the workers
        remote, t_remote = _timed(lambda: durer.dask.render(scene, size, size, samples=spp, client=client))
        _, t_tiny = _timed(lambda: durer.dask.run_job(tiny, client=client))
    tasks = len(durer.dask.split_for(job, a.workers).units())  # as render() cuts it for the cluster
    per_task = (t_tiny * a.workers - t_tiny_local) / len(tiny.units())
    print(f"same bytes as one process: {_same(local, remote) and _same(local, one)}")
    print(f"one process, {threads} threads: {t_local:.2f} s; 1 thread: {t_one:.2f} s")
    print(f"LocalCluster {a.workers} x 1 thread: {t_remote:.2f} s ({tasks} tasks; start-up {t_start:.2f} s)")
    print(f"speed-up over one process: {t_local / t_remote:.2f}x ({threads} threads), "
          f"{t_one / t_remote:.2f}x (1 thread)")
    print(f"overhead per task: {per_task * 1e3:.1f} ms ({len(tiny.units())} tiny tasks: {t_tiny:.2f} s on the "
          f"cluster, {t_tiny_local:.2f} s in one thread here); {tasks} tasks x that = "
          f"{100 * tasks * per_task / a.workers / t_remote:.1f}% of the render")


if __name__ == "__main__":
    main()
