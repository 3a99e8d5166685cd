"""durer.dask on a distributed.LocalCluster (2 worker processes on 127.0.0.1): every query equals the local call,
and the scene is scattered once rather than shipped with every task."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import trimesh

from durer.query import RaycastingScene

da = pytest.importorskip("dask.array", reason="durer.dask needs dask (pip install 'durer[dask]')")
distributed = pytest.importorskip("distributed", reason="the cluster test needs distributed (durer[dask])")
durer_dask = pytest.importorskip("durer.dask")


@pytest.fixture(scope="module")
def scene():
    s = RaycastingScene()
    torus = trimesh.creation.torus(1.0, 0.3, major_sections=24, minor_sections=12)
    g = s.add_triangles(torus.vertices, torus.faces)
    s.add_instance(g, np.diag([0.5, 0.5, 0.5, 1.0]))
    s.add_sphere([0.0, 0.0, 1.0], 0.25)
    return s


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None, silence_logs=40) as cluster, \
            distributed.Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(0)
    points = rng.uniform(-1.5, 1.5, (40, 50, 3))
    rays = np.concatenate([points * 2, -points], axis=-1)
    return points, rays


def test_without_a_cluster_the_local_scheduler_gives_the_same(scene, data):
    """Runs before the cluster fixture starts (pytest keeps file order), so no distributed client is active."""
    points, _ = data
    assert durer_dask.scatter(scene) is scene
    lazy = durer_dask.compute_distance(scene, da.from_array(points.astype(np.float32), chunks=(20, 50, 3)))
    assert lazy.dtype == np.float32  # float32 points, float32 distances (Open3D's types)
    np.testing.assert_array_equal(lazy.compute(scheduler="threads"),
                                  scene.compute_distance(points.astype(np.float32)))


@pytest.mark.slow
def test_cluster_results_equal_local_ones(scene, client, data):
    points, rays = data
    p = da.from_array(points, chunks=(10, 25, 3))
    r = da.from_array(rays, chunks=(20, 50, 6))
    cast = durer_dask.cast_rays(scene, r)
    lazy = {
        "distance": durer_dask.compute_distance(scene, p),
        "signed": durer_dask.compute_signed_distance(scene, p),
        "parity": durer_dask.compute_occupancy(scene, p, method="parity", nsamples=3),
        "occluded": durer_dask.test_occlusions(scene, r, tnear=0.1, tfar=2.0),
        **{f"cast_{k}": v for k, v in cast.items()},
    }
    assert all(isinstance(v, da.Array) for v in lazy.values())
    assert lazy["distance"].shape == (40, 50) and lazy["distance"].chunks == ((10,) * 4, (25, 25))
    got = dict(zip(lazy, client.compute(list(lazy.values()), sync=True), strict=True))
    local_cast = scene.cast_rays(rays)
    want = {
        "distance": scene.compute_distance(points), "signed": scene.compute_signed_distance(points),
        "parity": scene.compute_occupancy(points, method="parity", nsamples=3),
        "occluded": scene.test_occlusions(rays, t_min=0.1, t_max=2.0),
        **{f"cast_{k}": v for k, v in local_cast.items()},
    }
    for k in want:
        assert got[k].dtype == want[k].dtype, k
        np.testing.assert_array_equal(got[k], want[k], err_msg=k)


def test_the_scene_is_scattered_once(scene, client, data):
    points, _ = data
    handle = durer_dask.scatter(scene)
    assert isinstance(handle, distributed.Future)
    assert len(client.who_has([handle])[handle.key]) == 2  # on both workers
    p = da.from_array(points, chunks=(5, 50, 3))  # 8 tasks
    lazy = durer_dask.compute_signed_distance(handle, p)
    graph_bytes = len(pickle.dumps(dict(lazy.__dask_graph__())))
    assert graph_bytes < len(pickle.dumps(scene)) / 2  # the tasks name the scene, they do not carry it
    np.testing.assert_array_equal(lazy.compute(), scene.compute_signed_distance(points))


def test_value_errors(scene):
    with pytest.raises(ValueError, match=r"points must have shape \(\.\.\., 3\)"):
        durer_dask.compute_distance(scene, da.zeros((10, 4)))
    with pytest.raises(ValueError, match=r"rays must have shape \(\.\.\., 6\)"):
        durer_dask.cast_rays(scene, da.zeros((10, 3)))
    with pytest.raises(ValueError, match="numeric"):
        durer_dask.test_occlusions(scene, da.from_array(np.array([["a"] * 6])))
