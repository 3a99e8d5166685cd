"""Point queries on a TwoLevelBVH: closest points, distances and generalized winding numbers.

`DistanceIndex` wraps the scene's two-level BVH with what point queries need beyond rays:

* instances under similarity transforms (rotation, mirror, uniform scale, translation) are searched in object
  space, as rays are: distances scale by the uniform factor and solid angles do not change, so both are exact;
* a mesh instance under any other affine transform (non-uniform scale, shear) is *baked*: its triangles moved into
  world space and given their own tree, once, when the index is built (memory: one more copy of that mesh);
* every sphere instance is solved in world space as the ellipsoid its transform makes of it (Eberly's bisection,
  exact to float64 rounding; the closed form when the transform keeps it a sphere);
* per-node moments (area vectors, centroids, radii, areas) of every bottom-level tree for the fast winding number;
* large batches of points are queried in Morton order of a grid over them (`cell_order`), so neighbouring points
  walk the tree one after another, and the answers are put back in the caller's order.

The kernels are kernels/points/closest.py and kernels/points/winding.py; query.py's RaycastingScene builds one lazily.
"""

from __future__ import annotations

import time

import numpy as np

from ..kernels.bvh.layout import HI_X, LO_X, NODE_FLOATS, WIDTH
from ..kernels.common import MISS, SPHERE, TRIANGLE
from ..kernels.points.closest import closest_points_instances
from ..kernels.points.crossing_packets import outside_bounds, ray_windings
from ..kernels.points.order import grid_bits, sort_by_cell
from ..kernels.points.winding import (
    FAR_AREA,
    FAR_CX,
    FAR_FLOATS,
    FAR_RHO,
    crossing_votes_instances,
    far_field_table,
    lane_bounds,
    lane_moments,
    winding_numbers_instances,
)
from ..kernels.threads import run_blocks
from .bvh import Shape, TwoLevelBVH
from .caps import boundary_cap

DEFAULT_BETA = 2.0  # Barill et al.'s accuracy parameter: a BVH lane is approximated from beta radii away
DEFAULT_ORDER = 2   # Taylor order of the far field (1: dipole, 2: dipole and its first correction)
# inside tests only need |w| on the right side of 1/2: a coarser far field, twice as fast; on the Stanford bunny
# its largest error is 0.09 (0.05 with beta 2), and on a closed mesh an error below 1/2 cannot flip a sign
SIGN_BETA = 1.5
SIMILARITY_RTOL = 1e-9  # A^T A = s^2 I within this relative tolerance counts as a similarity
RAY_TILT = np.array([0.28, -0.43, 0.61])  # added to each point's outward direction: no ray along an axis or a grid
# the caps' winding number (accel/caps.py) where a point needs it: far fields (beta, order) whose error bounds decide
# where each is trusted, then the cap's triangles summed exactly. Bunny, 59k points near its caps: (2, 1) leaves
# 10k undecided in 64 ms where (2, 2) left 14k in 67 ms; on the 23k its lanes' bounds leave, (2, 1) leaves 8.2k, then
# (2.5, 1) 426 and (4, 1) 82 to sum exactly: 27.5 ms one thread CPU, where (4, 2) on the 8.2k took 34.9 ms
CAP_STEPS = ((2.0, 1), (2.5, 1), (4.0, 1), (np.inf, 2))
CAP_MARGIN = 1e-9  # |w| this close to 1/2 (rounding of the sums) takes the winding rule
CAP_MAX_SHARE = 0.5  # a mesh whose cap would have more triangles than this share of its own keeps the winding rule
# the inside test's rays go as packets of 16 (kernels/points/crossing_packets.py) where their origins spread at most
# this many times the trees' median leaf box side: torus 1M points (spread ~1.5 leaves) 0.81x the one-ray walk
# with no limit, 0.92x at 2.5; bunny 1M points (spread ~3 leaves) 1.22x with no limit, 1.00x at 2.5
PACKET_LEAF_SPREAD = 2.5
CAP_BOUND_LEVELS = 1  # inside: the caps' |w| bounded again from the lanes this many levels below the roots
BOX_MARGIN = 1e-6  # inside: points outside the scene's box grown by this times its size count 0 crossings
SORT_MIN_POINTS = 4096  # fewer points are queried in the caller's order: sorting them would not pay


