"""durer.dask.render and render_frames on a distributed.LocalCluster (2 worker processes on 127.0.0.1, started and
stopped here): the same bytes as durer.render for the path tracer, the Whitted tracer and a course scene, whatever
the tile size, with the pass sizes' own local reference; a worker killed mid-render still gives the same bytes;
frames equal their cameras rendered one by one."""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import durer
from durer.rendering import units as U
from durer.rendering.frames import camera_path, turntable

distributed = pytest.importorskip("distributed", reason="the cluster tests need distributed (durer[dask])")
durer_dask = pytest.importorskip("durer.dask")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
W, H = 20, 14  # not multiples of the tile sides: edge tiles are cut

CASES = {  # name -> scene, render options (a filter with a halo in each)
    "path": ("cornell_box.xml", dict(integrator="path", samples=3, max_depth=4, filter="tent", filter_radius=1.5)),
    "whitted": ("spheres.txt", dict(integrator="whitted", shadows=True, bounces=2, samples=2, sampler="random",
                                    filter="gaussian", filter_radius=0.5, seed=3)),
    "course": ("fisheye.txt", dict(samples=2, sampler="jittered", course_random=True, course_edges=True)),
}


def _arrays(r) -> np.ndarray:
    return np.concatenate([r.color, r.depth[..., None], r.normals], axis=-1)


@pytest.fixture(scope="module")
def scenes():
    return {name: durer.load(EXAMPLES / scene) for name, (scene, _) in CASES.items()}


@pytest.fixture(scope="module")
def local(scenes):
    """durer.render's images, before any cluster starts."""
    return {name: _arrays(durer.render(scenes[name], W, H, **kw)) for name, (_, kw) in CASES.items()}


def test_without_a_client_it_renders_here(scenes, local):
    """No distributed client: the same call renders on this machine (and gives the same bytes)."""
    assert durer_dask.active_client() is None
    _, kw = CASES["whitted"]
    np.testing.assert_array_equal(_arrays(durer_dask.render(scenes["whitted"], W, H, **kw)), local["whitted"])


@pytest.fixture(scope="module")
def cluster(local):
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None, silence_logs=40) as c:
        yield c


@pytest.fixture(scope="module")
def client(cluster):
    with distributed.Client(cluster) as c:
        c.wait_for_workers(2, timeout=120)  # under load the second worker process may still be starting
        yield c


@pytest.mark.parametrize("name", list(CASES))
def test_same_bytes_as_one_machine_whatever_the_tiles(name, scenes, local, client):
    _, kw = CASES[name]
    for tile in (None, 4, 7):
        got = durer_dask.render(scenes[name], W, H, client=client, tile=tile, **kw)
        np.testing.assert_array_equal(_arrays(got), local[name], err_msg=f"tile {tile}")
    assert local[name][..., :3].max() > 0


