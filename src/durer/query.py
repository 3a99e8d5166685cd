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

import contextlib
import functools
import os

import numba
import numpy as np

from .accel import batches
from .accel.batches import RayBatch
from .accel.bvh import INVALID_ID, Shape, TwoLevelBVH, flat_image_width
from .accel.distance import DEFAULT_BETA, DEFAULT_ORDER, SIGN_BETA, DistanceIndex
from .kernels.bvh.trace import image_width
from .kernels.common import SPHERE

__all__ = ["INVALID_ID", "RaycastingScene", "flat_image_width"]


def _numeric_array(name: str, a, shape_tail: tuple[int, ...], keep_float32: bool = False) -> np.ndarray:
    """a as a float64 array (..., *shape_tail), not necessarily contiguous (float32 kept as it is with
    keep_float32: the query kernels read it as it is); ValueError naming `name` otherwise."""
    arr = np.asarray(a)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if arr.ndim < len(shape_tail) or tuple(arr.shape[arr.ndim - len(shape_tail):]) != shape_tail:
        want = "(..., " + ", ".join(map(str, shape_tail)) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if keep_float32 and arr.dtype == np.float32:
        return arr
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
        from .scene.cameras import PerspectiveCamera, pixel_centers

        eye = np.asarray(eye, dtype=np.float64)
        camera = PerspectiveCamera(center=eye, direction=np.asarray(center, dtype=np.float64) - eye, up=up,
                                   angle=fov_deg)
        width_px, height_px = int(width_px), int(height_px)
        if width_px < 1 or height_px < 1:
            raise ValueError(f"image size must be positive, got {width_px} x {height_px}")
        origins, directions, _ = camera.generate_rays(pixel_centers(width_px, height_px), width_px, height_px)
        return np.concatenate([origins, directions], axis=-1)

    def __init__(self) -> None:
        self._shapes: list[Shape] = []
        self._instances: list[tuple[int, np.ndarray]] = []  # (shape index, object-to-world 4x4)
        self._bvh: TwoLevelBVH | None = None  # built on the first query after a change
        self._distance: DistanceIndex | None = None  # point queries' index over self._bvh, built on first use

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
        self._shapes.append(Shape.mesh(v[f]))
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
        self._shapes.append(Shape.sphere(c, r))
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
        self._bvh = None
        return len(self._instances) - 1

    # ------------------------------------------------------------------------------------------------ build
    def _tree(self) -> TwoLevelBVH:
        """The BVH over the current geometries (accel/bvh.TwoLevelBVH), built on the first query after a change."""
        if self._bvh is None:
            self._bvh = TwoLevelBVH(self._shapes, list(self._instances))
        return self._bvh

    @property
    def build_seconds(self) -> float:
        """Seconds spent building: each mesh's own tree when it was added, and the last build of the rest."""
        return self._bvh.build_seconds if self._bvh is not None else sum(s.build_seconds for s in self._shapes)

    # ------------------------------------------------------------------------------------------------ rays
    def _rays(self, origins, directions, t_min, t_max) -> RayBatch:
        """The rays as given (float32 or float64 views (N, 3), any strides: the kernels read and check them as
        they trace, accel/batches.py), the t range per ray (a scalar as a stride-0 view), the leading shape."""
        if directions is None:
            rays = np.asarray(origins)
            if rays.ndim < 1 or rays.shape[-1] != 6:
                raise ValueError(f"rays must have shape (..., 6) when no directions are given, got {rays.shape}")
            rays = _numeric_array("rays", rays, (6,), keep_float32=True)
            lead = rays.shape[:-1]
            rays = rays.reshape(-1, 6)
            o, d, names = rays[:, :3], rays[:, 3:], ("rays", "rays")
        else:
            o = _numeric_array("origins", origins, (3,), keep_float32=True)
            d = _numeric_array("directions", directions, (3,), keep_float32=True)
            if o.shape != d.shape:
                raise ValueError(f"origins {o.shape} and directions {d.shape} must have the same shape")
            lead = o.shape[:-1]
            o, d, names = o.reshape(-1, 3), d.reshape(-1, 3), ("origins", "directions")
        lo = self._interval("t_min", t_min, lead)
        hi = self._interval("t_max", t_max, lead)
        width = image_width(lead) if len(lead) != 1 else flat_image_width(o, d)
        return RayBatch(o, d, lo, hi, lead, names, width)

    @staticmethod
    def _interval(name: str, value, lead) -> np.ndarray:
        """t_min or t_max per ray, (N,) float64: a scalar as a stride-0 view (nothing allocated)."""
        a = np.asarray(value, dtype=np.float64)
        if np.isnan(a).any():
            raise ValueError(f"{name} contains NaN")
        if a.ndim == 0:
            return np.broadcast_to(a, (int(np.prod(lead, dtype=np.int64)),))
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
        not be unit length; t is in units of the direction's length. t, uvs and normals are float32 when the rays
        are (origins and directions both, or the (..., 6) array), as Open3D and Embree return them, else float64;
        they are computed in float64 either way and rounded once, so float32 rays get the float64 answers of the
        same values rounded to float32 (half the output memory: 32 bytes a ray instead of 56).
        """
        rays = self._rays(origins, directions, t_min, t_max)
        out = batches.cast(self._tree(), rays)
        return {key: a.reshape(*rays.lead, *a.shape[1:]) for key, a in out.items()}

    def test_occlusions(self, origins, directions=None, t_min: float = 0.0, t_max: float = np.inf) -> np.ndarray:
        """True for each ray that hits anything with t_min < t < t_max (stops at the first hit found)."""
        rays = self._rays(origins, directions, t_min, t_max)
        return batches.occluded(self._tree(), rays).reshape(rays.lead)

    def count_intersections(self, origins, directions=None, t_min: float = 0.0,
                            t_max: float = np.inf) -> np.ndarray:
        """Number of surface crossings along each ray (spheres count twice when passed through), int32.

        For a point and any direction, an odd count means inside a closed mesh. A ray through a shared edge or
        vertex hits every triangle there (the test is watertight, so none is skipped), which adds crossings:
        use a random direction.
        """
        rays = self._rays(origins, directions, t_min, t_max)
        counts, _ = batches.crossings(self._tree(), rays, fill=False)
        return counts.astype(np.int32).reshape(rays.lead)

    def list_intersections(self, origins, directions=None, t_min: float = 0.0, t_max: float = np.inf) -> dict:
        """Every crossing of every ray, as flat arrays sorted by ray then t (Open3D's layout):

        ray_splits (N+1,) so ray i's hits are [ray_splits[i], ray_splits[i+1]); ray_ids, t_hit, geometry_ids,
        primitive_ids, primitive_uvs (M, 2). Rays are numbered in C order of the leading shape.
        """
        rays = self._rays(origins, directions, t_min, t_max)
        n = len(rays)
        counts, out = batches.crossings(self._tree(), rays, fill=True)
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
        """Validate and flatten: (points (N, 3) float64 contiguous, leading shape, whether the input was float32)."""
        if not self._instances:
            raise ValueError("the scene is empty: add a mesh or a sphere before querying points")
        src = np.asarray(query_points)
        arr = np.ascontiguousarray(_numeric_array("query_points", src, (3,))).reshape(-1, 3)
        if not np.isfinite(arr).all():  # one cheap pass; the row only when there is one to name
            bad = ~np.isfinite(arr).all(axis=1)
            raise ValueError(f"query_points contains NaN or infinity (point {int(np.argmax(bad))})")
        return arr, src.shape[:-1], src.dtype == np.float32

    def _distance_index(self) -> DistanceIndex:
        tree = self._tree()
        if self._distance is None or self._distance.source is not tree:
            self._distance = DistanceIndex(tree)
        return self._distance

    def compute_closest_points(self, query_points, nthreads: int | None = None, keep_float32: bool = False) -> dict:
        """Closest surface point of each query point (..., 3): points (..., 3), geometry_ids, primitive_ids (int32;
        spheres 0), primitive_uvs (..., 2: barycentric weights of vertex 1 and 2, 0 for spheres) and
        primitive_normals (..., 3: unit, world space, by the triangle's winding; spheres outward). Exact for
        triangles (Ericson's region test) and spheres, ellipsoids included. keep_float32: float32 points give
        float32 points, uvs and normals (Open3D's types); otherwise float64."""
        p, lead, f32 = self._points(query_points)
        with _threads(nthreads):
            index = self._distance_index()
            _, inst, kind, prim, q, uv = index.closest_points(p)
            normals = index.normals(q, inst, kind, prim)
        ft = np.float32 if keep_float32 and f32 else np.float64
        return {
            "points": q.astype(ft, copy=False).reshape(*lead, 3),
            "geometry_ids": inst.reshape(lead),
            "primitive_ids": prim.reshape(lead),
            "primitive_uvs": uv.astype(ft, copy=False).reshape(*lead, 2),
            "primitive_normals": normals.astype(ft, copy=False).reshape(*lead, 3),
        }

    def compute_distance(self, query_points, nthreads: int | None = None, keep_float32: bool = False) -> np.ndarray:
        """Unsigned distance (...,) from each query point (..., 3) to the nearest surface."""
        p, lead, f32 = self._points(query_points)
        with _threads(nthreads):
            d2 = self._distance_index().closest_points(p)[0]
        return np.sqrt(d2).astype(np.float32 if keep_float32 and f32 else np.float64, copy=False).reshape(lead)

    def compute_winding_number(self, query_points, beta: float = DEFAULT_BETA, order: int = DEFAULT_ORDER,
                               nthreads: int | None = None, return_error_bound: bool = False):
        """Generalized winding number (...,) of each query point over all geometries: 1 inside a closed mesh
        wound counter-clockwise seen from outside (-1 if wound the other way, as the Stanford bunny is), 0
        outside, in between near holes (Jacobson et al. 2013); spheres count 1 inside. Evaluated through the BVH
        with Barill et al.'s far field (Taylor order 1 or 2) for BVH lanes more than `beta` radii away (beta > 1;
        inf sums every triangle exactly). With return_error_bound also a rigorous bound on each value's error
        from the approximation (kernels/points/winding.py). On the bunny, beta=2, order 2 is off by at most 0.05."""
        p, lead, _ = self._points(query_points)
        with _threads(nthreads):
            w, err = self._distance_index().winding_numbers(p, float(beta), int(order))
        return (w.reshape(lead), err.reshape(lead)) if return_error_bound else w.reshape(lead)

    def _inside(self, p: np.ndarray, method: str, nsamples: int, beta: float) -> np.ndarray:
        """Inside test of points p (N, 3): |winding number| > 1/2 (either winding order), or the majority of
        nsamples rays' crossing parity."""
        if method == "winding":
            return np.abs(self._distance_index().winding_numbers(p, float(beta), want_err=False)[0]) > 0.5
        if method != "parity":
            raise ValueError(f"method must be 'winding' or 'parity', got {method!r}")
        nsamples = int(nsamples)
        if nsamples < 1:
            raise ValueError(f"nsamples must be at least 1, got {nsamples}")
        dirs = _PARITY_DIRECTIONS[:nsamples] if nsamples <= len(_PARITY_DIRECTIONS) else _directions(nsamples)
        return self._distance_index().crossing_votes(p, dirs) * 2 > nsamples

    def compute_signed_distance(self, query_points, nthreads: int | None = None, nsamples: int = 1,
                                method: str = "winding", beta: float = SIGN_BETA,
                                keep_float32: bool = False) -> np.ndarray:
        """Distance to the nearest surface, negative inside (Open3D's sign). Inside is decided by

        * method="winding" (default): |generalized winding number| > 1/2, evaluated with far field `beta`
          (compute_winding_number; 1.5 here: a sign needs less accuracy than a value). Right for closed meshes
          and degrades gracefully on meshes with holes or self-intersections, such as scans: use it for training
          data and anything that must not flip signs.
        * method="parity": Open3D's rule, the parity of one ray's crossings (a majority vote of `nsamples`
          rays; each leaves the point away from the scene's middle, tilted by a fixed direction per sample).
          Several times faster than the winding number; right for closed, non-self-intersecting meshes, but a
          ray through a hole flips the sign, and a ray exactly through an edge counts both triangles.
        """
        p, lead, f32 = self._points(query_points)
        with _threads(nthreads):
            d = np.sqrt(self._distance_index().closest_points(p)[0])
            inside = self._inside(p, method, nsamples, beta)
        d = np.where(inside, -d, d)
        return d.astype(np.float32 if keep_float32 and f32 else np.float64, copy=False).reshape(lead)

    def compute_occupancy(self, query_points, nthreads: int | None = None, nsamples: int = 1,
                          method: str = "winding", beta: float = SIGN_BETA,
                          keep_float32: bool = False) -> np.ndarray:
        """1.0 inside, 0.0 outside for each query point (Open3D returns float too); method and nsamples as in
        compute_signed_distance."""
        p, lead, f32 = self._points(query_points)
        with _threads(nthreads):
            inside = self._inside(p, method, nsamples, beta)
        return inside.astype(np.float32 if keep_float32 and f32 else np.float64).reshape(lead)

    # ---------------------------------------------------------------------------------- pickling and repr
    def __getstate__(self) -> dict:
        """Shapes, instances and the built trees (built now if needed), so an unpickled scene (another process,
        a Dask worker) queries at once without rebuilding."""
        if self._instances:
            self._tree()
        return {"version": 1, "shapes": self._shapes, "instances": self._instances, "bvh": self._bvh,
                "distance": self._distance}

    def __setstate__(self, state: dict) -> None:
        if state.get("version") != 1:
            raise ValueError(f"cannot unpickle a RaycastingScene of state version {state.get('version')}")
        self._shapes, self._instances, self._bvh = state["shapes"], state["instances"], state["bvh"]
        self._distance = state["distance"]

    def __repr__(self) -> str:
        meshes = sum(1 for s, _ in self._instances if len(self._shapes[s].normals))
        tris = sum(len(self._shapes[s].normals) for s, _ in self._instances)
        stored = sum(len(s.normals) for s in self._shapes)
        if self._bvh is None:
            memory = "not built yet"
        else:
            extra = self._distance.nbytes + self._distance.moments_nbytes if self._distance is not None else 0
            memory = f"{(self._bvh.nbytes + extra) / 2**20:.1f} MiB"
        return (f"RaycastingScene({len(self._instances)} geometries: {meshes} meshes, "
                f"{len(self._instances) - meshes} spheres; {tris:,} triangles ({stored:,} stored); {memory})")


def _directions(n: int) -> np.ndarray:
    """n fixed unit directions for parity votes, random-looking so none lies along an axis or a mesh's edges."""
    d = np.random.default_rng(20131102).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


_PARITY_DIRECTIONS = _directions(16)


@contextlib.contextmanager
def _threads(nthreads: int | None):
    """Numba's thread count set to nthreads for the block (0: all cores; None: leave it), restored after."""
    if nthreads is None:
        yield
        return
    n = int(nthreads)
    if n < 0:
        raise ValueError(f"nthreads must be 0 (all cores) or positive, got {nthreads}")
    old = numba.get_num_threads()
    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS) if n else numba.config.NUMBA_NUM_THREADS)
    try:
        yield
    finally:
        numba.set_num_threads(old)


def _open3d_arguments(method):
    """Accept nthreads= (as every point query does) and Open3D's tnear / tfar for t_min / t_max."""
    @functools.wraps(method)
    def call(self, *args, nthreads: int | None = None, tnear=None, tfar=None, **kwargs):
        for o3d_name, name, value in (("tnear", "t_min", tnear), ("tfar", "t_max", tfar)):
            if value is not None:
                if name in kwargs:
                    raise ValueError(f"give {name} or Open3D's {o3d_name}, not both")
                kwargs[name] = value
        with _threads(nthreads):
            return method(self, *args, **kwargs)
    return call


for _name in ("cast_rays", "test_occlusions", "count_intersections", "list_intersections"):
    setattr(RaycastingScene, _name, _open3d_arguments(getattr(RaycastingScene, _name)))

RaycastingScene.INVALID_ID = INVALID_ID  # Open3D's spelling: the geometry and primitive id of a miss
