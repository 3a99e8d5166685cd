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

import numpy as np

from . import pinhole
from . import query_normals as qn
from .accel import batches
from .accel.batches import RayBatch
from .accel.bvh import Shape, TwoLevelBVH
from .accel.distance import DEFAULT_BETA, DEFAULT_ORDER, SIGN_BETA, DistanceIndex
from .accel.widths import flat_image_width
from .kernels.bvh.trace import image_width
from .kernels.common import SPHERE
from .query_args import (
    INVALID_ID,
    array,
    check_device,
    finite_array,
    ids,
    is_scalar,
    mesh_arrays,
    numeric_array,
    results,
    t_range,
    tensor,
    threads,
)
from .query_args import (
    transform as transform_matrix,
)

__all__ = ["INVALID_ID", "RaycastingScene", "flat_image_width"]

# the pickled state's layout: 2 since the trees travel as named tuples (accel/bvh.TreeArrays, TopArrays) and meshes
# carry their corner normals
STATE_VERSION = 2


class RaycastingScene:
    """Triangle meshes and spheres, each placed by a 4x4 transform, queried by batches of rays.

    Geometry ids count up from 0 in the order geometries (and instances) are added. The BVHs are built on the
    first query after a change (each mesh's own tree when it is added); `build_seconds` totals both.
    """

    INVALID_ID = INVALID_ID  # Open3D's id of a miss, 2**32 - 1 in the uint32 id arrays

    @staticmethod
    def create_rays_pinhole(*args, **kwargs) -> np.ndarray:
        """Open3D's camera rays, float32 (height_px, width_px, 6), in either of its forms:
        create_rays_pinhole(intrinsic_matrix, extrinsic_matrix, width_px, height_px) or
        create_rays_pinhole(fov_deg, center, eye, up, width_px, height_px), fov_deg horizontal. The same rays as
        Open3D's (row 0 looks along -up, column 0 to the camera's left; directions with camera-space z = 1, so
        t_hit is depth along the optical axis): see pinhole.py."""
        return tensor(pinhole.create_rays_pinhole(*args, **kwargs))

    def __init__(self, nthreads: int = 0, device=None) -> None:
        """nthreads and device as Open3D takes them: durer builds on Numba's threads (nthreads > 0 caps them
        while building) and runs on the CPU (any other device is a ValueError)."""
        check_device(device)
        self._nthreads = int(nthreads)
        self._shapes: list[Shape] = []
        self._instances: list[tuple[int, np.ndarray]] = []  # (shape index, object-to-world 4x4)
        self._bvh: TwoLevelBVH | None = None  # built on the first query after a change
        self._distance: DistanceIndex | None = None  # point queries' index over self._bvh, built on first use
        self._corners: dict[int, np.ndarray] = {}  # shape index -> (F, 3, 3) unit vertex normals (query_normals)

    # ---------------------------------------------------------------------------------------------- adding
    def add_triangles(self, vertex_positions=None, triangle_indices=None, transform=None, *, mesh=None,
                      vertices=None, triangles=None, vertex_normals=None) -> int:
        """Add a mesh: vertex_positions (V, 3) float and triangle_indices (F, 3) int (Open3D's names; durer's
        vertices / triangles also work), or one mesh (an Open3D or trimesh triangle mesh) as the first argument
        or mesh=. vertex_normals (V, 3), or a given mesh's own, are what cast_rays(primitive_normals=
        "interpolated") mixes at the hits. Returns its geometry id."""
        if mesh is not None or (triangle_indices is None and triangles is None and vertex_positions is not None
                                and mesh_arrays(vertex_positions) is not None):
            given = mesh if mesh is not None else vertex_positions
            arrays = mesh_arrays(given)
            if arrays is None:
                raise ValueError(f"add_triangles needs a triangle mesh, got {type(mesh).__name__}")
            vertex_positions, triangle_indices = arrays
            vertex_normals = qn.vertex_normals(given) if vertex_normals is None else vertex_normals
        vertex_positions = vertices if vertex_positions is None else vertex_positions
        triangle_indices = triangles if triangle_indices is None else triangle_indices
        if vertex_positions is None or triangle_indices is None:
            raise ValueError("add_triangles needs vertex_positions and triangle_indices, or a mesh")
        v = finite_array("vertex_positions", vertex_positions, (3,))
        if v.ndim != 2:
            raise ValueError(f"vertex_positions must have shape (V, 3), got {v.shape}")
        f = array(triangle_indices)
        if f.ndim != 2 or f.shape[1] != 3:
            raise ValueError(f"triangle_indices must have shape (F, 3), got {f.shape}")
        if f.size and not np.issubdtype(f.dtype, np.integer):
            if not np.issubdtype(f.dtype, np.floating) or not np.all(np.mod(f, 1) == 0):
                raise ValueError(f"triangle_indices must hold integer vertex indices, got dtype {f.dtype}")
        f = f.astype(np.int64)
        if f.size and (f.min() < 0 or f.max() >= len(v)):
            bad = f[(f < 0) | (f >= len(v))][0]
            raise ValueError(f"triangle index {bad} out of range for {len(v)} vertices")
        corners = None if vertex_normals is None else qn.corner_normals(vertex_normals, f, len(v))
        self._shapes.append(Shape.indexed(v, f))
        if corners is not None:
            self._corners[len(self._shapes) - 1] = corners
        return self._add(len(self._shapes) - 1, transform)

    def add_mesh(self, mesh, transform=None) -> int:
        """Add a trimesh.Trimesh or an Open3D triangle mesh, or a mesh file (anything trimesh reads: PLY, OBJ,
        STL, glTF...)."""
        if isinstance(mesh, (str, os.PathLike)):
            import trimesh

            if not os.path.exists(mesh):
                raise FileNotFoundError(f"no such mesh file: {os.fspath(mesh)}")
            try:
                loaded = trimesh.load(os.fspath(mesh), process=False)  # a mesh file keeps its vertex normals
                mesh = loaded if isinstance(loaded, trimesh.Trimesh) else trimesh.load(
                    os.fspath(mesh), force="mesh", process=False)
            except (NotImplementedError, ValueError, KeyError, IndexError, OSError) as e:
                raise ValueError(f"cannot read mesh file {os.fspath(mesh)!r} (trimesh reads PLY, STL, OBJ, OFF, glTF, "
                                 f"...): {e}") from None
        arrays = mesh_arrays(mesh)
        if arrays is None:
            raise ValueError(f"add_mesh needs a triangle mesh or a path, got {type(mesh).__name__}")
        return self.add_triangles(*arrays, transform, vertex_normals=qn.vertex_normals(mesh))

    def add_sphere(self, center, radius: float, transform=None) -> int:
        """Add a sphere (an ellipsoid under a non-uniform transform). Returns its geometry id."""
        c = finite_array("center", center, (3,)).reshape(-1)
        if c.shape != (3,):
            raise ValueError(f"center must have shape (3,), got {np.shape(center)}")
        if isinstance(radius, bool) or np.ndim(radius) != 0 or not isinstance(np.asarray(radius).item(), (int, float)):
            raise ValueError(f"radius must be one positive number, got {radius!r}")
        r = float(radius)
        if not np.isfinite(r) or r <= 0.0:
            raise ValueError(f"radius must be positive and finite, got {radius}")
        self._shapes.append(Shape.sphere(c, r))
        return self._add(len(self._shapes) - 1, transform)

    def add_instance(self, geometry_id: int, transform) -> int:
        """Place geometry `geometry_id`'s shape again under `transform` (4x4, object to world, applied on top of
        nothing: the new instance's transform replaces the original's). The shape is stored once."""
        if not 0 <= int(geometry_id) < len(self._instances):
            raise ValueError(f"no geometry with id {geometry_id} (have {len(self._instances)})")
        return self._add(self._instances[int(geometry_id)][0], transform)

    def _add(self, shape: int, transform) -> int:
        m = np.eye(4) if transform is None else transform_matrix(transform)
        self._instances.append((shape, m))
        self._bvh = None
        return len(self._instances) - 1

    # ------------------------------------------------------------------------------------------------ build
    def _tree(self) -> TwoLevelBVH:
        """The BVH over the current geometries (accel/bvh.TwoLevelBVH), built on the first query after a change."""
        if self._bvh is None:
            with threads(self._nthreads):
                self._bvh = TwoLevelBVH(self._shapes, list(self._instances))
        return self._bvh

    @property
    def build_seconds(self) -> float:
        """Seconds spent building: each mesh's own tree when it was added, and the last build of the rest."""
        return self._bvh.build_seconds if self._bvh is not None else sum(s.build_seconds for s in self._shapes)

    # ------------------------------------------------------------------------------------------------ rays
    def _rays(self, rays, directions, t_min, t_max) -> RayBatch:
        """The rays as given (float32 or float64 views (N, 3), any strides: the kernels read them as they trace,
        accel/batches.py), the t range per ray (a scalar as a stride-0 view), the leading shape. rays (..., 6),
        or origins (..., 3) with directions (..., 3); at least one leading dimension (a single ray is (1, 6))."""
        if directions is None:
            r = array(rays)
            if r.ndim < 2 or r.shape[-1] != 6:
                raise ValueError(f"rays must have shape (..., 6) with at least 2 dimensions (one ray is (1, 6)) "
                                 f"when no directions are given, got {r.shape}")
            r = numeric_array("rays", r, (6,), keep_float32=True)
            lead = r.shape[:-1]
            r = r.reshape(-1, 6)
            o, d, names = r[:, :3], r[:, 3:], ("rays", "rays")
        else:
            o = numeric_array("origins", rays, (3,), keep_float32=True)
            d = numeric_array("directions", directions, (3,), keep_float32=True)
            if o.shape != d.shape:
                raise ValueError(f"origins {o.shape} and directions {d.shape} must have the same shape")
            if o.ndim < 2:
                raise ValueError(f"origins and directions must have shape (..., 3) with at least 2 dimensions, "
                                 f"got {o.shape}")
            lead = o.shape[:-1]
            o, d, names = o.reshape(-1, 3), d.reshape(-1, 3), ("origins", "directions")
        lo = self._interval("t_min", t_min, lead)
        hi = self._interval("t_max", t_max, lead)
        width = image_width(lead) if len(lead) != 1 else flat_image_width(o, d)
        return RayBatch(o, d, lo, hi, lead, names, width)

    @staticmethod
    def _interval(name: str, value, lead) -> np.ndarray:
        """t_min or t_max per ray, (N,) float64: a scalar as a stride-0 view (nothing allocated)."""
        a = array(value).astype(np.float64, copy=False)
        if np.isnan(a).any():
            raise ValueError(f"{name} contains NaN")
        if a.ndim == 0:
            return np.broadcast_to(a, (int(np.prod(lead, dtype=np.int64)),))
        try:
            a = np.broadcast_to(a, lead)
        except ValueError:
            raise ValueError(f"{name} of shape {a.shape} does not broadcast to the rays' shape {lead}") from None
        return np.ascontiguousarray(a).reshape(-1)

    def cast_rays(self, rays, nthreads: int = 0, *, directions=None, t_min=None, t_max=None, tnear=None,
                  tfar=None, primitive_normals: str = "face") -> dict:
        """Closest hit of each ray: Open3D's cast_rays(rays (..., 6), nthreads=0). durer also takes
        cast_rays(origins, directions) (two (..., 3) arrays), a t range t_min / t_max (or tnear / tfar: scalars
        or per ray) and float64 rays.

        Returns t_hit (inf on a miss), geometry_ids and primitive_ids (uint32, INVALID_ID on a miss),
        primitive_uvs (barycentric weights of vertex 1 and 2), primitive_normals (unit, world space, by the
        triangle's winding; spheres: outward; with primitive_normals="interpolated", on meshes added with vertex
        normals their barycentric mix at the hit, in world space, as Mitsuba shades), each shaped like the rays'
        leading dimensions. Directions need
        not be unit length; t is in units of the direction's length. A ray with a NaN, an infinity or a zero
        direction misses (as in Open3D and Embree). t, uvs and normals are float32 when the rays are, computed in
        float64 and rounded once (so they equal the float64 answers of the same rays, rounded), else float64.
        """
        rays, directions, nthreads = _durer_form(rays, directions, nthreads)
        mode = qn.check_mode(primitive_normals)
        batch = self._rays(rays, directions, *t_range(t_min, t_max, tnear, tfar))
        with threads(nthreads):
            out = batches.cast(self._tree(), batch)
        if mode == "interpolated" and self._corners:
            qn.interpolate(out, self._corners, self._instances)
        out["geometry_ids"], out["primitive_ids"] = ids(out["geometry_ids"]), ids(out["primitive_ids"])
        return results({key: a.reshape(*batch.lead, *a.shape[1:]) for key, a in out.items()})

    def test_occlusions(self, rays, tnear: float = 0.0, tfar: float = np.inf, nthreads: int = 0, *,
                        directions=None, t_min=None, t_max=None) -> np.ndarray:
        """True for each ray that hits anything with tnear < t < tfar (stops at the first hit found): Open3D's
        test_occlusions(rays, tnear=0.0, tfar=inf, nthreads=0); t_min / t_max are durer's names for the range, and
        test_occlusions(origins, directions) durer's form."""
        if not is_scalar(tnear):  # durer's form: test_occlusions(origins, directions, ...)
            rays, directions, tnear = rays, tnear, 0.0
        near = None if t_min is not None and is_scalar(tnear) and float(array(tnear)) == 0.0 else tnear
        far = None if t_max is not None and is_scalar(tfar) and float(array(tfar)) == np.inf else tfar
        lo, hi = t_range(t_min, t_max, near, far)  # t_min / t_max beside a tnear / tfar not their default: error
        batch = self._rays(rays, directions, lo, hi)
        with threads(nthreads):
            return tensor(batches.occluded(self._tree(), batch).reshape(batch.lead))

    def count_intersections(self, rays, nthreads: int = 0, *, directions=None, t_min=None, t_max=None, tnear=None,
                            tfar=None) -> np.ndarray:
        """Number of surface crossings along each ray (spheres count twice when passed through), int32: Open3D's
        count_intersections(rays, nthreads=0), with cast_rays' durer forms. For a point and any direction, an odd
        count means inside a closed mesh. Each crossing counts once, also through a shared edge or vertex: the
        triangle test gives an edge to exactly one of the two triangles sharing it (kernels/intersect.py)."""
        rays, directions, nthreads = _durer_form(rays, directions, nthreads)
        batch = self._rays(rays, directions, *t_range(t_min, t_max, tnear, tfar))
        with threads(nthreads):
            counts, _ = batches.crossings(self._tree(), batch, fill=False)
        return tensor(counts.astype(np.int32).reshape(batch.lead))

    def list_intersections(self, rays, nthreads: int = 0, *, directions=None, t_min=None, t_max=None, tnear=None,
                           tfar=None) -> dict:
        """Every crossing of every ray, as flat arrays sorted by ray then t (Open3D's list_intersections(rays,
        nthreads=0) and layout): ray_splits (N+1,) so ray i's hits are [ray_splits[i], ray_splits[i+1]); ray_ids,
        geometry_ids, primitive_ids (uint32), t_hit, primitive_uvs (M, 2) (float32 for float32 rays). Rays are
        numbered in C order of the leading shape; the durer forms are cast_rays'."""
        rays, directions, nthreads = _durer_form(rays, directions, nthreads)
        batch = self._rays(rays, directions, *t_range(t_min, t_max, tnear, tfar))
        n = len(batch)
        with threads(nthreads):
            counts, out = batches.crossings(self._tree(), batch, fill=True)
        index = np.uint32 if int(counts.sum()) < INVALID_ID and n < INVALID_ID else np.int64
        ray_ids = np.repeat(np.arange(n, dtype=index), counts)  # the hits come ray by ray, sorted by t
        prim = np.where(out["kind"] == SPHERE, 0, out["prim"]).astype(np.int32)
        splits = np.zeros(n + 1, index)
        np.cumsum(counts, out=splits[1:])
        ft = batch.out_dtype
        uv = np.empty((len(ray_ids), 2), ft)
        uv[:, 0], uv[:, 1] = out["u"], out["v"]
        return results({
            "ray_splits": splits,
            "ray_ids": ray_ids,
            "t_hit": out["t"].astype(ft),
            "geometry_ids": ids(out["inst"]),
            "primitive_ids": ids(prim),
            "primitive_uvs": uv,
        })

    @property
    def nbytes(self) -> int:
        """Bytes held by the BVHs (built now if needed): the shapes' trees, the tree over instances and, when no
        shape is shared, the world-space tree with its id maps."""
        return self._tree().nbytes

    def build(self) -> None:
        """Build now rather than on the first query (for timing)."""
        self._tree()

    # ------------------------------------------------------------------------------------------ point queries
    # Closest points, distances, winding numbers, signed distance and occupancy (issue 11). Distances are exact
    # (float64) for meshes and spheres under any affine transform: see accel/distance.py.
    def _points(self, query_points) -> tuple[np.ndarray, tuple, bool]:
        """Validate and flatten: (points (N, 3) float64 contiguous, leading shape, the outputs' float type: float32
        for float32 points, as Open3D, else float64)."""
        src = array(query_points)
        arr = np.ascontiguousarray(numeric_array("query_points", src, (3,))).reshape(-1, 3)
        if not np.isfinite(arr).all():  # one cheap pass; the row only when there is one to name
            bad = ~np.isfinite(arr).all(axis=1)
            raise ValueError(f"query_points contains NaN or infinity (point {int(np.argmax(bad))})")
        return arr, src.shape[:-1], (np.float32 if src.dtype == np.float32 else np.float64)

    def _distance_index(self) -> DistanceIndex:
        tree = self._tree()
        if self._distance is None or self._distance.source is not tree:
            self._distance = DistanceIndex(tree)
        return self._distance

    def compute_closest_points(self, query_points, nthreads: int = 0) -> dict:
        """Closest surface point of each query point (..., 3): points (..., 3), geometry_ids, primitive_ids (uint32;
        spheres 0), primitive_uvs (..., 2: barycentric weights of vertex 1 and 2, 0 for spheres) and
        primitive_normals (..., 3: unit, world space, by the triangle's winding; spheres outward); float32 for
        float32 points. Exact for triangles (Ericson's region test) and spheres, ellipsoids included. On an empty
        scene: NaN points and normals, INVALID_ID ids."""
        p, lead, ft = self._points(query_points)
        if not self._instances:
            n = len(p)
            inst, prim = np.full(n, -1, np.int32), np.full(n, -1, np.int32)
            q, uv, normals = np.full((n, 3), np.nan), np.zeros((n, 2)), np.full((n, 3), np.nan)
        else:
            with threads(nthreads):
                index = self._distance_index()
                _, inst, kind, prim, q, uv = index.closest_points(p)
                normals = index.normals(q, inst, kind, prim)
        return results({
            "points": q.astype(ft, copy=False).reshape(*lead, 3),
            "geometry_ids": ids(inst.astype(np.int32, copy=False)).reshape(lead),
            "primitive_ids": ids(prim.astype(np.int32, copy=False)).reshape(lead),
            "primitive_uvs": uv.astype(ft, copy=False).reshape(*lead, 2),
            "primitive_normals": normals.astype(ft, copy=False).reshape(*lead, 3),
        })

    def _distances(self, p: np.ndarray) -> np.ndarray:
        """Unsigned distance of points p (N, 3), float64 (inf on an empty scene)."""
        if not self._instances:
            return np.full(len(p), np.inf)
        return np.sqrt(self._distance_index().closest_points(p)[0])

    def compute_distance(self, query_points, nthreads: int = 0) -> np.ndarray:
        """Unsigned distance (...,) from each query point (..., 3) to the nearest surface (inf on an empty scene)."""
        p, lead, ft = self._points(query_points)
        with threads(nthreads):
            d = self._distances(p)
        return tensor(d.astype(ft, copy=False).reshape(lead))

    def compute_winding_number(self, query_points, beta: float = DEFAULT_BETA, order: int = DEFAULT_ORDER,
                               nthreads: int = 0, return_error_bound: bool = False):
        """Generalized winding number (...,) of each query point over all geometries: 1 inside a closed mesh
        wound counter-clockwise seen from outside (-1 if wound the other way, as the Stanford bunny is), 0
        outside, in between near holes (Jacobson et al. 2013); spheres count 1 inside. Evaluated through the BVH
        with Barill et al.'s far field (Taylor order 1 or 2) for BVH lanes more than `beta` radii away (beta > 1;
        inf sums every triangle exactly). With return_error_bound also a rigorous bound on each value's error
        from the approximation (kernels/points/winding.py). On the bunny, beta=2, order 2 is off by at most 0.05."""
        p, lead, _ = self._points(query_points)
        if not self._instances:
            w = err = np.zeros(len(p))
        else:
            with threads(nthreads):
                w, err = self._distance_index().winding_numbers(p, float(beta), int(order))
        return (tensor(w.reshape(lead)), tensor(err.reshape(lead))) if return_error_bound else tensor(w.reshape(lead))

    def _inside(self, p: np.ndarray, method: str, nsamples: int, beta: float) -> np.ndarray:
        """Inside test of points p (N, 3): |winding number| > 1/2 (either winding order), or the majority of
        nsamples rays' crossing parity. Nothing is inside an empty scene."""
        if method not in ("winding", "parity"):
            raise ValueError(f"method must be 'winding' or 'parity', got {method!r}")
        if isinstance(nsamples, bool) or int(nsamples) != nsamples or nsamples < 1:
            raise ValueError(f"nsamples must be at least 1, got {nsamples!r}")
        if not self._instances:
            return np.zeros(len(p), np.bool_)
        if method == "winding":
            return self._distance_index().inside(p, float(beta))
        if method != "parity":
            raise ValueError(f"method must be 'winding' or 'parity', got {method!r}")
        nsamples = int(nsamples)
        if nsamples < 1:
            raise ValueError(f"nsamples must be at least 1, got {nsamples}")
        dirs = _PARITY_DIRECTIONS[:nsamples] if nsamples <= len(_PARITY_DIRECTIONS) else _directions(nsamples)
        return self._distance_index().crossing_votes(p, dirs) * 2 > nsamples

    def compute_signed_distance(self, query_points, nthreads: int = 0, nsamples: int = 1,
                                method: str = "winding", beta: float = SIGN_BETA) -> np.ndarray:
        """Distance to the nearest surface, negative inside (Open3D's sign). Inside is decided by

        * method="winding" (default): |generalized winding number| > 1/2, evaluated with far field `beta`
          (compute_winding_number; 1.5 here: a sign needs less accuracy than a value). Right for closed meshes
          and degrades gracefully on meshes with holes or self-intersections, such as scans: use it for training
          data and anything that must not flip signs.
        * method="parity": Open3D's rule, the parity of one ray's crossings (a majority vote of `nsamples`
          rays; each leaves the point away from the scene's middle, tilted by a fixed direction per sample).
          Several times faster than the winding number; right for closed, non-self-intersecting meshes, but a
          ray through a hole flips the sign.
        """
        p, lead, ft = self._points(query_points)
        with threads(nthreads):
            d = self._distances(p)
            inside = self._inside(p, method, nsamples, beta)
        d = np.where(inside, -d, d)
        return tensor(d.astype(ft, copy=False).reshape(lead))

    def compute_occupancy(self, query_points, nthreads: int = 0, nsamples: int = 1,
                          method: str = "winding", beta: float = SIGN_BETA) -> np.ndarray:
        """1.0 inside, 0.0 outside for each query point (Open3D returns float too); method and nsamples as in
        compute_signed_distance."""
        p, lead, ft = self._points(query_points)
        with threads(nthreads):
            inside = self._inside(p, method, nsamples, beta)
        return tensor(inside.astype(ft).reshape(lead))

    # ---------------------------------------------------------------------------------- pickling and repr
    def __getstate__(self) -> dict:
        """Shapes, instances and the built trees (built now if needed), so an unpickled scene (another process,
        a Dask worker) queries at once without rebuilding."""
        if self._instances:
            self._tree()
        return {"version": STATE_VERSION, "shapes": self._shapes, "instances": self._instances, "bvh": self._bvh,
                "distance": self._distance, "nthreads": self._nthreads, "corners": self._corners}

    def __setstate__(self, state: dict) -> None:
        if state.get("version") != STATE_VERSION:
            raise ValueError(f"cannot unpickle a RaycastingScene of state version {state.get('version')}: this durer "
                             f"reads version {STATE_VERSION}; build the scene again with this durer")
        self._shapes, self._instances, self._bvh = state["shapes"], state["instances"], state["bvh"]
        self._distance = state["distance"]
        self._nthreads = state.get("nthreads", 0)
        self._corners = state.get("corners", {})

    def __repr__(self) -> str:
        meshes = sum(1 for s, _ in self._instances if len(self._shapes[s].normals))
        tris = sum(len(self._shapes[s].normals) for s, _ in self._instances)
        stored = sum(len(s.normals) for s in self._shapes)
        if self._bvh is None:
            memory = "not built yet"
        else:
            d = self._distance
            extra = d.nbytes + d.moments_nbytes + d.caps_nbytes if d is not None else 0
            memory = f"{(self._bvh.nbytes + extra) / 2**20:.1f} MiB"
        return (f"RaycastingScene({len(self._instances)} geometries: {meshes} meshes, "
                f"{len(self._instances) - meshes} spheres; {tris:,} triangles ({stored:,} stored); {memory})")


def _directions(n: int) -> np.ndarray:
    """n fixed unit directions for parity votes, random-looking so none lies along an axis or a mesh's edges."""
    d = np.random.default_rng(20131102).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


_PARITY_DIRECTIONS = _directions(16)


def _durer_form(rays, directions, nthreads):
    """durer's form f(origins, directions) of a ray query whose second parameter is Open3D's nthreads: an array
    there is the directions. Returns (rays or origins, directions, nthreads)."""
    if not is_scalar(nthreads):
        if directions is not None:
            raise ValueError("directions given twice")
        return rays, nthreads, 0
    return rays, directions, nthreads