@pytest.mark.parametrize("pass_samples", [1, 2])
def test_sample_passes_as_tasks_equal_the_same_passes_here(pass_samples, scenes, client):
    """Passes of 1 or 2 of 3 samples per pixel: the tasks' sums, added in each tile's pass order whatever order
    they finish, equal the same decomposition run here (units.run), to the bit."""
    _, kw = CASES["path"]
    job = durer_dask.prepare_job(scenes["path"], W, H, tile=8, pass_samples=pass_samples, **kw)
    assert len(job.units()) == len(job.tiles()) * -(-3 // pass_samples)
    want = _arrays(U.finish(job, U.run(job)))
    got = durer_dask.render(scenes["path"], W, H, client=client, tile=8, pass_samples=pass_samples, **kw)
    np.testing.assert_array_equal(_arrays(got), want)


def test_frames_equal_their_cameras_rendered_one_by_one(scenes, client, tmp_path):
    scene = scenes["whitted"]
    _, kw = CASES["whitted"]
    cameras = turntable(scene, 3, W, H)
    path = tmp_path / "path.json"
    path.write_text(json.dumps([{"eye": [0, 2, 9], "look_at": [0, 0, 0], "fov": 30},
                                {"eye": [9, 2, 0], "look_at": [0, 1, 0], "up": [0, 1, 0], "fov": 50}]))
    keyed = camera_path(path, 3)
    np.testing.assert_allclose(keyed[1].center, [4.5, 2, 4.5])
    assert keyed[1].angle == 40.0
    cameras += keyed
    frames = durer_dask.render_frames(scene, cameras, W, H, client=client, tile=8, **kw)
    assert len(frames) == len(cameras)
    for k, (camera, frame) in enumerate(zip(cameras, frames, strict=True)):
        want = durer.render(dataclasses.replace(scene, camera=camera), W, H, **kw)
        np.testing.assert_array_equal(_arrays(frame), _arrays(want), err_msg=f"frame {k}")
    assert not np.array_equal(frames[0].color, frames[1].color)  # the camera did move


def test_a_scene_that_cannot_render_fails_before_any_task(client):
    bad = durer.load(EXAMPLES / "cornell_box.xml")
    with pytest.raises(ValueError, match="integrator='path'"):
        durer_dask.render(bad, W, H, client=client, integrator="whitted")
    with pytest.raises(ValueError, match="tile must be a positive integer"):
        durer_dask.render(bad, W, H, client=client, tile=0)


class _Counter:
    def __init__(self):
        self.n = 0

    def update(self, n: int = 1) -> None:
        self.n += n


def test_a_worker_killed_mid_render_costs_only_its_tasks(scenes, local, cluster, client):
    """One of the two worker processes dies (SIGKILL) after some tasks have finished: the nanny restarts it, the
    scheduler runs its tasks again, and the image is the same bytes."""
    _, kw = CASES["path"]
    job = durer_dask.prepare_job(scenes["path"], W, H, tile=2, pass_samples=1, **kw)  # 10 x 7 tiles x 3 passes
    want = _arrays(U.finish(job, U.run(job)))
    bar, out = _Counter(), {}
    runner = threading.Thread(target=lambda: out.setdefault("sums", durer_dask.run_job(job, client=client, bar=bar)))
    runner.start()
    deadline = time.monotonic() + 60
    while bar.n < 5 and time.monotonic() < deadline:
        time.sleep(0.01)
    victim = sorted(client.scheduler_info()["workers"])[0]
    killed_at = bar.n
    os.kill(client.run(os.getpid, workers=[victim])[victim], signal.SIGKILL)
    runner.join(180)
    assert not runner.is_alive()
    assert 5 <= killed_at < len(job.units()), killed_at  # it died mid-render
    assert victim not in client.scheduler_info()["workers"]  # (its nanny started a new one)
    np.testing.assert_array_equal(_arrays(U.finish(job, out["sums"][0])), want)
    assert bar.n == len(job.units())


def test_turntable_orbits_the_look_at_point_about_the_vertical(scenes):
    """spheres.txt's camera looks down at the scene: each frame keeps its height and its distance to the pivot
    (on the viewing axis, as far as the bounding-box centre) and looks at it; frame 2 of 4 is opposite frame 0."""
    from durer.rendering.frames import look_at_point

    scene = scenes["whitted"]
    cams = turntable(scene, 4, W, H)
    pivot = look_at_point(scene, cams[0])
    assert cams[0] is scene.camera or np.array_equal(cams[0].center, scene.camera.center)
    for c in cams:
        np.testing.assert_allclose(c.center[1], cams[0].center[1], atol=1e-12)  # the same height
        np.testing.assert_allclose(np.linalg.norm(c.center - pivot), np.linalg.norm(cams[0].center - pivot))
        to_pivot = (pivot - c.center) / np.linalg.norm(pivot - c.center)
        np.testing.assert_allclose(c.direction, to_pivot, atol=1e-12)
    np.testing.assert_allclose(cams[2].center[[0, 2]] - pivot[[0, 2]], -(cams[0].center[[0, 2]] - pivot[[0, 2]]),
                               atol=1e-12)


def test_small_images_are_cut_into_enough_tasks_for_the_cluster(scenes):
    _, kw = CASES["path"]
    job = durer_dask.prepare_job(scenes["path"], 128, 128, **{**kw, "samples": 16, "filter": "box", "filter_radius": 0.5})
    assert len(job.units()) < 8  # a small image has few tiles (units.job_for: one or two per local thread)
    split = durer_dask.split_for(job, threads=2)
    assert len(split.units()) >= 8 and split.tile_side % 4 == 0
    assert durer_dask.split_for(job, threads=2, frames=8).tile_side == job.tile_side  # frames are tasks too


def _unit_specs(dask_scheduler) -> list[int]:
    """(On the scheduler) pickled sizes of the durer units' task specs still known."""
    import pickle

    return [len(pickle.dumps(ts.run_spec)) for key, ts in dask_scheduler.tasks.items()
            if str(key).startswith("durer-unit") and ts.run_spec is not None]


class _Probe:
    """A progress bar that, at the first finished task, reads the task specs on the scheduler and where the job is."""

    def __init__(self, client):
        self.client, self.specs, self.job_on = client, None, None

    def update(self, n: int = 1) -> None:
        if self.specs is None:
            self.specs = self.client.run_on_scheduler(_unit_specs)
            self.job_on = self.client.run_on_scheduler(
                lambda dask_scheduler: {str(k): len(ts.who_has or ()) for k, ts in dask_scheduler.tasks.items()
                                        if type(ts.run_spec).__name__ == "DataNode" or ts.run_spec is None})


def test_the_job_goes_to_each_worker_once(scenes, client):
    """The tasks name the scattered job (on both workers), they do not carry it: each spec is a small fraction of
    the pickled job (compiled scene and BVH)."""
    import pickle

    _, kw = CASES["path"]
    job = durer_dask.prepare_job(scenes["path"], W, H, tile=4, **kw)
    # both workers up (a worker killed by an earlier test restarts; under load that takes seconds): the broadcast
    # reaches the workers the scheduler knows
    client.wait_for_workers(2, timeout=120)
    probe = _Probe(client)
    durer_dask.run_job(job, client=client, bar=probe)
    assert probe.specs and len(probe.specs) > 1
    assert max(probe.specs) < len(pickle.dumps(job)) / 20, (max(probe.specs), len(pickle.dumps(job)))
    assert 2 in probe.job_on.values(), probe.job_on  # the job, broadcast: on both workers
