"""The course's uniform grid (assignments 5-6): `-grid nx ny nz`, `-visualize_grid` and the grid's `-stats`.

GridAccelerator is an accelerator like BruteForce (closest_hit / any_hit returning identical results); the
kernels are in kernels/course/grid.py. The grid covers the course's scene bounding box, and primitives go into cells
as the course's solution inserts them, which is what -visualize_grid shows:

* a triangle into every cell its (world-space) bounding box overlaps - the handout's "special case for
  transformed triangles": the box of the transformed vertices, not the transformed box;
* a sphere with no Transform above it into every cell whose centre lies within the radius plus half the
  cell's diagonal of the sphere's centre (the handout's rasterisation by cell centres, made conservative);
* a sphere under a Transform (even an identity one) into every cell of its bounding box, the handout's
  fallback "Object3D::insertIntoGrid", the box being the transformed corners of the sphere's own box;
* planes into no cell: they are tested beside the grid, as the course does for infinite primitives.
"""

from __future__ import annotations

import numpy as np

from ..kernels.common import SPHERE, TRIANGLE
from ..kernels.course.grid import any_hit_grid, build_cells, closest_hit_grid, first_occupied_cell, walk_cells
from ..options import check_grid
from .compile import CompiledScene
from .hits import Hits, QueriedOnly, per_ray, ray_arrays
from .stats import RayStats


