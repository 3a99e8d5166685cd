"""The bounding volume hierarchy every render and every ray query goes through.

* `WideBVH` / `build_tree`: one 4-wide SAH tree over triangles and sphere boxes (layout in kernels/bvh/layout.py).
* `TwoLevelBVH`: shapes (meshes, spheres), each with its own tree, placed by instances (shape, 4x4 matrix); a mesh
  placed twice is stored once. It picks the fastest traversal the scene allows: one instance in its own tree, or
  several instances of distinct shapes in one world-space tree (both through the packet kernels), or the two-level
  kernels when a shape is shared. `RaycastingScene` (query.py) holds one; so does `BVHAccelerator` for the meshes a
  scene places more than once.
* `BVHAccelerator`: the renderer's accelerator (the Accelerator protocol of accel/hits.py): the flat tree of the
  compiled scene, its planes beside it, and a TwoLevelBVH for its instanced meshes.

Results match BruteForce: both call the same per-primitive tests (the watertight triangle test of
kernels/intersect.py), so t agrees to the bit and only exact ties may name a different primitive.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..kernels.bvh.build import build_wide_bvh, build_wide_bvh_rows
from ..kernels.bvh.instance_packets import any_hit_instances, closest_hit_instances
from ..kernels.bvh.instances import rays_to_object
from ..kernels.bvh.items import indexed_items, indexed_leaves, item_boxes, leaf_items, mesh_normals_bounds
from ..kernels.bvh.layout import MAX_LEAF, leaf_codes, leaf_slots, stack_size_for
from ..kernels.bvh.trace import any_hit_bvh, closest_hit_bvh
from ..kernels.common import MISS, SPHERE, TRIANGLE
from ..kernels.threads import run_blocks
from .compile import CompiledScene
from .hits import Hits, ray_arrays
from .pages import tree_on_huge_pages
from .widths import checked_width

INVALID_ID = -1


@dataclass
class WideBVH:
    """One 4-wide tree and its leaf-ordered items (see kernels/bvh/layout.py for the layout)."""

    bounds: np.ndarray     # (N, 6, 4) float32
    child: np.ndarray      # (N, 4) int32
    leaf_prim: np.ndarray  # (M,) int32: triangle id, or -(sphere + 1)
    leaf_tri: np.ndarray   # (M, 9) triangle vertices in leaf order: float32 if large and exact (narrow_leaves)
    depth: int

    def __post_init__(self) -> None:
        # the layout step after every build: a large tree's walk reads from 2 MiB pages (accel/pages.py)
        self.bounds, self.child, self.leaf_prim, self.leaf_tri = tree_on_huge_pages(
            (self.bounds, self.child, self.leaf_prim, self.leaf_tri))

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
    return WideBVH(bounds, child, leaf_prim, narrow_leaves(leaf_tri), depth)


def build_indexed_tree(vertices: np.ndarray, faces: np.ndarray, max_leaf: int = MAX_LEAF):
    """The tree of the mesh vertices[faces] ((V, 3) float, (F, 3) int), read through its indices (no (F, 3, 3)
    copy), and its unit normals (F, 3) and bounds lo, hi: the same tree, normals and bounds as build_tree and
    mesh_normals_bounds give for vertices[faces]."""
    normals, lo, hi, ib, root_box, root_cb = indexed_items(vertices, faces)
    bounds, child, order, depth = build_wide_bvh_rows(ib, root_box, root_cb, max_leaf)
    leaf_prim, leaf_tri = indexed_leaves(vertices, faces, order, len(order) >= NARROW_LEAVES_FROM)
    return WideBVH(bounds, child, leaf_prim, leaf_tri, depth), normals, lo, hi


# Trees with fewer leaf slots keep float64 leaves: theirs fit in a core's L2 cache (16,384 x 72 bytes = 1.2 MB), so
# float32 would save no memory traffic, only cost every kernel a second compiled version (and the test suite
# a minute and a half).
NARROW_LEAVES_FROM = 16_384


def narrow_leaves(leaf_tri: np.ndarray) -> np.ndarray:
    """leaf_tri as float32 when it is large (NARROW_LEAVES_FROM slots) and every coordinate is a float32 value
    (meshes read from PLY, STL, glTF or given as float32 arrays), else unchanged: half the bytes a traversal
    reads per triangle, and the same results to the bit, since the kernels widen each coordinate to float64 as
    they load it (kernels/bvh/layout.leaf_vertices)."""
    if len(leaf_tri) < NARROW_LEAVES_FROM:
        return leaf_tri
    narrow = leaf_tri.astype(np.float32)
    return narrow if np.array_equal(narrow, leaf_tri) else leaf_tri


# ------------------------------------------------------------------------------------------------ two-level BVH
@dataclass
class Shape:
    """One stored geometry (a mesh or a sphere) and its own tree, shared by the instances that place it."""

    tree: WideBVH
    normals: np.ndarray      # (F, 3) unit object-space triangle normals (empty for a sphere)
    center: np.ndarray       # (1, 3) sphere centre (empty for a mesh)
    radius: np.ndarray       # (1,) sphere radius
    lo: np.ndarray           # (3,) object-space bounds
    hi: np.ndarray
    build_seconds: float

    @classmethod
    def mesh(cls, triangles: np.ndarray) -> Shape:
        """A mesh from its triangles (F, 3, 3), object space."""
        tris = np.ascontiguousarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
        normals, lo, hi = mesh_normals_bounds(tris)
        start = time.perf_counter()
        tree = build_tree(tris, np.zeros((0, 3)), np.zeros((0, 3)))
        seconds = time.perf_counter() - start
        if not len(tris):
            lo, hi = np.zeros(3), np.zeros(3)
        return cls(tree, normals, np.zeros((0, 3)), np.zeros(0), lo, hi, seconds)

    @classmethod
    def indexed(cls, vertices: np.ndarray, faces: np.ndarray) -> Shape:
        """A mesh from its vertices (V, 3) and triangle indices (F, 3) (valid ones), object space: the same shape
        as mesh(vertices[faces]), built without that copy."""
        v = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
        f = np.ascontiguousarray(faces, dtype=np.int64).reshape(-1, 3)
        start = time.perf_counter()
        tree, normals, lo, hi = build_indexed_tree(v, f)
        seconds = time.perf_counter() - start
        if not len(f):
            lo, hi = np.zeros(3), np.zeros(3)
        return cls(tree, normals, np.zeros((0, 3)), np.zeros(0), lo, hi, seconds)

    @classmethod
    def sphere(cls, center: np.ndarray, radius: float) -> Shape:
        c = np.asarray(center, dtype=np.float64).reshape(3)
        tree = build_tree(np.zeros((0, 3, 3)), (c - radius)[None], (c + radius)[None])
        return cls(tree, np.zeros((0, 3)), c[None], np.array([float(radius)]), c - radius, c + radius, 0.0)

    def triangles(self) -> np.ndarray:
        """The mesh's triangles (F, 9) in their original order (the tree stores them in leaf order)."""
        out = np.empty((len(self.normals), 9))
        lp = self.tree.leaf_prim
        out[lp[lp >= 0]] = self.tree.leaf_tri[lp >= 0]
        return out


