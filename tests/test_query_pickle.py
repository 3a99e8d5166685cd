"""Pickling a RaycastingScene (issue 11): round trips keep the trees (no rebuild) and give the same answers in
other processes: multiprocessing fork and spawn, and a PyTorch-style Dataset worker (without torch)."""

from __future__ import annotations

import multiprocessing as mp
import pickle
import sys

import numpy as np
import pytest
import trimesh

import durer.accel.bvh
import durer.accel.distance
from durer.query import RaycastingScene

POINTS = np.random.default_rng(0).uniform(-1.5, 1.5, (300, 3))
RAYS = np.concatenate([POINTS * 3, -POINTS], axis=1)


def make_scene() -> RaycastingScene:
    s = RaycastingScene()
    torus = trimesh.creation.torus(1.0, 0.3, major_sections=16, minor_sections=8)
    g = s.add_triangles(torus.vertices, torus.faces)
    s.add_instance(g, np.diag([0.5, 0.5, 0.5, 1.0]))
    s.add_sphere([0.0, 0.0, 1.0], 0.25, transform=np.diag([1.0, 2.0, 1.0, 1.0]))
    return s


def answers(scene: RaycastingScene, rays: bool = True) -> dict:
    """Every query's result on fixed points (and rays)."""
    out = {"distance": scene.compute_distance(POINTS), "signed": scene.compute_signed_distance(POINTS),
           "parity": scene.compute_occupancy(POINTS, method="parity"),
           "closest": scene.compute_closest_points(POINTS)["points"],
           "normals": scene.compute_closest_points(POINTS)["primitive_normals"]}
    if rays:
        out.update(t_hit=scene.cast_rays(RAYS)["t_hit"], occluded=scene.test_occlusions(RAYS))
    return out


def _worker(payload: bytes) -> dict:
    return answers(pickle.loads(payload))


_INHERITED: RaycastingScene | None = None  # set before forking: the children see the parent's object unpickled


def _inherited_worker(_) -> dict:
    return answers(_INHERITED)


class PointDataset:
    """A torch.utils.data.Dataset-like object: holds the scene, serves (points, signed distances) by index.
    DataLoader workers receive it pickled (spawn) or inherit it (fork)."""

    def __init__(self, scene: RaycastingScene, points: np.ndarray, batch: int):
        self.scene, self.points, self.batch = scene, points, batch

    def __len__(self) -> int:
        return -(-len(self.points) // self.batch)

    def __getitem__(self, i: int):
        p = self.points[i * self.batch:(i + 1) * self.batch]
        return p, self.scene.compute_signed_distance(p)


def _load_all(dataset: PointDataset) -> np.ndarray:
    return np.concatenate([dataset[i][1] for i in range(len(dataset))])


@pytest.fixture(scope="module")
def scene():
    return make_scene()


@pytest.fixture(scope="module")
def expected(scene):
    return answers(scene)


def _assert_same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def test_round_trip_keeps_trees_and_answers(scene, expected, monkeypatch):
    scene.compute_winding_number(POINTS[:1])  # moments built too
    copy = pickle.loads(pickle.dumps(scene))
    assert copy._bvh is not None and copy._distance is not None and copy._distance._moments is not None

    def no_rebuild(*args, **kwargs):
        raise AssertionError("rebuilt after unpickling")

    monkeypatch.setattr(durer.accel.bvh.TwoLevelBVH, "__init__", no_rebuild)
    monkeypatch.setattr(durer.accel.distance.DistanceIndex, "__init__", no_rebuild)
    _assert_same(answers(copy), expected)
    assert repr(copy) == repr(scene)


def test_an_unbuilt_scene_is_built_before_pickling():
    s = make_scene()
    assert s._bvh is None
    copy = pickle.loads(pickle.dumps(s))
    assert s._bvh is not None and copy._bvh is not None
    empty = pickle.loads(pickle.dumps(RaycastingScene()))
    assert "0 geometries" in repr(empty)
    with pytest.raises(ValueError, match="state version"):
        RaycastingScene().__setstate__({"version": 99})
    with pytest.raises(ValueError, match="state version 1: this durer reads version 2"):  # pickled by session 11's
        RaycastingScene().__setstate__({"version": 1})


@pytest.mark.slow
def test_spawned_processes_give_the_same_answers(scene, expected):
    with mp.get_context("spawn").Pool(2) as pool:
        results = pool.map(_worker, [pickle.dumps(scene)] * 2)
    for r in results:
        _assert_same(r, expected)


def test_forked_processes_give_the_same_answers(scene, expected, monkeypatch):
    """Fork after the parent has run every query: no query uses a Numba parallel region (the ray kernels, two-level
    ones included, and the point kernels run on run_blocks' thread pools, which are remade in the child), so they
    all work even under GNU OpenMP, which cannot enter a parallel region in a child forked after using one. The
    pool calls are bounded in time: a worker that died would otherwise leave map() waiting forever."""
    if "fork" not in mp.get_all_start_methods():
        pytest.skip("start method fork not available on this platform")
    scene.cast_rays(RAYS)  # the parent has traced rays (two-level kernels: a shape is placed twice) before forking
    monkeypatch.setattr(sys.modules[__name__], "_INHERITED", scene)
    with mp.get_context("fork").Pool(2) as pool:
        results = pool.map_async(_worker, [pickle.dumps(scene)] * 2).get(timeout=300)
        results += pool.map_async(_inherited_worker, [0, 1]).get(timeout=300)
    for r in results:
        _assert_same(r, expected)


@pytest.mark.slow
def test_a_dataset_holding_the_scene_works_in_a_spawned_worker(scene):
    data = PointDataset(scene, POINTS, batch=64)
    local = _load_all(data)
    with mp.get_context("spawn").Pool(1) as pool:
        remote = pool.apply(_load_all, (data,))
    np.testing.assert_array_equal(remote, local)
    np.testing.assert_array_equal(local, scene.compute_signed_distance(POINTS))
