"""BVHAccelerator: the BruteForce interface (closest_hit, any_hit -> Hits) answered through a 4-wide SAH BVH.

Triangles and spheres (ellipsoids under a transform) share one tree; planes are unbounded, so the kernels test
them beside it. Results match BruteForce: both call the same per-primitive tests (the watertight triangle test
of kernels/intersect.py), so t agrees to the bit and only exact ties may name a different primitive.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .compile import CompiledScene, sphere_bounds
from .hits import Hits, _per_ray
from .kernels.bvh import (
    MAX_LEAF,
    TILE,
    any_hit_bvh,
    build_wide_bvh,
    closest_hit_bvh,
    item_boxes,
    leaf_items,
    run_blocks,
    stack_size_for,
)
from .kernels.instances import any_hit_instances, closest_hit_instances


@dataclass
class WideBVH:
    """One 4-wide tree and its leaf-ordered items (see kernels/bvh.py for the layout)."""

    bounds: np.ndarray     # (N, 6, 4) float32
    child: np.ndarray      # (N, 4) int32
    leaf_prim: np.ndarray  # (M,) int32: triangle id, or -(sphere + 1)
    leaf_tri: np.ndarray   # (M, 9) float64 triangle vertices in leaf order
    depth: int

    @property
    def nbytes(self) -> int:
        return self.bounds.nbytes + self.child.nbytes + self.leaf_prim.nbytes + self.leaf_tri.nbytes

    @property
    def stack_size(self) -> int:
        return stack_size_for(self.depth)


def build_tree(triangles: np.ndarray, sphere_lo: np.ndarray, sphere_hi: np.ndarray,
               max_leaf: int = MAX_LEAF) -> WideBVH:
    """Build the tree over triangles (F, 3, 3) and sphere boxes (S, 3); item ids: triangles 0..F-1, then spheres."""
    f = len(triangles)
    tris = np.ascontiguousarray(triangles, dtype=np.float64).reshape(f, 9)
    lo, hi = item_boxes(tris, np.ascontiguousarray(sphere_lo, dtype=np.float64).reshape(-1, 3),
                        np.ascontiguousarray(sphere_hi, dtype=np.float64).reshape(-1, 3))
    bounds, child, order, depth = build_wide_bvh(lo, hi, max_leaf)
    leaf_prim, leaf_tri = leaf_items(tris, order)
    return WideBVH(bounds, child, leaf_prim, leaf_tri, depth)


def _checked_width(width: int, n: int) -> int:
    """width if n rays form whole rows of 4 x 4 tiles that wide, else 0 (rays in their given order)."""
    width = int(width)
    return width if width > 0 and width % TILE == 0 and n % (TILE * width) == 0 else 0


class BVHAccelerator:
    """Drop-in replacement for hits.BruteForce: closest_hit / any_hit with the same Hits semantics.

    t_min / t_max are scalars or per-ray arrays; t_min = -inf (orthographic cameras) works.
    `build_seconds` and `nbytes` report the build's cost.
    """

    name = "bvh"

    def __init__(self, cs: CompiledScene, max_leaf: int = MAX_LEAF):
        self.cs = cs
        start = time.perf_counter()
        slo, shi = sphere_bounds(cs)
        self.tree = build_tree(cs.triangles, slo, shi, max_leaf)
        self.instances = None
        if len(cs.instance_mesh):
            # meshes placed more than once: one bottom-level tree per stored mesh, a top-level tree over the
            # instances (query.py's two-level structure); the flat tree holds everything else
            from .query import RaycastingScene

            rs = RaycastingScene()
            for mesh in cs.mesh_triangles:  # shape i of rs is stored mesh i
                rs.add_triangles(mesh.reshape(-1, 3), np.arange(3 * len(mesh)).reshape(-1, 3))
            # instance k of the scene is instance k of rs
            rs._instances = [(int(m), np.asarray(matrix, dtype=np.float64))
                             for m, matrix in zip(cs.instance_mesh, cs.instance_matrix, strict=True)]
            rs._packed = None
            self.instances = rs._args()  # keep only the packed arrays (the per-shape trees are copies)
            self._inst_offset = cs.instance_offset[:-1]
            self._inst_mirror = np.linalg.det(cs.instance_matrix[:, :3, :3]) < 0
        self.build_seconds = time.perf_counter() - start

    @property
    def nbytes(self) -> int:
        """Bytes held by the acceleration structure (nodes and leaf-ordered triangles; with instances, the
        two-level structure, whose meshes are stored once)."""
        extra = sum(a.nbytes for a in self.instances if isinstance(a, np.ndarray)) if self.instances else 0
        return self.tree.nbytes + extra

    def _args(self):
        cs, tr = self.cs, self.tree
        return (tr.bounds.reshape(-1), tr.child, tr.leaf_prim, tr.leaf_tri.reshape(-1), cs.sphere_center,
                cs.sphere_radius, cs.sphere_world_to_object, cs.plane_normal, cs.plane_offset, tr.stack_size)

    def closest_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> Hits:
        """width > 0 says the rays are an image that wide, row by row (both sides multiples of 4; see
        kernels.bvh.image_width): coherent rays are then traced in 4 x 4 tiles, which is faster."""
        n = len(origins)
        h = Hits.empty(n)
        run_blocks(closest_hit_bvh, n, np.ascontiguousarray(origins, dtype=np.float64),
                   np.ascontiguousarray(directions, dtype=np.float64),
                   _per_ray(t_min, n), _per_ray(t_max, n), *self._args(), _checked_width(width, n),
                   h.t, h.kind, h.prim, h.u, h.v)
        if self.instances is not None and n:
            self._closest_instances(origins, directions, t_min, t_max, h)
        return h

    def _closest_instances(self, origins, directions, t_min, t_max, h: Hits) -> None:
        """Merge the instances' closest hits into h (a tie keeps the flat hit); prim becomes the virtual id."""
        n = len(h.t)
        t, inst, kind = np.empty(n), np.empty(n, np.int32), np.empty(n, np.int8)
        prim, u, v = np.empty(n, np.int32), np.empty(n), np.empty(n)
        closest_hit_instances(np.ascontiguousarray(origins, dtype=np.float64),
                              np.ascontiguousarray(directions, dtype=np.float64), _per_ray(t_min, n),
                              np.minimum(_per_ray(t_max, n), h.t), *self.instances, t, inst, kind, prim, u, v)
        m = kind != 0
        if m.any():
            k = inst[m]
            mirror = self._inst_mirror[k]
            h.t[m] = t[m]
            h.kind[m] = kind[m]
            h.prim[m] = self._inst_offset[k] + prim[m]
            # a mirrored instance's world triangle is (v0, v2, v1): its barycentrics swap
            h.u[m] = np.where(mirror, v[m], u[m])
            h.v[m] = np.where(mirror, u[m], v[m])

    def any_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> np.ndarray:
        n = len(origins)
        out = np.empty(n, dtype=np.bool_)
        run_blocks(any_hit_bvh, n, np.ascontiguousarray(origins, dtype=np.float64),
                   np.ascontiguousarray(directions, dtype=np.float64),
                   _per_ray(t_min, n), _per_ray(t_max, n), *self._args(), _checked_width(width, n), out)
        if self.instances is not None and n and not out.all():
            rest = np.flatnonzero(~out)
            more = np.empty(len(rest), dtype=np.bool_)
            any_hit_instances(np.ascontiguousarray(np.asarray(origins, dtype=np.float64)[rest]),
                              np.ascontiguousarray(np.asarray(directions, dtype=np.float64)[rest]),
                              _per_ray(t_min, n)[rest], _per_ray(t_max, n)[rest], *self.instances, more)
            out[rest] = more
        return out
