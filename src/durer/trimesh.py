"""A ray backend for trimesh: `mesh.ray = durer.trimesh.RayMeshIntersector(mesh)`.

The same methods, arguments, return order and dtypes as trimesh's embree backend (`trimesh.ray.ray_pyembree`),
answered by durer's RaycastingScene: float64 throughout (no float32 rounding, so no rescaling of the mesh and no
stepping past hits), and each crossing listed once, through shared edges and vertices too (the watertight test's
tie-break, kernels/intersect.py). The tree is rebuilt when the mesh changes (trimesh's content hash).
"""

from __future__ import annotations

import numpy as np

from .query import RaycastingScene
from .query_args import INVALID_ID


class RayMeshIntersector:
    """Ray queries on a trimesh.Trimesh, as trimesh.ray.ray_pyembree.RayMeshIntersector answers them."""

    def __init__(self, geometry, scale_to_box: bool = True) -> None:
        """geometry: the trimesh.Trimesh to query. scale_to_box is trimesh's signature: embree's float32 needs the
        mesh scaled to a unit box, durer's float64 test does not, so either value gives the same answers."""
        self.mesh = geometry
        self._scale_to_box = scale_to_box
        self._key = None
        self._built: RaycastingScene | None = None

    def _scene(self) -> RaycastingScene:
        """The scene of the mesh as it is now: rebuilt when trimesh's hash of its vertices and faces changes."""
        key = hash(self.mesh)
        if self._built is None or key != self._key:
            scene = RaycastingScene()
            scene.add_triangles(np.asarray(self.mesh.vertices, np.float64), np.asarray(self.mesh.faces))
            self._built, self._key = scene, key
        return self._built

    @staticmethod
    def _rays(ray_origins, ray_directions) -> tuple[np.ndarray, np.ndarray]:
        """(n, 3) float64 origins and unit directions (a zero direction stays zero, and misses)."""
        o = np.array(ray_origins, dtype=np.float64).reshape(-1, 3)
        d = np.array(ray_directions, dtype=np.float64).reshape(-1, 3)
        if o.shape != d.shape:
            raise ValueError("Ray origin and direction don't match!")
        norm = np.linalg.norm(d, axis=1)
        d[norm > 0] /= norm[norm > 0, None]
        return o, d

    def intersects_id(self, ray_origins, ray_directions, multiple_hits: bool = True, max_hits: int = 100,
                      return_locations: bool = False):
        """The triangles hit by rays: (index_tri (m,) int64, index_ray (m,) int64[, locations (m, 3) float64]).
        With multiple_hits every crossing (at most max_hits a ray), listed as embree's backend lists them: every
        ray's first hit in ray order, then every second hit, and so on; else each ray's first hit."""
        o, d = self._rays(ray_origins, ray_directions)
        if len(o) == 0:
            tri, ray, t = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
        elif not multiple_hits:
            hits = self._scene().cast_rays(o, d)
            hit = np.asarray(hits["geometry_ids"]) != INVALID_ID
            ray = np.flatnonzero(hit).astype(np.int64)
            tri = np.asarray(hits["primitive_ids"])[hit].astype(np.int64)
            t = np.asarray(hits["t_hit"])[hit]
        else:
            listed = self._scene().list_intersections(o, d)
            ray = np.asarray(listed["ray_ids"]).astype(np.int64)
            rank = np.arange(len(ray)) - np.asarray(listed["ray_splits"]).astype(np.int64)[ray]
            keep = rank < int(max_hits)
            order = np.lexsort((ray[keep], rank[keep]))  # by depth, then ray: embree's rounds
            ray = ray[keep][order]
            tri = np.asarray(listed["primitive_ids"]).astype(np.int64)[keep][order]
            t = np.asarray(listed["t_hit"])[keep][order]
        if return_locations:
            return tri, ray, o[ray] + t[:, None] * d[ray]
        return tri, ray

    def intersects_location(self, ray_origins, ray_directions, multiple_hits: bool = True):
        """Where rays hit the surface: (locations (m, 3) float64, index_ray (m,) int64, index_tri (m,) int64)."""
        tri, ray, locations = self.intersects_id(ray_origins, ray_directions, multiple_hits=multiple_hits,
                                                 return_locations=True)
        return locations, ray, tri

    def intersects_first(self, ray_origins, ray_directions) -> np.ndarray:
        """The first triangle each ray hits, -1 for none: (n,) int32, as embree returns it."""
        o, d = self._rays(ray_origins, ray_directions)
        if len(o) == 0:
            return np.zeros(0, np.int32)
        return np.asarray(self._scene().cast_rays(o, d)["primitive_ids"]).view(np.int32).copy()

    def intersects_any(self, ray_origins, ray_directions) -> np.ndarray:
        """Whether each ray hits the surface: (n,) bool."""
        o, d = self._rays(ray_origins, ray_directions)
        if len(o) == 0:
            return np.zeros(0, np.bool_)
        return np.asarray(self._scene().test_occlusions(o, d)).copy()

    def contains_points(self, points) -> np.ndarray:
        """Whether each point (n, 3) is inside the mesh, by trimesh's own ray test (trimesh.ray.ray_util) on these
        rays: the embree backend's answer. Undefined on the surface, as there."""
        from trimesh.ray.ray_util import contains_points

        return contains_points(self, points)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_built"], state["_key"] = None, None  # rebuilt on first use
        return state
