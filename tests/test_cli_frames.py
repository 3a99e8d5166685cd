"""`durer render --scheduler / --frames / --camera-path` (cli_frames.py): frames on a LocalCluster of 2 workers on
127.0.0.1 (local:2) and here are durer.render's bytes for the same cameras; every mistake (bad address,
unreachable scheduler, unreadable scene, bad pattern or camera path) ends in one line and exit 2, quickly."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np
import pytest

import durer
from durer.cli import main
from durer.rendering.frames import turntable

pytest.importorskip("distributed", reason="--scheduler needs distributed (durer[dask])")
from durer.dask import cluster  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SPHERES = str(EXAMPLES / "spheres.txt")
FLAGS = ["--size", "16", "12", "--shadows", "--samples", "2", "-q"]


def _fails(capsys, argv: list[str], *needles: str) -> str:
    """main(argv) ends with exit 2 and an error on stderr's last line (no traceback) naming every needle."""
    assert main(["render", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err
    last = err.splitlines()[-1]
    for needle in needles:
        assert needle in last, err
    return last


@pytest.mark.parametrize("spec", ["foo", "local:0", "local:two", "http://host:8786", "tcp://"])
def test_bad_scheduler_addresses_end_in_one_line(spec, capsys, tmp_path):
    start = time.monotonic()
    _fails(capsys, [SPHERES, "-o", str(tmp_path / "a.png"), "--scheduler", spec, *FLAGS], "--scheduler", spec)
    assert time.monotonic() - start < 5  # parsed before the scene is read
    assert not (tmp_path / "a.png").exists()


def test_an_unreachable_scheduler_ends_in_one_line_within_the_timeout(capsys, tmp_path, monkeypatch):
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT", 2.0)
    start = time.monotonic()
    last = _fails(capsys, [SPHERES, "-o", str(tmp_path / "a.png"), "--scheduler", "tcp://127.0.0.1:1", *FLAGS],
                  "cannot reach the scheduler")
    assert last.startswith("durer: --scheduler tcp://127.0.0.1:1")
    assert time.monotonic() - start < 30  # 2 s to connect, plus compiling the scene


def test_an_unreadable_scene_fails_before_connecting(capsys, tmp_path):
    start = time.monotonic()
    _fails(capsys, [str(tmp_path / "missing.txt"), "-o", str(tmp_path / "a.png"), "--scheduler",
                    "tcp://127.0.0.1:1", *FLAGS], "missing.txt")
    assert time.monotonic() - start < 5


def test_frame_patterns_and_camera_paths_are_checked(capsys, tmp_path):
    _fails(capsys, [SPHERES, "-o", str(tmp_path / "a.png"), "--frames", "3", *FLAGS], "-o", "%04d")
    _fails(capsys, [SPHERES, "-o", str(tmp_path / "a_%d.png"), "--frames", "0", *FLAGS], "--frames")
    bad = tmp_path / "path.json"
    bad.write_text('[{"eye": [0, 0, 5], "look_at": [0, 0]}]')
    _fails(capsys, [SPHERES, "-o", str(tmp_path / "a_%d.png"), "--camera-path", str(bad), *FLAGS],
           "key 0", "'look_at' must be a list of 3 numbers")
    bad.write_text("not json")
    _fails(capsys, [SPHERES, "-o", str(tmp_path / "a_%d.png"), "--camera-path", str(bad), *FLAGS], "not JSON")
    assert not list(tmp_path.glob("a*"))


def _reference(frames: int) -> list[np.ndarray]:
    scene = durer.load(SPHERES)
    kw = dict(shadows=True, samples=2, sampler="jittered")
    return [durer.render(dataclasses.replace(scene, camera=c), 16, 12, **kw).color
            for c in turntable(scene, frames, 16, 12)]


def test_turntable_frames_here_and_on_a_local_cluster_are_the_same_bytes(tmp_path):
    want = _reference(3)
    assert main(["render", SPHERES, "-o", str(tmp_path / "here_%02d.npy"), "--frames", "3", *FLAGS]) == 0
    assert main(["render", SPHERES, "-o", str(tmp_path / "dask_%02d.npy"), "--frames", "3", "--scheduler", "local:2",
                 *FLAGS]) == 0
    for k in range(3):
        np.testing.assert_array_equal(np.load(tmp_path / f"here_{k:02d}.npy"), want[k])
        np.testing.assert_array_equal(np.load(tmp_path / f"dask_{k:02d}.npy"), want[k])
    assert not np.array_equal(want[0], want[1])