def similarity_scale(matrix: np.ndarray) -> float | None:
    """The uniform scale s of a 4x4 affine matrix whose linear part is s times an orthogonal matrix, else None."""
    a = np.asarray(matrix, dtype=np.float64)[:3, :3]
    g = a.T @ a
    s2 = np.trace(g) / 3.0
    if s2 <= 0.0 or np.abs(g - s2 * np.eye(3)).max() > SIMILARITY_RTOL * s2:
        return None
    return float(np.sqrt(s2))


def cell_order(points: np.ndarray, box: tuple[np.ndarray, np.ndarray] | None = None
               ) -> tuple[np.ndarray, np.ndarray | None]:
    """(the points in Morton order of a grid over them, the permutation: sorted[j] = points[order[j]]), or (the
    points, None) for small batches. Queries walk the tree for neighbouring points one after another, which
    shares the cache (kernels/points/order.py); `restore_order` puts the answers back. With `box` (lo, hi) only
    the points inside it are kept (and always an order, as `restore_order(..., n=N)` needs)."""
    n = len(points)
    if n < SORT_MIN_POINTS:
        if box is None:
            return points, None
        keep = np.flatnonzero(np.all((points >= box[0]) & (points <= box[1]), axis=1))
        return points[keep], keep
    sorted_points, order = np.empty_like(points), np.empty(n, np.int64)
    placed = sort_by_cell(points, grid_bits(n), sorted_points, order, box)
    return sorted_points[:placed], order[:placed]


def restore_order(order: np.ndarray | None, *arrays: np.ndarray, n: int | None = None) -> tuple[np.ndarray, ...]:
    """The answers for sorted points (cell_order) in the caller's order of the points; with n (a cell_order of
    the points inside a box: N points, the answers of the kept ones), zeros for the points left out."""
    if order is None:
        return arrays
    out = []
    for a in arrays:
        b = np.empty_like(a) if n is None else np.zeros((n, *a.shape[1:]), a.dtype)
        b[order] = a
        out.append(b)
    return tuple(out)


def closed_mesh(tris: np.ndarray) -> bool:
    """Whether triangles (F, 9) form a closed, consistently oriented surface: with vertices welded by exact
    coordinates, the directed edges a -> b are, as a multiset, the reversed ones b -> a."""
    if not len(tris):
        return True
    _, ids = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    f = ids.reshape(-1, 3).astype(np.int64)
    a, b = f.ravel(), np.roll(f, -1, axis=1).ravel()
    n = int(f.max()) + 1
    return bool(np.array_equal(np.sort(a * n + b), np.sort(b * n + a)))


