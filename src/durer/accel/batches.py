"""Batch ray queries through a TwoLevelBVH, on the rays as the user gave them (RaycastingScene's engine room).

The rays stay where they are (float32 or float64 views, any strides) and a t range given as a scalar stays a
stride-0 view: kernels/bvh/queries.py reads them band by band into cache-sized scratch, checks them, traces them and
writes the outputs in the same pass. Per query this allocates the outputs the user gets and nothing of the
rays' size besides (measured in benchmarks/README.md, issue 9).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels.bvh.bands import band_size, first_problem, n_bands
from ..kernels.bvh.queries import (
    closest_one_level,
    closest_two_level,
    count_crossings,
    hit_lists_two_level,
    occluded_one_level,
    occluded_two_level,
)
from ..kernels.threads import map_pieces, run_pieces
from .bvh import INVALID_ID, TwoLevelBVH

_NO_MAP = np.zeros(0, np.int32)
_IDENTITY = np.ascontiguousarray(np.eye(4)[:3])


@dataclass
class RayBatch:
    """Rays as given: origins, directions (N, 3) float32 or float64 of any strides; t_min, t_max (N,) float64
    (stride 0 for a scalar); the leading shape to give the outputs; the argument names for errors; the image
    width the packet kernels may use (0: none)."""

    origins: np.ndarray
    directions: np.ndarray
    t_min: np.ndarray
    t_max: np.ndarray
    lead: tuple
    names: tuple[str, str]
    width: int

    def __len__(self) -> int:
        return self.origins.shape[0]

    @property
    def out_dtype(self) -> type:
        """The float type of cast_rays' t, uvs and normals: float32 when the rays are (Open3D's and Embree's
        outputs), else float64."""
        both32 = self.origins.dtype == np.float32 and self.directions.dtype == np.float32
        return np.float32 if both32 else np.float64

    def band(self) -> int:
        return band_size(self.width)

    def collect(self, kernel, *args) -> list:
        """kernel(origins, directions, t_min, t_max, *args, first, k0, k1) over the bands as run does, returning
        each work item's result in ray order."""
        first = np.empty((n_bands(len(self), self.band()), 3), np.int64)
        return map_pieces(kernel, len(first), self.origins, self.directions, self.t_min, self.t_max, *args, first)

    def run(self, kernel, *args) -> tuple[int, int, int]:
        """kernel(origins, directions, t_min, t_max, *args, first, k0, k1) over the batch's bands on every
        thread. Rays with a NaN, an infinity or a zero direction are misses (bands.load_band); returns the first
        of them (first ray with NaN or infinity, 0 origin / 1 direction, first zero direction; -1: none)."""
        bands = n_bands(len(self), self.band())
        first = np.empty((bands, 3), np.int64)
        run_pieces(kernel, bands, self.origins, self.directions, self.t_min, self.t_max, *args, first)
        return first_problem(first)


def _one_level(tree: TwoLevelBVH) -> tuple | None:
    """(w2o, moved, tree arguments, id maps) for the one-level kernels, or None when a shape is shared (as
    TwoLevelBVH._one_level chooses): a lone instance in its own tree, several through the world tree."""
    p = tree.packed
    if len(tree.instances) == 1:
        w2o = np.ascontiguousarray(p.w2o[0])
        moved = not np.array_equal(w2o, np.eye(4)[:3])
        return w2o, moved, tree.one_level_tree().args, (_NO_MAP, _NO_MAP, _NO_MAP, _NO_MAP)
    if tree.world is None:
        return None
    w = tree.world
    return _IDENTITY, False, w.kernel.args, (w.tri_inst, w.tri_local, w.sph_inst, w.sph_prim)


def cast(tree: TwoLevelBVH, rays: RayBatch) -> dict:
    """RaycastingScene.cast_rays' arrays, flat: t_hit, geometry_ids, primitive_ids, primitive_uvs (N, 2),
    primitive_normals (N, 3); t, uvs and normals in rays.out_dtype (computed in float64, rounded once when float32).
    The outputs are left untouched here: the work item that computes a band writes it first (its pages fault in
    on that thread, once)."""
    n, ft = len(rays), rays.out_dtype
    t, inst, prim = np.empty(n, ft), np.empty(n, np.int32), np.empty(n, np.int32)
    uv, normals = np.empty((n, 2), ft), np.empty((n, 3), ft)
    if not tree.instances:
        t[:], inst[:], prim[:], uv[:], normals[:] = np.inf, INVALID_ID, INVALID_ID, 0.0, 0.0
    elif (one := _one_level(tree)) is not None:
        w2o, moved, args, maps = one
        rays.run(closest_one_level, w2o, moved, args, rays.width, rays.band(), *maps, *_normal_args(tree),
                 t, inst, prim, uv, normals)
    else:
        p = tree.packed
        rays.run(closest_two_level, p.args, rays.width, rays.band(), p.inst_shape, p.tri_off, p.normals, p.inst_sign,
                 t, inst, prim, uv, normals)
    return {"t_hit": t, "geometry_ids": inst, "primitive_ids": prim, "primitive_uvs": uv,
            "primitive_normals": normals}


def occluded(tree: TwoLevelBVH, rays: RayBatch) -> np.ndarray:
    """Whether each ray hits anything with t_min < t < t_max (RaycastingScene.test_occlusions), flat."""
    out = np.zeros(len(rays), np.bool_)
    if not tree.instances:
        return out
    if (one := _one_level(tree)) is not None:
        w2o, moved, args, _ = one
        rays.run(occluded_one_level, w2o, moved, args, rays.width, rays.band(), out)
    else:
        rays.run(occluded_two_level, tree.packed.args, rays.width, rays.band(), out)
    return out


def crossings(tree: TwoLevelBVH, rays: RayBatch, fill: bool):
    """Every hit of every ray (the two-level kernels): counts (N,) int64, and with fill the hits as flat arrays
    t, inst, kind, prim, u, v, ray by ray and sorted by t within a ray (a stable sort: equal t in the walk's
    order). Counting alone stores no hits; the lists are made in one pass (queries.hit_lists_two_level)."""
    n = len(rays)
    counts = np.zeros(n, np.int64)
    f, i32, i8 = np.zeros(0), np.zeros(0, np.int32), np.zeros(0, np.int8)
    names = ("t", "inst", "kind", "prim", "u", "v")
    if not tree.instances:
        return counts, (dict(zip(names, (f, i32, i8, i32, f, f), strict=True)) if fill else None)
    args = (tree.packed.args, rays.band())
    if not fill:
        rays.run(count_crossings, *args, rays.width, counts)
        return counts, None
    parts = rays.collect(hit_lists_two_level, *args, counts)
    out = {k: np.concatenate([p[1 + j] for p in parts]) for j, k in enumerate(names)}
    return counts, out


def _normal_args(tree: TwoLevelBVH) -> tuple:
    p = tree.packed
    return p.inst_shape, p.tri_off, p.normals, p.w2o, p.inst_sign, p.blas.sph_center

