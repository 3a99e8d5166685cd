"""Packaging: `pip install .` imports durer while building (setup.py warms the kernel cache), so every runtime
dependency must also be a build requirement, or a fresh install fails before anything renders."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

tomllib = pytest.importorskip("tomllib")


def _names(requirements: list[str]) -> set[str]:
    return {re.split(r"[<>=!~;\[ ]", r, maxsplit=1)[0].lower() for r in requirements}


def test_every_runtime_dependency_is_a_build_requirement():
    meta = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    missing = _names(meta["project"]["dependencies"]) - _names(meta["build-system"]["requires"])
    assert not missing, f"add to [build-system] requires: {sorted(missing)}"