class DistanceIndex:
    """Closest points and winding numbers over the instances of a TwoLevelBVH (see the module docstring)."""

    def __init__(self, tree: TwoLevelBVH):
        start = time.perf_counter()
        shapes, instances = list(tree.shapes), list(tree.instances)
        k = len(instances)
        self.baked = 0
        for i, (s, m) in enumerate(instances):
            shape = shapes[s]
            if len(shape.normals) and similarity_scale(m) is None:
                world = shape.triangles().reshape(-1, 3, 3) @ m[:3, :3].T + m[:3, 3]
                shapes.append(Shape.mesh(world))
                instances[i] = (len(shapes) - 1, np.eye(4))
                self.baked += 1
        self.source = tree  # the scene's tree this index answers for
        self.tree = tree if not self.baked else TwoLevelBVH(shapes, instances)
        o2w = np.array([m for _, m in instances]).reshape(k, 4, 4)
        self.o2w = np.ascontiguousarray(o2w[:, :3, :])
        self.scale = np.array([similarity_scale(m) or 1.0 for _, m in instances])
        self.sign = np.sign(np.linalg.det(o2w[:, :3, :3])) if k else np.zeros(0)
        sph_off = np.cumsum([0] + [len(s.radius) for s in shapes])
        self.inst_sphere = np.array([sph_off[s] if len(shapes[s].radius) else -1 for s, _ in instances], np.int64)
        self.inst_ell = np.full(k, -1, np.int64)
        centers, frames, semis = [], [], []
        for i, (s, m) in enumerate(instances):
            if self.inst_sphere[i] < 0:
                continue
            self.inst_ell[i] = len(centers)
            centers.append(m[:3, :3] @ shapes[s].center[0] + m[:3, 3])
            u, sv, _ = np.linalg.svd(m[:3, :3])  # the unit sphere's image: semi-axes sv along u's columns
            r = shapes[s].radius[0]
            scale = similarity_scale(m)
            frames.append(u.T)
            semis.append(np.full(3, r * scale) if scale is not None else r * sv)
        self.ell_center = np.array(centers).reshape(-1, 3)
        self.ell_frame = np.array(frames).reshape(-1, 3, 3)
        self.ell_semi = np.array(semis).reshape(-1, 3)
        self._moments: tuple | None = None
        self._closed: bool | None = None
        self._packet_spread: float | None = None
        self.build_seconds = time.perf_counter() - start
        self.nbytes = (0 if not self.baked else self.tree.nbytes) + sum(
            a.nbytes for a in (self.o2w, self.scale, self.ell_center, self.ell_frame, self.ell_semi))

    # ---------------------------------------------------------------------------------------- closest points
    def closest_points(self, points: np.ndarray):
        """points (N, 3) float64 contiguous -> (squared distance, instance, kind, primitive, closest point (N, 3),
        barycentric weights of vertices 1 and 2 (N, 2)); spheres give primitive 0 and weights 0."""
        n = len(points)
        points, perm = cell_order(points)
        p = self.tree.packed
        top, b = p.top, p.blas
        d2, inst = np.empty(n), np.empty(n, np.int32)
        kind, prim = np.empty(n, np.int8), np.empty(n, np.int32)
        q, uv = np.empty((n, 3)), np.empty((n, 2))
        if n:
            run_blocks(closest_points_instances, n, points, *top, self.o2w, self.scale, self.inst_ell,
                       self.ell_center, self.ell_frame, self.ell_semi, b.bounds, b.child, b.leaf_prim, b.leaf_tri,
                       p.stack, d2, inst, kind, prim, q, uv)
        return restore_order(perm, d2, inst, kind, prim, q, uv)

    def normals(self, q: np.ndarray, inst: np.ndarray, kind: np.ndarray, prim: np.ndarray) -> np.ndarray:
        """Unit world-space normals at closest points q: triangles by their winding (flipped under a mirror, as
        moved vertices would be), ellipsoids outward (the object-space radius by the inverse transpose). NumPy,
        no Numba parallel region, so forked processes may call it."""
        p = self.tree.packed
        k = np.where(kind != MISS, inst, 0)
        w2o = p.w2o[k][:, :, :3] if len(p.w2o) else np.zeros((len(q), 3, 3))
        obj = np.zeros((len(q), 3))
        tri = kind == TRIANGLE
        obj[tri] = p.normals[p.tri_off[p.inst_shape[k[tri]]] + prim[tri]] * p.inst_sign[k[tri], None]
        sph = kind == SPHERE
        if sph.any():
            local = np.einsum("nij,nj->ni", p.w2o[k[sph]][:, :, :3], q[sph]) + p.w2o[k[sph]][:, :, 3]
            obj[sph] = local - p.blas.sph_center[self.inst_sphere[k[sph]]]
        n = np.einsum("nji,nj->ni", w2o, obj)  # the inverse transpose of object-to-world is w2o transposed
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.divide(n, length, out=np.zeros_like(n), where=length > 0)

    # ---------------------------------------------------------------------------------------- winding numbers
    @property
    def moments(self) -> np.ndarray:
        """The far-field table (lanes, FAR_FLOATS) of every lane of every bottom-level node: centre, radius, area
        vector, area and second moment (kernels/points/winding.lane_moments packed by far_field_table), computed on
        first use."""
        if self._moments is None:
            b = self.tree.packed.blas
            m = len(b.child) * WIDTH
            table = np.zeros((m, FAR_FLOATS))
            if m:
                raw = (np.zeros((m, 3)), np.zeros((m, 3)), np.zeros((m, 9)), np.zeros(m), np.zeros(m))
                lane_moments(b.bounds, b.child, b.leaf_prim, b.leaf_tri, *raw)
                far_field_table(*raw, table)
            self._moments = table
        return self._moments

    def winding_numbers(self, points: np.ndarray, beta: float = DEFAULT_BETA, order: int = DEFAULT_ORDER,
                        want_err: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Generalized winding number of each point (N, 3) over all instances and a bound on its error (0 when
        beta is inf: every triangle summed exactly; 0 when not want_err, which saves a division per far lane).
        See kernels/points/winding.py."""
        if not beta > 1.0:
            raise ValueError(f"beta must be greater than 1, got {beta}")
        if order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {order}")
        points, perm = cell_order(points)
        return restore_order(perm, *self._windings(points, beta, order, want_err))

    def _windings(self, points: np.ndarray, beta: float, order: int, want_err: bool) -> tuple[np.ndarray, np.ndarray]:
        """winding_numbers of points (N, 3) in the order given (sorted already by the caller)."""
        n = len(points)
        p = self.tree.packed
        b = p.blas
        w, err = np.empty(n), np.zeros(n)
        if n:
            run_blocks(winding_numbers_instances, n, points, p.top.inst_root, p.w2o, self.sign, self.inst_sphere,
                       b.sph_center, b.sph_radius, b.child, b.leaf_prim, b.leaf_tri, self.moments, float(beta),
                       int(order), bool(want_err), p.stack, w, err)
        return w, err

    @property
    def closed(self) -> bool:
        """Whether every mesh instance is closed and consistently oriented: each edge (its ends welded by exact
        coordinates) used as often from a to b as from b to a, so winding numbers are integers off the surface and
        one ray's signed crossings give them (kernels/points/crossings.py). Checked once, on first use."""
        if getattr(self, "_closed", None) is None:  # indexes pickled before the flag existed lack it
            p = self.tree.packed
            used = {int(s) for k, s in enumerate(p.inst_shape) if self.inst_sphere[k] < 0}
            self._closed = all(closed_mesh(self.tree.shapes[s].triangles()) for s in used)
        return self._closed

    @property
    def caps(self) -> DistanceIndex | None:
        """An index over the caps that close the open mesh instances (accel/caps.py), placed as their meshes are;
        None when a cap would be too large to pay (CAP_MAX_SHARE). Built on first use."""
        if getattr(self, "_caps", False) is False:  # indexes pickled before the caps existed lack the field
            self._caps = self._build_caps()
        return self._caps

    def _build_caps(self) -> DistanceIndex | None:
        shapes: list[Shape] = []
        instances, made = [], {}
        for k, (s, m) in enumerate(self.tree.instances):
            if self.inst_sphere[k] >= 0:
                continue
            if s not in made:
                tris = self.tree.shapes[s].triangles()
                cap = boundary_cap(tris)
                if len(cap) > CAP_MAX_SHARE * len(tris):
                    return None
                made[s] = len(shapes) if len(cap) else -1
                if len(cap):
                    shapes.append(Shape.mesh(cap.reshape(-1, 3, 3)))
            if made[s] >= 0:
                instances.append((made[s], m))
        return DistanceIndex(TwoLevelBVH(shapes, instances))

    def root_lanes(self, levels: int = 0) -> np.ndarray:
        """The lanes `levels` below the roots of every mesh instance's tree (leaf lanes above that depth kept
        where they are: every triangle under exactly one lane) in world space (L, 5: centre, radius, area), for
        kernels/points/winding.lane_bound."""
        p, table = self.tree.packed, self.moments
        child = p.blas.child
        rows = []
        for k, root in enumerate(p.top.inst_root):
            if self.inst_sphere[k] >= 0:
                continue
            nodes, lanes = [int(root)], []
            for depth in range(levels + 1):
                below = []
                for node in nodes:
                    for lane in range(WIDTH):
                        code = child[node, lane]
                        if code > 0 and depth < levels:
                            below.append(int(code))
                        elif code != 0:
                            lanes.append(node * WIDTH + lane)
                nodes = below
            for q in lanes:
                row = table[q]
                c = self.o2w[k] @ np.append(row[FAR_CX:FAR_CX + 3], 1.0)
                s = self.scale[k]
                rows.append([*c, s * row[FAR_RHO], s * s * row[FAR_AREA]])
        return np.array(rows, np.float64).reshape(-1, 5)

    def packet_spread(self) -> float:
        """The largest origin spread (every axis) of a packet of inside-test rays: PACKET_LEAF_SPREAD times the
        median largest side of the bottom-level trees' leaf boxes (object space; a heuristic, answers do not
        depend on it)."""
        b = self.tree.packed.blas
        nodes, lanes = np.nonzero(b.child < 0)
        if not len(nodes):
            return 0.0
        rows = b.bounds.reshape(-1, NODE_FLOATS)
        side = np.max([rows[nodes, HI_X + a * WIDTH + lanes] - rows[nodes, LO_X + a * WIDTH + lanes]
                       for a in range(3)], axis=0)
        return PACKET_LEAF_SPREAD * float(np.median(side))

    def scene_box(self, caps: DistanceIndex | None) -> tuple[np.ndarray, np.ndarray]:
        """The box around every instance and every cap, grown by BOX_MARGIN of its size (far beyond float32 leaf
        vertices and the matrices' rounding): the closed surfaces' winding number is 0 outside it."""
        lo, hi = self.tree._inst_lo.min(axis=0), self.tree._inst_hi.max(axis=0)
        if caps is not None:
            lo = np.minimum(lo, caps.tree._inst_lo.min(axis=0, initial=np.inf))
            hi = np.maximum(hi, caps.tree._inst_hi.max(axis=0, initial=-np.inf))
        margin = BOX_MARGIN * (float(np.abs(hi - lo).max()) + float(np.abs([lo, hi]).max()))
        return lo - margin, hi + margin

    def _ray_windings(self, points: np.ndarray, caps: DistanceIndex | None, spread: float | None = None,
                      skip_outside: bool = True) -> tuple[np.ndarray, ...]:
        """(signed crossings of each point's ray over the meshes and the caps, unsure, bound on the caps' |w|)
        (kernels/points/crossing_packets.ray_windings), in the given order; the ray leaves along RAY_TILT plus the
        unit direction from the scene's middle to the point; packets of them where their origins spread at most
        `spread` (default packet_spread(): 0 walks every ray alone, inf every coherent packet as one); points outside
        the scene's box grown by BOX_MARGIN count 0, unwalked, and rays missing a cap instance's box grown as much
        do not walk its tree, unless skip_outside is False."""
        p = self.tree.packed
        n = len(points)
        w, unsure, bound = np.empty(n), np.zeros(n, np.bool_), np.zeros(n)
        lo, hi = self.tree._inst_lo.min(axis=0), self.tree._inst_hi.max(axis=0)
        t_eps = 1e-9 * max(float(np.linalg.norm(hi - lo)), 1e-300)
        box_lo, box_hi = self.scene_box(caps) if skip_outside else (lo - np.inf, hi + np.inf)
        if caps is None:  # the meshes' own arrays with no rows: the same types, so one compiled kernel
            cap_args = (p.top.inst_root[:0], p.w2o[:0], self.sign[:0], self.inst_sphere[:0],
                        *(a[:0] for a in p.blas), p.stack)
            lanes, cap_lo, cap_hi = np.zeros((0, 5)), np.zeros((0, 3)), np.zeros((0, 3))
        else:
            c = caps.tree.packed
            cap_args = (c.top.inst_root, c.w2o, caps.sign, caps.inst_sphere, *c.blas, c.stack)
            lanes = caps.root_lanes()
            cap_lo, cap_hi = caps.tree._inst_lo, caps.tree._inst_hi
            margin = BOX_MARGIN * (np.abs(cap_hi - cap_lo).max(axis=1, initial=0.0)
                                   + np.abs(np.concatenate([cap_lo, cap_hi], axis=1)).max(axis=1, initial=0.0))
            cap_lo, cap_hi = cap_lo - margin[:, None], cap_hi + margin[:, None]
            if not skip_outside:
                cap_lo, cap_hi = cap_lo - np.inf, cap_hi + np.inf
        if spread is None:
            if getattr(self, "_packet_spread", None) is None:  # indexes pickled before the field existed lack it
                self._packet_spread = self.packet_spread()
            spread = self._packet_spread
        run_blocks(ray_windings, n, points, RAY_TILT, (lo + hi) / 2, box_lo, box_hi, t_eps, float(spread),
                   p.top.inst_root, p.w2o, self.sign, self.inst_sphere, *p.blas, p.stack, cap_args, lanes, cap_lo,
                   cap_hi, w, unsure, bound)
        return w, unsure, bound

    def inside(self, points: np.ndarray, beta: float) -> np.ndarray:
        """|winding number| > 1/2 for each point (N, 3), from one ray's signed crossings per point: on closed meshes
        (`closed`) they are the winding number; on open ones the crossings of the meshes and their caps minus the
        caps' winding number (accel/caps.py): its far field where the error bound keeps |w| off 1/2, else its few
        triangles summed exactly. The winding rule (far field beta) decides where a crossing is not clean (grazing,
        near an edge, a point on the surface), where |w| is within CAP_MARGIN of 1/2, and everywhere when the caps
        would be too large."""
        caps = None if self.closed else self.caps
        if not self.closed and caps is None:
            return np.abs(self.winding_numbers(points, beta, want_err=False)[0]) > 0.5
        # outside the scene's box the count is 0: those points are neither sorted nor walked
        box = self.scene_box(caps)
        ordered, perm = cell_order(points, box)
        w, unsure, bound = self._ray_windings(ordered, caps)
        out = np.zeros(len(points), np.bool_)
        if caps is not None:
            # far from the caps |w_cap| < 1/2, so an integer count k decides alone: |k - w_cap| > 1/2 iff k != 0
            near = np.flatnonzero(~unsure & ((bound >= 0.5 - CAP_MARGIN) | (w != np.round(w))))
            # outside the box k = 0, and only the caps' winding number can put a point inside: its bound, unsorted
            out_bound = np.empty(len(points))
            if len(points):
                run_blocks(outside_bounds, len(points), points, *box, caps.root_lanes(), out_bound)
            far = np.flatnonzero(out_bound >= 0.5 - CAP_MARGIN)
            pts = np.concatenate([ordered[near], points[far]])
            k = np.concatenate([w[near], np.zeros(len(far))])
            # the same bound from the lanes a level down (16 for 4) where the root lanes' left |w_cap| open: the
            # bunny's near points 56k -> 23k, so the caps' far field runs on 0.4x the points
            deep = np.empty(len(pts))
            lane_bounds(caps.root_lanes(CAP_BOUND_LEVELS), pts, deep)
            open_ = np.flatnonzero((deep >= 0.5 - CAP_MARGIN) | (k != np.round(k)))
            k[open_] -= self._cap_windings(caps, pts[open_], k[open_])
            sure = np.abs(np.abs(k[open_]) - 0.5) > CAP_MARGIN
            if not sure.all():  # |w| within CAP_MARGIN of 1/2: the winding rule
                rule = open_[~sure]
                k[rule] = self._windings(pts[rule], beta, DEFAULT_ORDER, False)[0]
            walked = open_[open_ < len(near)]
            w[near[walked]] = k[walked]
            out[far] = np.abs(k[len(near):]) > 0.5
        if unsure.any():
            w[unsure] = self._windings(ordered[unsure], beta, DEFAULT_ORDER, False)[0]
        if len(ordered):
            out[perm] = np.abs(w) > 0.5
        return out

    @staticmethod
    def _cap_windings(caps: DistanceIndex, points: np.ndarray, crossings: np.ndarray) -> np.ndarray:
        """The caps' winding number w_C at points (N, 3) whose crossing counts are `crossings`, accurate enough to
        tell the side of 1/2 of |crossings - w_C|: each step of CAP_STEPS (far fields of growing beta, then every
        triangle summed exactly) is taken only where the error bound of the one before leaves the side open."""
        w_cap = np.empty(len(points))
        todo = np.arange(len(points))
        for beta, order in CAP_STEPS:
            exact = beta == np.inf
            wc, err = caps._windings(points[todo], beta, order, not exact)
            w_cap[todo] = wc
            if exact:
                break
            todo = todo[np.abs(np.abs(crossings[todo] - wc) - 0.5) <= err + CAP_MARGIN]
            if not len(todo):
                break
        return w_cap

    def crossing_votes(self, points: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """How many of R rays from each point (N, 3) cross the surfaces an odd number of times: ray r along
        dirs[r] (R, 3) plus the unit direction away from the middle of the scene (kernels/points/winding.py)."""
        points, perm = cell_order(points)
        p = self.tree.packed
        votes = np.zeros(len(points), np.int64)
        if len(points):
            lo, hi = self.tree._inst_lo.min(axis=0), self.tree._inst_hi.max(axis=0)
            run_blocks(crossing_votes_instances, len(points), points, np.ascontiguousarray(dirs, np.float64),
                       (lo + hi) / 2, p.top.inst_root, p.w2o, *p.blas, p.stack, votes)
        return restore_order(perm, votes)[0]

    @property
    def moments_nbytes(self) -> int:
        return 0 if self._moments is None else self._moments.nbytes

    @property
    def caps_nbytes(self) -> int:
        """Bytes of the caps' index once an inside test on open meshes built it: its own tree (no accelerator shares
        it, unlike the meshes'), placements and far-field moments."""
        caps = getattr(self, "_caps", None)
        return 0 if not caps else caps.tree.nbytes + caps.nbytes + caps.moments_nbytes
