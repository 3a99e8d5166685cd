"""Ray and point batches of a RaycastingScene on Dask (optional extra: pip install "durer[dask]").

Each query maps the scene's own method over the chunks of a dask.array of rays (..., 6) or points (..., 3) and
returns dask arrays of the same leading shape and chunks, so it runs on whatever scheduler is active: threads by
default, or any `distributed` cluster (a LocalCluster, or a real one through its scheduler's address). The scene
is sent once: with a distributed client it is scattered to every worker (`client.scatter(..., broadcast=True)`)
and the tasks refer to it by key; it pickles with its BVHs, so workers do not rebuild them.

    from distributed import Client, LocalCluster
    import dask.array as da
    import durer.dask

    client = Client(LocalCluster(n_workers=2, threads_per_worker=1))   # or Client("tcp://scheduler:8786")
    points = da.random.uniform(-1, 1, (10_000_000, 3), chunks=(1_000_000, 3))
    sdf = durer.dask.compute_signed_distance(scene, points)   # lazy
    sdf.compute()                                             # numpy array

Pass `scene=durer.dask.scatter(scene)` to several calls to share one copy on the cluster.
"""

from __future__ import annotations

import dask.array as da
import numpy as np

from ..query import RaycastingScene
from .cluster import active_client

__all__ = ["cast_rays", "compute_distance", "compute_occupancy", "compute_signed_distance", "scatter",
           "test_occlusions"]

_CAST_FIELDS = 8  # t_hit, geometry id, primitive id, u, v, normal x, y, z (packed as float64 per ray)


def scatter(scene: RaycastingScene, client=None):
    """The scene placed on the cluster once: a Future on every worker of `client` (default: the active client),
    or the scene itself when no distributed client is running. Pass the result as `scene` to the queries."""
    if not isinstance(scene, RaycastingScene):
        return scene  # already scattered
    client = client or active_client()
    if client is None:
        return scene
    scene._tree()  # build before pickling, once, here rather than on each worker
    return client.scatter(scene, broadcast=True, hash=False)


def _array(name: str, a, width: int) -> da.Array:
    """a as a float dask array (..., width), one chunk along the last axis; ValueError naming `name` otherwise."""
    arr = a if isinstance(a, da.Array) else da.asarray(a)
    if arr.ndim < 1 or arr.shape[-1] != width:
        raise ValueError(f"{name} must have shape (..., {width}), got {arr.shape}")
    if not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if len(arr.chunks[-1]) != 1:
        arr = arr.rechunk({arr.ndim - 1: width})
    return arr


def _per_item(func, scene, arr: da.Array, dtype, **kwargs) -> da.Array:
    """func(block, scene, **kwargs) over the blocks of arr (..., k), giving (...,) blocks."""
    if dtype == np.float64 and arr.dtype == np.float32:  # float32 points give float32 answers
        dtype = np.float32
    handle = scatter(scene)
    return da.map_blocks(func, arr, handle, dtype=dtype, drop_axis=arr.ndim - 1,
                         meta=np.empty((0,) * (arr.ndim - 1), dtype), **kwargs)


def _cast_block(rays, scene, **kwargs):
    r = scene.cast_rays(rays, **kwargs)
    out = np.empty((*rays.shape[:-1], _CAST_FIELDS))
    out[..., 0] = r["t_hit"]
    out[..., 1] = r["geometry_ids"]
    out[..., 2] = r["primitive_ids"]
    out[..., 3:5] = r["primitive_uvs"]
    out[..., 5:8] = r["primitive_normals"]
    return out


def cast_rays(scene, rays, **kwargs) -> dict:
    """RaycastingScene.cast_rays over a dask array of rays (..., 6): a dict of dask arrays (t_hit, geometry_ids,
    primitive_ids, primitive_uvs, primitive_normals), computed together chunk by chunk."""
    arr = _array("rays", rays, 6)
    handle = scatter(scene)
    packed = da.map_blocks(_cast_block, arr, handle, dtype=np.float64, chunks=(*arr.chunks[:-1], (_CAST_FIELDS,)),
                           meta=np.empty((0,) * arr.ndim), **kwargs)
    return {
        "t_hit": packed[..., 0],
        "geometry_ids": packed[..., 1].astype(np.uint32),
        "primitive_ids": packed[..., 2].astype(np.uint32),
        "primitive_uvs": packed[..., 3:5],
        "primitive_normals": packed[..., 5:8],
    }


def _occlusion_block(rays, scene, **kwargs):
    return scene.test_occlusions(rays, **kwargs)


def test_occlusions(scene, rays, **kwargs) -> da.Array:
    """RaycastingScene.test_occlusions over a dask array of rays (..., 6) (t_min/t_max or tnear/tfar scalars)."""
    return _per_item(_occlusion_block, scene, _array("rays", rays, 6), np.bool_, **kwargs)


test_occlusions.__test__ = False  # a query, not a test for pytest to collect


def _distance_block(points, scene, **kwargs):
    return scene.compute_distance(points, **kwargs)


def _signed_block(points, scene, **kwargs):
    return scene.compute_signed_distance(points, **kwargs)


def _occupancy_block(points, scene, **kwargs):
    return scene.compute_occupancy(points, **kwargs)


def compute_distance(scene, points, **kwargs) -> da.Array:
    """RaycastingScene.compute_distance over a dask array of points (..., 3)."""
    return _per_item(_distance_block, scene, _array("points", points, 3), np.float64, **kwargs)


def compute_signed_distance(scene, points, **kwargs) -> da.Array:
    """RaycastingScene.compute_signed_distance over a dask array of points (..., 3) (method=, nsamples=, beta=)."""
    return _per_item(_signed_block, scene, _array("points", points, 3), np.float64, **kwargs)


def compute_occupancy(scene, points, **kwargs) -> da.Array:
    """RaycastingScene.compute_occupancy over a dask array of points (..., 3) (method=, nsamples=, beta=)."""
    return _per_item(_occupancy_block, scene, _array("points", points, 3), np.float64, **kwargs)