def _sphere_boxes(cs: CompiledScene, as_box: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World boxes of the spheres: centre +- r when untransformed, else the 8 transformed corners of the
    object-space box (the course's transformed bounding box; exact for scales and translations)."""
    s = len(cs.sphere_radius)
    lo = cs.sphere_center - cs.sphere_radius[:, None]
    hi = cs.sphere_center + cs.sphere_radius[:, None]
    if not s or not as_box.any():
        return lo, hi
    m = np.zeros((s, 4, 4))
    m[:, :3, :] = cs.sphere_world_to_object
    m[:, 3, 3] = 1.0
    o2w = np.linalg.inv(m)
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64)
    pts = lo[:, None, :] + corners[None] * (hi - lo)[:, None, :]                   # (S, 8, 3) object space
    world = np.einsum("sij,skj->ski", o2w[:, :3, :3], pts) + o2w[:, None, :3, 3]
    wlo, whi = world.min(axis=1), world.max(axis=1)
    code = (cs.sphere_radius <= 0)[:, None]  # disks and cylinders: their exact boxes (compile.sphere_bounds)
    wlo, whi = np.where(code, cs.sphere_lo, wlo), np.where(code, cs.sphere_hi, whi)
    return np.where(as_box[:, None], wlo, lo), np.where(as_box[:, None], whi, hi)


class GridAccelerator(QueriedOnly):
    """A uniform grid of nx x ny x nz cells over the scene's bounded primitives, walked with 3D-DDA.

    `sphere_as_box` (S,) says which spheres go in by their box (default: those under a Transform in the scene
    tree, CompiledScene.sphere_transformed, as the course does); the spheres whose world-to-object matrix is not
    the identity always do.
    `exact_triangles` keeps a triangle only in the cells its plane really crosses (separating-axis test)
    instead of all cells of its box: fewer tests, but not what the course's images show. Pass a RayStats as
    `stats` to count rays, tests and cells.
    """

    name = "grid"

    def __init__(self, cs: CompiledScene, dims: tuple[int, int, int], *, sphere_as_box: np.ndarray | None = None,
                 exact_triangles: bool = False, stats: RayStats | None = None):
        dims = tuple(int(n) for n in dims)
        check_grid(dims)  # count and size, before anything is allocated
        self.cs = cs
        cs = cs.flat  # the grid stores world-space triangles: instances flattened (same triangle ids)
        self.dims = np.array(dims, dtype=np.int64)
        identity = np.zeros((3, 4))
        identity[:, :3] = np.eye(3)
        moved = ~np.all(cs.sphere_world_to_object == identity, axis=(1, 2))  # rasterising needs world = object
        if sphere_as_box is None:
            sphere_as_box = cs.sphere_transformed
        self.sphere_as_box = (np.asarray(sphere_as_box, dtype=bool).reshape(len(cs.sphere_radius)) | moved
                              | (cs.sphere_radius <= 0))  # disks and cylinders are never rasterised as spheres
        sph_lo, sph_hi = _sphere_boxes(cs, self.sphere_as_box)
        self.lo, self.hi = self._bounds(cs, sph_lo, sph_hi)
        self.size = (self.hi - self.lo) / self.dims
        pad = 1e-9 * float(np.max(self.hi - self.lo))
        self.box = np.array([self.lo - pad, self.hi + pad])  # rays are clipped to this (see kernels._clip)
        self.start, self.items = build_cells(cs.triangles, exact_triangles, cs.sphere_center, cs.sphere_radius,
                                             sph_lo, sph_hi, self.sphere_as_box, self.lo, self.size, self.dims)
        self.stats = stats
        if stats is not None:
            stats.bounds = (self.lo.copy(), self.hi.copy())
            stats.grid = dims

    @staticmethod
    def _bounds(cs: CompiledScene, sph_lo: np.ndarray, sph_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The scene box of the bounded primitives; a flat axis is widened a little so cells keep a size."""
        los, his = [], []
        if len(cs.triangles):
            los.append(cs.triangles.min(axis=(0, 1)))
            his.append(cs.triangles.max(axis=(0, 1)))
        if len(sph_lo):
            los.append(sph_lo.min(axis=0))
            his.append(sph_hi.max(axis=0))
        if not los:
            return np.zeros(3), np.ones(3)
        lo, hi = np.min(los, axis=0), np.max(his, axis=0)
        pad = 1e-6 * max(float(np.max(hi - lo)), 1.0)
        flat = (hi - lo) <= pad
        return np.where(flat, lo - pad, lo), np.where(flat, hi + pad, hi)

    @property
    def cell_counts(self) -> np.ndarray:
        """(nz, ny, nx) number of primitives in each cell."""
        nx, ny, nz = (int(n) for n in self.dims)
        return np.diff(self.start).reshape(nz, ny, nx)

    def cell_items(self, i: int, j: int, k: int) -> list[tuple[int, int]]:
        """(kind, index) of the primitives in cell (i, j, k): kind TRIANGLE or SPHERE (kernels/common.py)."""
        nx, ny = int(self.dims[0]), int(self.dims[1])
        c = (k * ny + j) * nx + i
        items = self.items[self.start[c]:self.start[c + 1]]
        return [(TRIANGLE, int(x)) if x >= 0 else (SPHERE, int(-x - 1)) for x in items]

    def walk(self, origin, direction, t_min: float = 0.0, t_max: float = np.inf):
        """The 3D-DDA walk of one ray, as the kernels take it: cells (K,3) as (i, j, k) in order, the t where
        the ray enters each, and the axis of the face it enters through (-1: the ray starts in that cell)."""
        most = int(self.dims.sum()) + 3
        cells = np.empty((most, 3), np.int64)
        t = np.empty(most)
        axis = np.empty(most, np.int64)
        n = walk_cells(np.asarray(origin, np.float64), np.asarray(direction, np.float64), float(t_min),
                       float(t_max), self.lo, self.box, self.size, self.dims, cells, t, axis)
        return cells[:n], t[:n], axis[:n]

    def _geometry(self):
        cs = self.cs
        return (self.lo, self.box, self.size, self.dims, self.start, self.items, cs.flat.triangles, cs.sphere_center,
                cs.sphere_radius, cs.sphere_world_to_object, cs.plane_normal, cs.plane_offset)

    def _counters(self, n: int) -> tuple[bool, np.ndarray, np.ndarray]:
        if self.stats is None:
            return False, np.zeros(0, np.int64), np.zeros(0, np.int64)
        return True, np.zeros(n, np.int64), np.zeros(n, np.int64)

    def closest_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> Hits:
        n = len(origins)
        h = Hits.empty(n)
        count, tests, cells = self._counters(n)
        closest_hit_grid(*ray_arrays(origins, directions, t_min, t_max), *self._geometry(),
                         h.t, h.kind, h.prim, h.u, h.v, count, tests, cells)
        if count:
            self.stats.add(n, False, int(tests.sum()), int(cells.sum()))
        return h

    def any_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> np.ndarray:
        n = len(origins)
        out = np.empty(n, dtype=np.bool_)
        count, tests, cells = self._counters(n)
        any_hit_grid(*ray_arrays(origins, directions, t_min, t_max), *self._geometry(), out, count, tests, cells)
        if count:
            self.stats.add(n, True, int(tests.sum()), int(cells.sum()))
        return out

    def first_occupied(self, origins, directions, t_min=0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per ray: entry t of the first cell holding a primitive (inf if none), the axis of the face it
        enters through (-1 when the ray starts inside that cell), and the cell's primitive count. Clipped to
        the exact grid box, so the entry t of a boundary cell is that of the box's face."""
        n = len(origins)
        t = np.empty(n)
        axis = np.empty(n, np.int64)
        count = np.empty(n, np.int64)
        cells = np.zeros(n if self.stats is not None else 0, np.int64)
        exact_box = np.array([self.lo, self.hi])
        first_occupied_cell(np.ascontiguousarray(origins, dtype=np.float64),
                            np.ascontiguousarray(directions, dtype=np.float64), per_ray(t_min, n),
                            self.lo, exact_box, self.size, self.dims, self.start, t, axis, count, cells)
        if self.stats is not None:
            self.stats.add(n, False, 0, int(cells.sum()))
        return t, axis, count