class TreeArrays(NamedTuple):
    """One or more trees in shared arrays as every BVH kernel takes them, in this order (kernels/bvh/layout.py).
    The kernels take the fields as positional arguments (`*arrays`): a tuple argument costs them speed and a
    compiled variant of its own (benchmarks/README.md, kernel_args.py)."""

    bounds: np.ndarray      # (N * 24,) float32, flat
    child: np.ndarray       # (N, 4) int32 child codes
    leaf_prim: np.ndarray   # (M,) int32: triangle id, or -(sphere + 1)
    leaf_tri: np.ndarray    # (M * 9,) float32 or float64, flat
    sph_center: np.ndarray  # (S, 3)
    sph_radius: np.ndarray  # (S,)
    sph_w2o: np.ndarray     # (S, 3, 4) world-to-object of each sphere


class TopArrays(NamedTuple):
    """The tree over instances (same layout; its leaf slots name instances), in the two-level kernels' order."""

    bounds: np.ndarray      # (N * 24,) float32, flat
    child: np.ndarray       # (N, 4) int32
    leaf: np.ndarray        # (K,) instance of each leaf slot
    inst_root: np.ndarray   # (K,) root node of each instance's tree in the bottom level's arrays
    w2o: np.ndarray         # (K, 3, 4) world-to-object of each instance


