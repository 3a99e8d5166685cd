"""RaycastingScene: batch ray queries on triangle meshes and spheres, NumPy in and NumPy out.

Names follow Open3D's RaycastingScene where they overlap (cast_rays -> t_hit, geometry_ids, primitive_ids,
primitive_uvs, primitive_normals; test_occlusions; count_intersections; list_intersections), so its users feel
at home. Every added geometry is an *instance*: a shared bottom-level BVH plus a 4x4 transform, so
`add_instance(geometry_id, transform)` places a mesh again without storing it twice (a two-level BVH).

    scene = durer.RaycastingScene()
    bunny = scene.add_mesh("bun_zipper.ply")
    scene.add_instance(bunny, transform)           # the same mesh, moved
    hits = scene.cast_rays(origins, directions)    # dict of arrays, leading shape of the rays kept
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np

from .bvh import WideBVH, build_tree
from .kernels.bvh import (
    SPHERE,
    TRIANGLE,
    any_hit_bvh,
    build_wide_bvh,
    closest_hit_bvh,
    image_width,
    run_blocks,
    stack_size_for,
)
from .kernels.instances import (
    all_hits_instances,
    any_hit_instances,
    closest_hit_instances,
    hit_normals,
    rays_to_object,
)
from .kernels.rays import first_problem, n_chunks, split_checked_rays

INVALID_ID = -1


@dataclass
class _Shape:
    """One stored geometry (a mesh or a sphere) and its bottom-level tree, shared by its instances."""

    tree: WideBVH
    normals: np.ndarray      # (F, 3) unit object-space triangle normals (empty for a sphere)
    center: np.ndarray       # (1, 3) sphere centre (empty for a mesh)
    radius: np.ndarray       # (1,) sphere radius
    lo: np.ndarray           # (3,) object-space bounds
    hi: np.ndarray
    build_seconds: float


def _numeric_array(name: str, a, shape_tail: tuple[int, ...]) -> np.ndarray:
    """a as a float64 array (..., *shape_tail), not necessarily contiguous; ValueError naming `name` otherwise."""
    arr = np.asarray(a)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if arr.ndim < len(shape_tail) or tuple(arr.shape[arr.ndim - len(shape_tail):]) != shape_tail:
        want = "(..., " + ", ".join(map(str, shape_tail)) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    return arr.astype(np.float64, copy=False)


def _finite_array(name: str, a, shape_tail: tuple[int, ...]) -> np.ndarray:
    """_numeric_array, C-contiguous, and free of NaN and infinity."""
    arr = np.ascontiguousarray(_numeric_array(name, a, shape_tail))
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinity")
    return arr


def _transform(matrix) -> np.ndarray:
    m = np.asarray(matrix, dtype=np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"transform must be a 4x4 matrix, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError("transform contains NaN or infinity")
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"transform must be affine (last row 0 0 0 1), got {m[3]}")
    if abs(np.linalg.det(m[:3, :3])) < 1e-300:
        raise ValueError("transform is singular")
    return m


class RaycastingScene:
    """Triangle meshes and spheres, each placed by a 4x4 transform, queried by batches of rays.

    Geometry ids count up from 0 in the order geometries (and instances) are added. The BVHs are built on the
    first query after a change (each mesh's own tree when it is added); `build_seconds` totals both.
    """

    @staticmethod
    def create_rays_pinhole(fov_deg: float, center, eye, up, width_px: int, height_px: int) -> np.ndarray:
        """Rays (height_px, width_px, 6) of a pinhole camera at `eye` looking at `center`, one through each
        pixel's centre: Open3D's call, with durer's conventions (row 0 at the top, columns left to right,
        unit directions so t_hit is a distance; fov_deg spans the longer image side)."""
        from .cameras import PerspectiveCamera, pixel_centers

        eye = np.asarray(eye, dtype=np.float64)
        camera = PerspectiveCamera(center=eye, direction=np.asarray(center, dtype=np.float64) - eye, up=up,
                                   angle=fov_deg)
        width_px, height_px = int(width_px), int(height_px)
        if width_px < 1 or height_px < 1:
            raise ValueError(f"image size must be positive, got {width_px} x {height_px}")
        origins, directions, _ = camera.generate_rays(pixel_centers(width_px, height_px), width_px, height_px)
        return np.concatenate([origins, directions], axis=-1)

    def __init__(self) -> None:
        self._shapes: list[_Shape] = []
        self._instances: list[tuple[int, np.ndarray]] = []  # (shape index, object-to-world 4x4)
        self._packed: dict | None = None
        self.build_seconds = 0.0

    # ---------------------------------------------------------------------------------------------- adding
    def add_triangles(self, vertices, triangles, transform=None) -> int:
        """Add a mesh: vertices (V, 3) float, triangles (F, 3) int indices. Returns its geometry id."""
        v = _finite_array("vertices", vertices, (3,))
        if v.ndim != 2:
            raise ValueError(f"vertices must have shape (V, 3), got {v.shape}")
        f = np.asarray(triangles)
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"triangles must have shape (F, 3), got {f.shape}")
        if f.size and not np.issubdtype(f.dtype, np.integer):
            if not np.issubdtype(f.dtype, np.floating) or not np.all(np.mod(f, 1) == 0):
                raise ValueError(f"triangles must hold integer vertex indices, got dtype {f.dtype}")
        f = f.astype(np.int64)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            bad = f[(f < 0) | (f >= len(v))][0]
            raise ValueError(f"triangle index {bad} out of range for {len(v)} vertices")
        tris = v[f]
        normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        length = np.linalg.norm(normals, axis=1, keepdims=True)
        np.divide(normals, length, out=normals, where=length > 0)
        start = time.perf_counter()
        tree = build_tree(tris, np.zeros((0, 3)), np.zeros((0, 3)))
        seconds = time.perf_counter() - start
        lo = tris.min(axis=(0, 1)) if len(tris) else np.zeros(3)
        hi = tris.max(axis=(0, 1)) if len(tris) else np.zeros(3)
        self._shapes.append(_Shape(tree, normals, np.zeros((0, 3)), np.zeros(0), lo, hi, seconds))
        return self._add(len(self._shapes) - 1, transform)

    def add_mesh(self, mesh, transform=None) -> int:
        """Add a trimesh.Trimesh, or a mesh file (anything trimesh reads: PLY, OBJ, STL, glTF...)."""
        if isinstance(mesh, (str, os.PathLike)):
            import trimesh

            if not os.path.exists(mesh):
                raise FileNotFoundError(f"no such mesh file: {os.fspath(mesh)}")
            mesh = trimesh.load(os.fspath(mesh), force="mesh", process=False)
        if not hasattr(mesh, "vertices") or not hasattr(mesh, "faces"):
            raise ValueError(f"add_mesh needs a trimesh.Trimesh or a path, got {type(mesh).__name__}")
        return self.add_triangles(mesh.vertices, mesh.faces, transform)

    def add_sphere(self, center, radius: float, transform=None) -> int:
        """Add a sphere (an ellipsoid under a non-uniform transform). Returns its geometry id."""
        c = _finite_array("center", center, (3,)).reshape(-1)
        if c.shape != (3,):
            raise ValueError(f"center must have shape (3,), got {np.shape(center)}")
        r = float(radius)
        if not np.isfinite(r) or r <= 0.0:
            raise ValueError(f"radius must be positive and finite, got {radius}")
        tree = build_tree(np.zeros((0, 3, 3)), (c - r)[None], (c + r)[None])
        self._shapes.append(_Shape(tree, np.zeros((0, 3)), c[None], np.array([r]), c - r, c + r, 0.0))
        return self._add(len(self._shapes) - 1, transform)

    def add_instance(self, geometry_id: int, transform) -> int:
        """Place geometry `geometry_id`'s shape again under `transform` (4x4, object to world, applied on top of
        nothing: the new instance's transform replaces the original's). The shape is stored once."""
        if not 0 <= int(geometry_id) < len(self._instances):
            raise ValueError(f"no geometry with id {geometry_id} (have {len(self._instances)})")
        return self._add(self._instances[int(geometry_id)][0], transform)

    def _add(self, shape: int, transform) -> int:
        m = np.eye(4) if transform is None else _transform(transform)
        self._instances.append((shape, m))
        self._packed = None
        return len(self._instances) - 1

    # ------------------------------------------------------------------------------------------------ build
    def _pack(self) -> dict:
        """Concatenate the shapes' trees into shared arrays and build the top-level tree over instances."""
        if self._packed is not None:
            return self._packed
        start = time.perf_counter()
        node_off, slot_off, sph_off, tri_off = [], [], [], []
        n_nodes = n_slots = n_sph = n_tri = 0
        for s in self._shapes:
            node_off.append(n_nodes)
            slot_off.append(n_slots)
            sph_off.append(n_sph)
            tri_off.append(n_tri)
            n_nodes += len(s.tree.child)
            n_slots += len(s.tree.leaf_prim)
            n_sph += len(s.radius)
            n_tri += len(s.normals)
        bounds = np.concatenate([s.tree.bounds for s in self._shapes]) if self._shapes else np.zeros((0, 6, 4))
        child = []
        leaf_prim = []
        for s, no, so, ho in zip(self._shapes, node_off, slot_off, sph_off, strict=True):
            c = s.tree.child.astype(np.int64)
            inner = c > 0
            leaf = c < 0
            code = -c - 1
            c = np.where(inner, c + no, c)
            c = np.where(leaf, -(((code >> 3) + so) * 8 + (code & 7)) - 1, c)
            child.append(c)
            p = s.tree.leaf_prim
            leaf_prim.append(np.where(p >= 0, p, p - ho))
        if n_slots * 8 >= 2**31:
            raise ValueError("scene too large for 32-bit leaf codes")
        child_all = np.concatenate(child).astype(np.int32) if child else np.zeros((0, 4), np.int32)
        lp = np.concatenate(leaf_prim).astype(np.int32) if leaf_prim else np.zeros(0, np.int32)
        lt = np.concatenate([s.tree.leaf_tri for s in self._shapes]) if self._shapes else np.zeros((0, 9))
        sph_c = np.concatenate([s.center for s in self._shapes]) if self._shapes else np.zeros((0, 3))
        sph_r = np.concatenate([s.radius for s in self._shapes]) if self._shapes else np.zeros(0)
        sph_w2o = np.tile(np.eye(4)[:3], (len(sph_r), 1, 1))

        # instances: world boxes (the 8 transformed corners of each shape's box) and world-to-object matrices
        k = len(self._instances)
        inst_root = np.array([node_off[s] for s, _ in self._instances], dtype=np.int32)
        o2w = np.array([m for _, m in self._instances]).reshape(k, 4, 4)
        w2o = np.ascontiguousarray(np.linalg.inv(o2w)[:, :3, :]) if k else np.zeros((0, 3, 4))
        lo = np.zeros((k, 3))
        hi = np.zeros((k, 3))
        corners = np.array(np.meshgrid([0, 1], [0, 1], [0, 1], indexing="ij")).reshape(3, 8).T
        for i, (s, m) in enumerate(self._instances):
            shape = self._shapes[s]
            pts = np.where(corners, shape.hi, shape.lo) @ m[:3, :3].T + m[:3, 3]
            lo[i], hi[i] = pts.min(axis=0), pts.max(axis=0)
        top_bounds, top_child, top_leaf, top_depth = build_wide_bvh(lo, hi)
        depth = max([top_depth] + [s.tree.depth for s in self._shapes])
        normals = np.concatenate([s.normals for s in self._shapes]) if self._shapes else np.zeros((0, 3))
        self._packed = dict(
            top=(top_bounds.reshape(-1), top_child, top_leaf, inst_root, w2o),
            blas=(bounds.reshape(-1), child_all, lp, lt.reshape(-1), sph_c, sph_r, sph_w2o),
            stack=stack_size_for(depth), tri_off=np.array(tri_off + [n_tri], np.int64),
            sph_off=np.array(sph_off + [n_sph], np.int64), normals=normals,
            inst_shape=np.array([s for s, _ in self._instances], dtype=np.int64), o2w=o2w, w2o=w2o,
            inst_sign=np.sign(np.linalg.det(w2o[:, :, :3])) if k else np.zeros(0),
        )
        self._packed["flat"] = self._flat_tree(lo, hi, np.array(sph_off, np.int64)) if k > 1 else None
        self.build_seconds = time.perf_counter() - start + sum(s.build_seconds for s in self._shapes)
        return self._packed

    def _args(self):
        p = self._pack()
        return (*p["top"], *p["blas"], p["stack"])

    def _flat_tree(self, inst_lo, inst_hi, sph_off) -> dict | None:
        """When no shape is placed twice, one tree over every instance's primitives in world space, so the
        one-level packet kernels answer cast_rays and test_occlusions (the two-level kernels trace one ray at a
        time); the per-shape trees stay for count_intersections and list_intersections. Returns the tree and
        the maps from its triangle and sphere ids back to (instance, primitive), or None if a shape is shared."""
        shapes = [s for s, _ in self._instances]
        if len(set(shapes)) != len(shapes):
            return None
        tris, tri_inst, tri_local, sph_c, sph_r, sph_w2o, sph_inst, sph_prim, s_lo, s_hi = ([] for _ in range(10))
        for i, (shape_id, m) in enumerate(self._instances):
            shape = self._shapes[shape_id]
            if len(shape.normals):
                obj = np.empty((len(shape.normals), 9))
                lp = shape.tree.leaf_prim
                obj[lp[lp >= 0]] = shape.tree.leaf_tri[lp >= 0]  # back from leaf order to triangle order
                tris.append(obj.reshape(-1, 3, 3) @ m[:3, :3].T + m[:3, 3])
                tri_inst.append(np.full(len(obj), i, np.int32))
                tri_local.append(np.arange(len(obj), dtype=np.int32))
            else:  # a sphere: tested in its object space through the instance's world-to-object matrix
                sph_c.append(shape.center)
                sph_r.append(shape.radius)
                sph_w2o.append(self._packed["w2o"][i][None])
                sph_inst.append(np.int32(i))
                sph_prim.append(sph_off[shape_id])
                s_lo.append(inst_lo[i])
                s_hi.append(inst_hi[i])
        cat = np.concatenate
        tris = cat(tris) if tris else np.zeros((0, 3, 3))
        tree = build_tree(tris, np.array(s_lo).reshape(-1, 3), np.array(s_hi).reshape(-1, 3))
        return dict(
            args=(tree.bounds.reshape(-1), tree.child, tree.leaf_prim, tree.leaf_tri.reshape(-1),
                  cat(sph_c) if sph_c else np.zeros((0, 3)), cat(sph_r) if sph_r else np.zeros(0),
                  cat(sph_w2o) if sph_w2o else np.zeros((0, 3, 4)), np.zeros((0, 3)), np.zeros(0),
                  tree.stack_size),
            tri_inst=cat(tri_inst) if tri_inst else np.zeros(0, np.int32),
            tri_local=cat(tri_local) if tri_local else np.zeros(0, np.int32),
            sph_inst=np.array(sph_inst, np.int32), sph_prim=np.array(sph_prim, np.int32),
        )

    def _one_level(self, o, d):
        """Rays and tree arguments for the one-level kernels of kernels/bvh.py, which trace coherent rays in
        packets, or None when the scene needs the two-level kernels (a shape placed more than once).

        A single instance (one mesh or sphere: the common case) is traced in its own tree, with the rays moved
        into its object space by the two-level kernels' own arithmetic (t is unchanged); several instances of
        distinct shapes through the world-space tree of _flat_tree."""
        if len(self._instances) == 1:
            p = self._pack()
            w2o = p["w2o"][0]
            if not np.array_equal(w2o, np.eye(4)[:3]):
                oo, dd = np.empty_like(o), np.empty_like(d)
                rays_to_object(o, d, w2o, oo, dd)
                o, d = oo, dd
            no_planes = (np.zeros((0, 3)), np.zeros(0))
            return o, d, (*p["blas"], *no_planes, p["stack"])
        flat = self._pack()["flat"] if self._instances else None
        return None if flat is None else (o, d, flat["args"])

    def _flat_ids(self, kind, prim, inst) -> None:
        """Turn the flat tree's triangle and sphere ids (prim) into instances (inst) and their own primitive
        ids, in place; with a single instance there is nothing to map."""
        flat = self._packed["flat"] if len(self._instances) > 1 else None
        if flat is None:
            inst[:] = np.where(kind != 0, 0, INVALID_ID)
            return
        tri = kind == TRIANGLE
        sph = kind == SPHERE
        inst[:] = INVALID_ID
        inst[tri] = flat["tri_inst"][prim[tri]]
        inst[sph] = flat["sph_inst"][prim[sph]]
        prim[tri] = flat["tri_local"][prim[tri]]
        prim[sph] = flat["sph_prim"][prim[sph]]

    # ------------------------------------------------------------------------------------------------ rays
    def _rays(self, origins, directions, t_min, t_max):
        """Validate and flatten: (origins (N,3), directions (N,3), t_min (N,), t_max (N,), leading shape)."""
        if directions is None:
            rays = np.asarray(origins)
            if rays.ndim < 1 or rays.shape[-1] != 6:
                raise ValueError(f"rays must have shape (..., 6) when no directions are given, got {rays.shape}")
            rays = _numeric_array("rays", rays, (6,))
            lead = rays.shape[:-1]
            rays = rays.reshape(-1, 6)
            src_o, src_d, names = rays[:, :3], rays[:, 3:], ("rays", "rays")
        else:
            src_o = _numeric_array("origins", origins, (3,))
            src_d = _numeric_array("directions", directions, (3,))
            if src_o.shape != src_d.shape:
                raise ValueError(f"origins {src_o.shape} and directions {src_d.shape} must have the same shape")
            lead = src_o.shape[:-1]
            src_o, src_d, names = src_o.reshape(-1, 3), src_d.reshape(-1, 3), ("origins", "directions")
        n = src_o.shape[0]
        o, d = np.empty((n, 3)), np.empty((n, 3))
        first = np.empty((n_chunks(n), 3), np.int64)
        split_checked_rays(src_o, src_d, o, d, first)
        bad, part, zero = first_problem(first)
        if bad >= 0:
            raise ValueError(f"{names[part]} contains NaN or infinity (ray {bad})")
        if zero >= 0:
            raise ValueError(f"direction {zero} is zero")
        lo = self._interval("t_min", t_min, lead)
        hi = self._interval("t_max", t_max, lead)
        return o, d, lo, hi, lead

    @staticmethod
    def _interval(name: str, value, lead) -> np.ndarray:
        a = np.asarray(value, dtype=np.float64)
        if np.isnan(a).any():
            raise ValueError(f"{name} contains NaN")
        try:
            a = np.broadcast_to(a, lead)
        except ValueError:
            raise ValueError(f"{name} of shape {a.shape} does not broadcast to the rays' shape {lead}") from None
        return np.ascontiguousarray(a).reshape(-1)

    def cast_rays(self, origins, directions=None, t_min: float = 0.0, t_max: float = np.inf) -> dict:
        """Closest hit of each ray. origins and directions (..., 3), or one (..., 6) array of both.

        Returns t_hit (inf on a miss), geometry_ids and primitive_ids (-1 on a miss, uint32-safe int32),
        primitive_uvs (barycentric weights of vertex 1 and 2), primitive_normals (unit, world space, by the
        triangle's winding; spheres: outward), each shaped like the rays' leading dimensions. Directions need
        not be unit length; t is in units of the direction's length.
        """
        o, d, lo, hi, lead = self._rays(origins, directions, t_min, t_max)
        n = len(o)
        t = np.empty(n)
        inst = np.empty(n, np.int32)
        kind = np.empty(n, np.int8)
        prim = np.empty(n, np.int32)
        u = np.empty(n)
        v = np.empty(n)
        one = self._one_level(o, d) if n else None
        if one is not None:
            run_blocks(closest_hit_bvh, n, one[0], one[1], lo, hi, *one[2], image_width(lead), t, kind, prim, u, v)
            self._flat_ids(kind, prim, inst)
        elif self._instances and n:
            closest_hit_instances(o, d, lo, hi, *self._args(), t, inst, kind, prim, u, v)
        else:
            t[:], inst[:], kind[:], prim[:], u[:], v[:] = np.inf, -1, 0, -1, 0.0, 0.0
        normals = self._normals(o, d, t, inst, kind, prim)
        prim = np.where(kind == SPHERE, 0, prim).astype(np.int32)
        return {
            "t_hit": t.reshape(lead),
            "geometry_ids": inst.reshape(lead),
            "primitive_ids": prim.reshape(lead),
            "primitive_uvs": np.stack([u, v], axis=-1).reshape(*lead, 2),
            "primitive_normals": normals.reshape(*lead, 3),
        }

    def _normals(self, o, d, t, inst, kind, prim) -> np.ndarray:
        out = np.zeros((len(t), 3))
        if self._instances:
            p = self._pack()
            hit_normals(o, d, t, inst, kind, prim, p["inst_shape"], p["tri_off"], p["normals"], p["w2o"],
                        p["inst_sign"], p["blas"][4], out)
        return out

    def test_occlusions(self, origins, directions=None, t_min: float = 0.0, t_max: float = np.inf) -> np.ndarray:
        """True for each ray that hits anything with t_min < t < t_max (stops at the first hit found)."""
        o, d, lo, hi, lead = self._rays(origins, directions, t_min, t_max)
        out = np.zeros(len(o), dtype=np.bool_)
        one = self._one_level(o, d) if len(o) else None
        if one is not None:
            run_blocks(any_hit_bvh, len(o), one[0], one[1], lo, hi, *one[2], image_width(lead), out)
        elif self._instances and len(o):
            any_hit_instances(o, d, lo, hi, *self._args(), out)
        return out.reshape(lead)

    def _all_hits(self, o, d, lo, hi, fill: bool):
        n = len(o)
        counts = np.zeros(n, np.int64)
        empty_f, empty_i, empty_k = np.zeros(0), np.zeros(0, np.int32), np.zeros(0, np.int8)
        args = self._args()
        all_hits_instances(o, d, lo, hi, *args, np.zeros(n, np.int64), empty_f, empty_i, empty_k, empty_i,
                           empty_f, empty_f, counts)
        if not fill:
            return counts, None
        offsets = np.zeros(n, np.int64)
        np.cumsum(counts[:-1], out=offsets[1:])
        total = int(counts.sum())
        out = dict(t=np.empty(total), inst=np.empty(total, np.int32), kind=np.empty(total, np.int8),
                   prim=np.empty(total, np.int32), u=np.empty(total), v=np.empty(total))
        if total:
            all_hits_instances(o, d, lo, hi, *args, offsets, out["t"], out["inst"], out["kind"], out["prim"],
                               out["u"], out["v"], counts)
        return counts, out

    def count_intersections(self, origins, directions=None, t_min: float = 0.0,
                            t_max: float = np.inf) -> np.ndarray:
        """Number of surface crossings along each ray (spheres count twice when passed through), int32.

        For a point and any direction, an odd count means inside a closed mesh. A ray through a shared edge or
        vertex hits every triangle there (the test is watertight, so none is skipped), which adds crossings:
        use a random direction.
        """
        o, d, lo, hi, lead = self._rays(origins, directions, t_min, t_max)
        if not self._instances or not len(o):
            return np.zeros(lead, np.int32)
        counts, _ = self._all_hits(o, d, lo, hi, fill=False)
        return counts.astype(np.int32).reshape(lead)

    def list_intersections(self, origins, directions=None, t_min: float = 0.0, t_max: float = np.inf) -> dict:
        """Every crossing of every ray, as flat arrays sorted by ray then t (Open3D's layout):

        ray_splits (N+1,) so ray i's hits are [ray_splits[i], ray_splits[i+1]); ray_ids, t_hit, geometry_ids,
        primitive_ids, primitive_uvs (M, 2). Rays are numbered in C order of the leading shape.
        """
        o, d, lo, hi, lead = self._rays(origins, directions, t_min, t_max)
        n = len(o)
        if self._instances and n:
            counts, out = self._all_hits(o, d, lo, hi, fill=True)
        else:
            counts = np.zeros(n, np.int64)
            out = dict(t=np.zeros(0), inst=np.zeros(0, np.int32), kind=np.zeros(0, np.int8),
                       prim=np.zeros(0, np.int32), u=np.zeros(0), v=np.zeros(0))
        ray_ids = np.repeat(np.arange(n, dtype=np.int64), counts)
        order = np.lexsort((out["t"], ray_ids))
        prim = np.where(out["kind"] == SPHERE, 0, out["prim"]).astype(np.int32)
        splits = np.zeros(n + 1, np.int64)
        np.cumsum(counts, out=splits[1:])
        return {
            "ray_splits": splits,
            "ray_ids": ray_ids[order],
            "t_hit": out["t"][order],
            "geometry_ids": out["inst"][order],
            "primitive_ids": prim[order],
            "primitive_uvs": np.stack([out["u"], out["v"]], axis=-1)[order],
        }

    @property
    def nbytes(self) -> int:
        """Bytes held by the BVHs (after the first query or an explicit build()): the per-shape trees, the
        tree over instances and, when no shape is shared, the world-space tree with its id maps."""
        p = self._pack()
        flat = p["flat"]
        extra = 0 if flat is None else sum(a.nbytes for a in (*flat["args"][:-1], flat["tri_inst"], flat["tri_local"]))
        return sum(a.nbytes for a in (*p["top"], *p["blas"])) + extra

    def build(self) -> None:
        """Build now rather than on the first query (for timing)."""
        self._pack()
