"""BruteForce: the lecture's loop, "for every object, keep the closest hit", with no acceleration structure.

Every ray is tested against every primitive (kernels/brute.py); it is the reference every accelerator must agree
with, the `--accel brute` render option, and the loop the course's -stats counts.
"""

from __future__ import annotations

import numpy as np

from ..kernels.brute import any_hit_all, closest_hit_all
from .compile import CompiledScene
from .hits import Hits, QueriedOnly, ray_arrays


class BruteForce(QueriedOnly):
    """Tests every ray against every primitive; the reference that accelerators must agree with."""

    name = "brute"

    def __init__(self, cs: CompiledScene):
        self.cs = cs

    def _geometry(self):
        cs = self.cs.flat  # instances flattened (same triangle ids)
        return (cs.triangles, cs.sphere_center, cs.sphere_radius, cs.sphere_world_to_object,
                cs.plane_normal, cs.plane_offset)

    def closest_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> Hits:
        h = Hits.empty(len(origins))
        closest_hit_all(*ray_arrays(origins, directions, t_min, t_max), *self._geometry(), h.t, h.kind, h.prim, h.u,
                        h.v)
        return h

    def any_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> np.ndarray:
        out = np.empty(len(origins), dtype=np.bool_)
        any_hit_all(*ray_arrays(origins, directions, t_min, t_max), *self._geometry(), out)
        return out
