"""durer.warmup: the kernel warm-up that `pip install .` runs (setup.py) and `durer warmup` runs by hand."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from durer import warmup


def test_unknown_groups_are_refused_by_name():
    with pytest.raises(ValueError, match="unknown warm-up group.*nope.*course, path, queries, points"):
        warmup.warm_up(["points", "nope"])


@pytest.mark.slow
def test_a_group_runs_in_a_child_process_and_leaves_the_kernels_cached():
    seconds = warmup.warm_up(["points"], processes=1, quiet=True)
    assert seconds > 0
    # a fresh process now finds every point-query kernel in the cache: Numba saves nothing new
    env = {**os.environ, "NUMBA_DEBUG_CACHE": "1"}
    proc = subprocess.run([sys.executable, "-m", "durer.warmup", "points"], env=env, capture_output=True, text=True,
                          check=True)
    lines = (proc.stdout + proc.stderr).splitlines()
    assert any("data loaded" in line for line in lines)  # kernels came from the cache ...
    assert [line for line in lines if "data saved" in line] == []  # ... and none had to be compiled


@pytest.mark.slow
def test_every_group_covers_the_public_api_without_errors():
    warmup.run_groups(["course", "path"])  # in this process: the kernels the rest of the suite needs anyway


def test_the_command_refuses_an_unknown_group_in_one_line(capsys):
    from durer.cli import main

    assert main(["warmup", "bogus"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown warm-up group(s): bogus" in err[0]