class KernelTree(NamedTuple):
    """The one-level kernels' tree arguments (kernels/bvh/trace.py order): a tree, the planes beside it, the stack
    size its walks need."""

    tree: TreeArrays
    pl_normal: np.ndarray   # (P, 3)
    pl_offset: np.ndarray   # (P,)
    stack_size: int

    @property
    def args(self) -> tuple:
        """The positional arguments, flat: the kernels' order."""
        return (*self.tree, self.pl_normal, self.pl_offset, self.stack_size)

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in (*self.tree, self.pl_normal, self.pl_offset))


_NO_PLANES = (np.zeros((0, 3)), np.zeros(0))


@dataclass
class TwoLevelArrays:
    """The shapes' trees concatenated into shared arrays (the bottom level) and the tree over instances (the top
    level), in the argument order of kernels/bvh/instances.py."""

    top: TopArrays
    blas: TreeArrays
    stack: int
    tri_off: np.ndarray     # (shapes+1,) first triangle of each shape in `normals`
    normals: np.ndarray     # (F, 3) object-space triangle normals of every shape
    inst_shape: np.ndarray  # (K,) shape of each instance
    w2o: np.ndarray         # (K, 3, 4)
    inst_sign: np.ndarray   # (K,) sign of each instance's determinant (mirrors flip triangle normals)

    @property
    def args(self) -> tuple:
        return (*self.top, *self.blas, self.stack)


@dataclass
class WorldTree:
    """Every instance's primitives in one world-space tree (when no shape is shared), with the maps from its
    triangle and sphere ids back to (instance, primitive)."""

    kernel: KernelTree      # the world tree (no planes)
    tri_inst: np.ndarray
    tri_local: np.ndarray
    sph_inst: np.ndarray
    sph_prim: np.ndarray


