"""durer on Dask (optional extra: pip install "durer[dask]"): ray and point queries over dask arrays
(queries.py), renders and animation frames as tasks of tiles x sample passes (render.py), and the cluster to run
on (cluster.py: the active client, or `--scheduler tcp://HOST:8786` / `local:N`).

    import durer.dask
    sdf = durer.dask.compute_signed_distance(scene, points)        # a dask array, lazy
    result = durer.dask.render(durer.load("scene.xml"), 512, 512)  # durer.render's bytes, on the cluster
"""

from __future__ import annotations

from .cluster import active_client, connect
from .queries import cast_rays, compute_distance, compute_occupancy, compute_signed_distance, scatter, test_occlusions
from .render import prepare_job, render, render_frames, run_job, split_for

__all__ = ["active_client", "cast_rays", "compute_distance", "compute_occupancy", "compute_signed_distance",
           "connect", "prepare_job", "render", "render_frames", "run_job", "scatter", "split_for", "test_occlusions"]
