"""durer on Dask (optional extra: pip install "durer[dask]"): ray and point queries over dask arrays
(queries.py) and the cluster to run on (cluster.py: the active client, or `--scheduler tcp://HOST:8786` / `local:N`).

    import durer.dask
    sdf = durer.dask.compute_signed_distance(scene, points)        # a dask array, lazy
"""

from __future__ import annotations

from .cluster import active_client, connect
from .queries import cast_rays, compute_distance, compute_occupancy, compute_signed_distance, scatter, test_occlusions

__all__ = ["active_client", "cast_rays", "compute_distance", "compute_occupancy", "compute_signed_distance",
           "connect", "scatter", "test_occlusions"]
