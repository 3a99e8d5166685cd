"""Shared test fixtures: where ../shared is, and skips with a reason when it is absent."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest
from hypothesis import settings

# CI runs the property tests with fixed seeds (derandomize), so a submission's verdict does not depend on luck;
# local runs keep exploring new examples, and whatever they find is pinned with @example.
settings.register_profile("ci", derandomize=True)
# long local runs of the fuzz suite (tests/test_project_fuzz.py): `python -m pytest tests/test_project_fuzz.py --hypothesis-profile=fuzz`
settings.register_profile("fuzz", max_examples=5000, deadline=None)
if os.environ.get("CI"):
    settings.load_profile("ci")

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("DURER_SHARED", REPO.parent / "shared"))  # a worktree elsewhere names it
COURSE = SHARED / "scenes" / "mit6837"
MESHES = SHARED / "meshes"
MITSUBA_SCENES = SHARED / "scenes" / "mitsuba"

sys.path.insert(0, str(REPO / "tools"))

needs_course = pytest.mark.skipif(not COURSE.is_dir(), reason=f"course scenes not found at {COURSE} "
                                  "(they live in ../shared beside the repository)")
needs_meshes = pytest.mark.skipif(not MESHES.is_dir(), reason=f"Stanford meshes not found at {MESHES} "
                                  "(they live in ../shared beside the repository)")


@pytest.fixture(autouse=True, scope="session")
def _course_mesh_path():
    """Course scenes name meshes that live in other assignments' folders; let the loader find them."""
    if COURSE.is_dir():
        os.environ["DURER_MESH_PATH"] = os.pathsep.join(str(p) for p in sorted(COURSE.glob("assignment*")))
    yield


def pinhole_rays(rng, res: int, ortho: bool, ortho_span: float = 4.0):
    """res x res camera rays (origins, directions (res * res, 3)) in image order, so consecutive rays are coherent
    and take the packet path, from a random eye 9 from the origin looking at it; orthographic: parallel rays from
    a grid of origins ortho_span wide on each side of the eye."""
    import numpy as np

    eye = rng.normal(size=3)
    eye *= 9.0 / np.linalg.norm(eye)
    w = -eye / np.linalg.norm(eye)
    u = np.cross(w, rng.normal(size=3))
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    s = (np.arange(res) + 0.5) / res * 2 - 1
    a, b = np.meshgrid(s, s)
    side = a[..., None] * u + b[..., None] * v
    if ortho:
        return (eye + ortho_span * side).reshape(-1, 3), np.broadcast_to(w, (res * res, 3)).copy()
    return np.broadcast_to(eye, (res * res, 3)).copy(), (w + 0.4 * side).reshape(-1, 3)