class TwoLevelBVH:
    """Shapes placed by instances: `instances[k] = (shape index, 4x4 object-to-world)`. Built once; immutable."""

    def __init__(self, shapes: list[Shape], instances: list[tuple[int, np.ndarray]]):
        start = time.perf_counter()
        self.shapes = shapes
        self.instances = instances
        self.packed = self._pack()
        self.world = self._world_tree() if len(instances) > 1 else None
        self.build_seconds = time.perf_counter() - start + sum(s.build_seconds for s in shapes)

    def _pack(self) -> TwoLevelArrays:
        shapes, instances = self.shapes, self.instances
        node_off, slot_off, sph_off, tri_off = [], [], [], []
        n_nodes = n_slots = n_sph = n_tri = 0
        for s in shapes:
            node_off.append(n_nodes)
            slot_off.append(n_slots)
            sph_off.append(n_sph)
            tri_off.append(n_tri)
            n_nodes += len(s.tree.child)
            n_slots += len(s.tree.leaf_prim)
            n_sph += len(s.radius)
            n_tri += len(s.normals)
        if n_slots * 8 >= 2**31:
            raise ValueError("scene too large for 32-bit leaf codes")
        child, leaf_prim = [], []
        for s, no, so, ho in zip(shapes, node_off, slot_off, sph_off, strict=True):
            if len(shapes) == 1:  # nothing to offset: the shape's own arrays, not copies (80 MB at 1.1M triangles)
                child.append(s.tree.child)
                leaf_prim.append(s.tree.leaf_prim)
                break
            c = s.tree.child.astype(np.int64)
            first, count = leaf_slots(np.where(c < 0, c, -1))
            c = np.where(c > 0, c + no, c)
            c = np.where(c < 0, leaf_codes(first + so, count), c)
            child.append(c)
            p = s.tree.leaf_prim
            leaf_prim.append(np.where(p >= 0, p, p - ho))
        def cat(arrays):
            return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)

        bounds = cat([s.tree.bounds for s in shapes]) if shapes else np.zeros((0, 6, 4), np.float32)
        child_all = cat(child).astype(np.int32, copy=False) if child else np.zeros((0, 4), np.int32)
        lp = cat(leaf_prim).astype(np.int32, copy=False) if leaf_prim else np.zeros(0, np.int32)
        lt = cat([s.tree.leaf_tri for s in shapes]) if shapes else np.zeros((0, 9))
        sph_c = cat([s.center for s in shapes]) if shapes else np.zeros((0, 3))
        sph_r = cat([s.radius for s in shapes]) if shapes else np.zeros(0)
        sph_w2o = np.tile(np.eye(4)[:3], (len(sph_r), 1, 1))

        # instances: world boxes (the 8 transformed corners of each shape's box) and world-to-object matrices
        k = len(instances)
        inst_root = np.array([node_off[s] for s, _ in instances], dtype=np.int32)
        o2w = np.array([m for _, m in instances]).reshape(k, 4, 4)
        w2o = np.ascontiguousarray(np.linalg.inv(o2w)[:, :3, :]) if k else np.zeros((0, 3, 4))
        self._inst_lo, self._inst_hi = np.zeros((k, 3)), np.zeros((k, 3))
        corners = np.array(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij")).reshape(3, 8).T
        for i, (s, m) in enumerate(instances):
            pts = np.where(corners, shapes[s].hi, shapes[s].lo) @ m[:3, :3].T + m[:3, 3]
            self._inst_lo[i], self._inst_hi[i] = pts.min(axis=0), pts.max(axis=0)
        # one instance a leaf: each gets its own box in its parent node, so a packet (or ray) skips the instances
        # it misses instead of moving into every one of a shared leaf (bunny x4, 1M camera rays: 0.28 -> 0.16 CPU s)
        top_bounds, top_child, top_leaf, top_depth = build_wide_bvh(self._inst_lo, self._inst_hi, 1)
        depth = max([top_depth] + [s.tree.depth for s in shapes])
        self._sph_off = np.array(sph_off, np.int64)
        return TwoLevelArrays(
            top=TopArrays(top_bounds.reshape(-1), top_child, top_leaf, inst_root, w2o),
            blas=TreeArrays(bounds.reshape(-1), child_all, lp, lt.reshape(-1), sph_c, sph_r, sph_w2o),
            stack=stack_size_for(depth), tri_off=np.array(tri_off + [n_tri], np.int64),
            normals=cat([s.normals for s in shapes]) if shapes else np.zeros((0, 3)),
            inst_shape=np.array([s for s, _ in instances], dtype=np.int64), w2o=w2o,
            inst_sign=np.sign(np.linalg.det(w2o[:, :, :3])) if k else np.zeros(0),
        )

    def _world_tree(self) -> WorldTree | None:
        """One tree over every instance's primitives in world space, so the one-level packet kernels answer
        closest_hit and any_hit (the two-level kernels trace one ray at a time); None if a shape is shared."""
        shapes = [s for s, _ in self.instances]
        if len(set(shapes)) != len(shapes):
            return None
        tris, tri_inst, tri_local, sph_c, sph_r, sph_w2o, sph_inst, sph_prim, s_lo, s_hi = ([] for _ in range(10))
        for i, (shape_id, m) in enumerate(self.instances):
            shape = self.shapes[shape_id]
            if len(shape.normals):
                obj = shape.triangles()
                tris.append(obj.reshape(-1, 3, 3) @ m[:3, :3].T + m[:3, 3])
                tri_inst.append(np.full(len(obj), i, np.int32))
                tri_local.append(np.arange(len(obj), dtype=np.int32))
            else:  # a sphere: tested in its object space through the instance's world-to-object matrix
                sph_c.append(shape.center)
                sph_r.append(shape.radius)
                sph_w2o.append(self.packed.w2o[i][None])
                sph_inst.append(np.int32(i))
                sph_prim.append(self._sph_off[shape_id])
                s_lo.append(self._inst_lo[i])
                s_hi.append(self._inst_hi[i])
        cat = np.concatenate
        tree = build_tree(cat(tris) if tris else np.zeros((0, 3, 3)), np.array(s_lo).reshape(-1, 3),
                          np.array(s_hi).reshape(-1, 3))
        return WorldTree(
            kernel=KernelTree(TreeArrays(tree.bounds.reshape(-1), tree.child, tree.leaf_prim,
                                         tree.leaf_tri.reshape(-1), cat(sph_c) if sph_c else np.zeros((0, 3)),
                                         cat(sph_r) if sph_r else np.zeros(0),
                                         cat(sph_w2o) if sph_w2o else np.zeros((0, 3, 4))),
                              *_NO_PLANES, tree.stack_size),
            tri_inst=cat(tri_inst) if tri_inst else np.zeros(0, np.int32),
            tri_local=cat(tri_local) if tri_local else np.zeros(0, np.int32),
            sph_inst=np.array(sph_inst, np.int32), sph_prim=np.array(sph_prim, np.int32),
        )

    @property
    def nbytes(self) -> int:
        """Bytes of the packed trees, the tree over instances and, when no shape is shared, the world tree."""
        p, w = self.packed, self.world
        extra = 0 if w is None else w.kernel.nbytes + w.tri_inst.nbytes + w.tri_local.nbytes
        return sum(a.nbytes for a in (*p.top, *p.blas)) + extra

    def one_level_tree(self) -> KernelTree | None:
        """The tree the one-level kernels trace, or None when a shape is shared: a lone instance's own tree (rays
        moved into its object space), or the world tree of several instances."""
        if len(self.instances) == 1:
            return KernelTree(self.packed.blas, *_NO_PLANES, self.packed.stack)
        return None if self.world is None else self.world.kernel

    def _one_level(self, o, d):
        """Rays and tree for the one-level packet kernels, or None when a shape is shared.

        A single instance (one mesh or sphere: the common case) is traced in its own tree, with the rays moved
        into its object space by the two-level kernels' own arithmetic (t is unchanged); several instances of
        distinct shapes through the world tree."""
        if len(self.instances) == 1:
            w2o = self.packed.w2o[0]
            if not np.array_equal(w2o, np.eye(4)[:3]):
                oo, dd = np.empty_like(o), np.empty_like(d)
                rays_to_object(o, d, w2o, oo, dd)
                o, d = oo, dd
        tree = self.one_level_tree()
        return None if tree is None else (o, d, tree)

    def _instance_ids(self, kind, prim, inst) -> None:
        """Turn the one-level kernels' triangle and sphere ids (prim) into instances (inst) and their own
        primitive ids, in place."""
        if self.world is None:  # one instance: nothing to map
            inst[:] = np.where(kind != MISS, 0, INVALID_ID)
            return
        w = self.world
        tri = kind == TRIANGLE
        sph = kind == SPHERE
        inst[:] = INVALID_ID
        inst[tri] = w.tri_inst[prim[tri]]
        inst[sph] = w.sph_inst[prim[sph]]
        prim[tri] = w.tri_local[prim[tri]]
        prim[sph] = w.sph_prim[prim[sph]]

    def closest_hit(self, o, d, t_min, t_max, width: int = 0):
        """Closest hit of rays o, d (N,3) float64 contiguous with per-ray t_min, t_max: (t, instance, kind,
        primitive, u, v) arrays; width > 0 says the rays are an image that wide (4 x 4 tile packets)."""
        n = len(o)
        t, inst, kind = np.empty(n), np.empty(n, np.int32), np.empty(n, np.int8)
        prim, u, v = np.empty(n, np.int32), np.empty(n), np.empty(n)
        one = self._one_level(o, d) if n and self.instances else None
        if one is not None:
            oo, dd, tree = one
            run_blocks(closest_hit_bvh, n, oo, dd, t_min, t_max, *tree.args, width, t, kind, prim, u, v)
            self._instance_ids(kind, prim, inst)
        elif self.instances and n:
            run_blocks(closest_hit_instances, n, o, d, t_min, t_max, *self.packed.args, width, t, inst, kind,
                       prim, u, v)
        else:
            t[:], inst[:], kind[:], prim[:], u[:], v[:] = np.inf, INVALID_ID, MISS, INVALID_ID, 0.0, 0.0
        return t, inst, kind, prim, u, v

    def any_hit(self, o, d, t_min, t_max, width: int = 0) -> np.ndarray:
        """Whether each ray hits anything with t_min < t < t_max (stops at the first hit found)."""
        out = np.zeros(len(o), dtype=np.bool_)
        one = self._one_level(o, d) if len(o) and self.instances else None
        if one is not None:
            oo, dd, tree = one
            run_blocks(any_hit_bvh, len(o), oo, dd, t_min, t_max, *tree.args, width, out)
        elif self.instances and len(o):
            run_blocks(any_hit_instances, len(o), o, d, t_min, t_max, *self.packed.args, width, out)
        return out


# ---------------------------------------------------------------------------------------- the renderer's accelerator
class BVHAccelerator:
    """The renderer's default accelerator: closest_hit / any_hit with the same Hits semantics as BruteForce.

    t_min / t_max are scalars or per-ray arrays; t_min = -inf (orthographic cameras) works.
    `build_seconds` and `nbytes` report the build's cost.
    """

    name = "bvh"

    def __init__(self, cs: CompiledScene, max_leaf: int = MAX_LEAF):
        self.cs = cs
        start = time.perf_counter()
        self.tree = build_tree(cs.triangles, cs.sphere_lo, cs.sphere_hi, max_leaf)
        self.instances = None
        if len(cs.instance_mesh):
            # meshes placed more than once: each stored once, traced two-level; the flat tree holds the rest
            shapes = [Shape.mesh(mesh) for mesh in cs.mesh_triangles]
            placed = [(int(m), np.asarray(matrix, dtype=np.float64))
                      for m, matrix in zip(cs.instance_mesh, cs.instance_matrix, strict=True)]
            self.instances = TwoLevelBVH(shapes, placed)
            self._inst_offset = cs.instance_offset[:-1]
            self._inst_mirror = np.linalg.det(cs.instance_matrix[:, :3, :3]) < 0
        self.build_seconds = time.perf_counter() - start

    @property
    def nbytes(self) -> int:
        """Bytes held by the acceleration structure (nodes and leaf-ordered triangles; with instances, the
        two-level structure, whose meshes are stored once)."""
        return self.tree.nbytes + (self.instances.nbytes if self.instances is not None else 0)

    def kernel_tree(self) -> tuple | None:
        """The one-level tree's kernel arrays as a plain tuple (the Accelerator protocol: fused kernels take it
        whole, and a named tuple would be a type of its own to them); None with instances (two-level)."""
        return self._args().args if self.instances is None else None

    def _args(self) -> KernelTree:
        cs, tr = self.cs, self.tree
        return KernelTree(TreeArrays(tr.bounds.reshape(-1), tr.child, tr.leaf_prim, tr.leaf_tri.reshape(-1),
                                     cs.sphere_center, cs.sphere_radius, cs.sphere_world_to_object),
                          cs.plane_normal, cs.plane_offset, tr.stack_size)

    def closest_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0) -> Hits:
        """width > 0 says the rays are an image that wide, row by row (both sides multiples of 4): coherent rays
        are then traced in 4 x 4 tiles, which is faster."""
        n = len(origins)
        h = Hits.empty(n)
        o, d, lo, hi = ray_arrays(origins, directions, t_min, t_max)
        width = checked_width(width, o, d)
        run_blocks(closest_hit_bvh, n, o, d, lo, hi, *self._args().args, width, h.t, h.kind, h.prim, h.u, h.v)
        if self.instances is not None and n:
            self._closest_instances(o, d, lo, np.minimum(hi, h.t), h, width)
        return h

    def _closest_instances(self, o, d, lo, hi, h: Hits, width: int) -> None:
        """Merge the instances' closest hits into h (a tie keeps the flat hit); prim becomes the virtual id.
        width: the rays' image width (4 x 4 tile packets through the instances too), or 0."""
        t, inst, kind, prim, u, v = self.instances.closest_hit(o, d, lo, hi, width)
        m = kind != MISS
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
        o, d, lo, hi = ray_arrays(origins, directions, t_min, t_max)
        run_blocks(any_hit_bvh, n, o, d, lo, hi, *self._args().args, checked_width(width, o, d), out)
        if self.instances is not None and n and not out.all():
            rest = np.flatnonzero(~out)
            out[rest] = self.instances.any_hit(np.ascontiguousarray(o[rest]), np.ascontiguousarray(d[rest]),
                                               lo[rest], hi[rest])
        return out
