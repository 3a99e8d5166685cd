"""What the BVH build takes and gives over triangles (Numba): the items' boxes, the mesh's normals and bounds, and
the leaf-ordered vertices the traversal reads (float32 where that is exact).

A mesh given as vertices (V, 3) and indices (F, 3) (RaycastingScene.add_triangles) is read through its indices:
no (F, 3, 3) copy of its triangles is made (80 MB and 0.07 s at 1.1M triangles).
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from ..threads import map_pieces


@nb.njit(**JIT, inline="always")
def unit_normal(ax, ay, az, bx, by, bz):
    """a x b made unit (zero for a degenerate triangle) in np.cross's and np.linalg.norm's order of operations, so
    the normals equal NumPy's to the bit."""
    nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    length = np.sqrt((nx * nx + ny * ny) + nz * nz)
    if length > 0.0:
        nx, ny, nz = nx / length, ny / length, nz / length
    return nx, ny, nz


@nb.njit(**JIT)
def item_boxes(tris, sphere_lo, sphere_hi):
    """Boxes (n, 3) lo and hi of the triangles (F, 9) followed by the spheres' boxes (S, 3)."""
    f = tris.shape[0]
    n = f + sphere_lo.shape[0]
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for i in range(f):
        for a in range(3):
            x, y, z = tris[i, a], tris[i, 3 + a], tris[i, 6 + a]
            lo[i, a] = min(x, y, z)
            hi[i, a] = max(x, y, z)
    for i in range(f, n):
        for a in range(3):
            lo[i, a] = sphere_lo[i - f, a]
            hi[i, a] = sphere_hi[i - f, a]
    return lo, hi


@nb.njit(**JIT)
def mesh_normals_bounds(tris):
    """Unit normals (F, 3) of triangles (F, 3, 3) (zero for a degenerate one) and the mesh's bounds lo, hi (3,),
    in one pass: NumPy's cross product, norm and two reductions over the (F, 3, 3) array took 0.5 s of the 1.1M
    bunny's 2 s build. The arithmetic is NumPy's (a1 b2 - a2 b1; sqrt((x x + y y) + z z)), so the same bits."""
    f = tris.shape[0]
    normals = np.zeros((f, 3))
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for i in range(f):
        normals[i, 0], normals[i, 1], normals[i, 2] = unit_normal(
            tris[i, 1, 0] - tris[i, 0, 0], tris[i, 1, 1] - tris[i, 0, 1], tris[i, 1, 2] - tris[i, 0, 2],
            tris[i, 2, 0] - tris[i, 0, 0], tris[i, 2, 1] - tris[i, 0, 1], tris[i, 2, 2] - tris[i, 0, 2])
        for c in range(3):
            for a in range(3):
                x = tris[i, c, a]
                lo[a] = min(lo[a], x)
                hi[a] = max(hi[a], x)
    return normals, lo, hi


@nb.njit(**JIT)
def leaf_items(tris, order):
    """leaf_prim (triangle id, or -(sphere + 1)) and leaf_tri (the triangle's 9 coordinates, zeros for a
    sphere) in leaf order."""
    f = tris.shape[0]
    n = order.shape[0]
    leaf_prim = np.empty(n, np.int32)
    leaf_tri = np.zeros((n, 9))
    for j in range(n):
        p = order[j]
        if p < f:
            leaf_prim[j] = p
            for q in range(9):
                leaf_tri[j, q] = tris[p, q]
        else:
            leaf_prim[j] = -(p - f) - 1
    return leaf_prim, leaf_tri


PARALLEL_ITEMS = 100_000  # triangles from which indexed_items and indexed_leaves run in pieces on every thread


def indexed_items(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, ...]:
    """For the triangles v[f] (vertices (V, 3) float32 or float64, indices (F, 3)): unit normals (F, 3), the
    mesh's bounds lo, hi (3,), and the build's item rows (build.item_rows: ib (F, 9) of each triangle's box and
    centroid, the root's box (6,) and centroid bounds (6,)), in one pass over the indices, with no (F, 3) box
    arrays in between (53 MB of page faults at 1.1M triangles). The arithmetic is mesh_normals_bounds',
    item_boxes' and item_rows' on float64(v[f]), so the same bits. The large arrays are NumPy's (see
    build.node_arrays: huge pages where the system gives them). Large meshes in pieces on every thread (each
    piece's rows are its own; the bounds are minima and maxima of the pieces', so the same bits)."""
    n = len(f)
    normals, ib = np.empty((n, 3)), np.empty((n, 9))
    pieces = map_pieces(_indexed_items, n, v, f, normals, ib, threads=None if n >= PARALLEL_ITEMS else 1)
    ext = np.array([p for p in pieces if p.shape[0]]).reshape(-1, 2, 6)  # per piece: box, centroid bounds
    root_box, root_cb = np.empty(6), np.empty(6)
    for row, ref in ((0, root_box), (1, root_cb)):
        ref[:3] = ext[:, row, :3].min(axis=0) if len(ext) else np.inf
        ref[3:] = ext[:, row, 3:].max(axis=0) if len(ext) else -np.inf
    return normals, root_box[:3].copy(), root_box[3:].copy(), ib, root_box, root_cb


@nb.njit(**JIT)
def _indexed_items(v, f, normals, ib, i0, i1):
    """indexed_items for triangles i0..i1 into the given normals and ib: returns (2, 6) their box (lo, hi) and
    their centroid bounds, or (0, 6) for no triangles."""
    ext = np.empty((2, 6))
    for a in range(3):
        ext[0, a] = ext[1, a] = np.inf
        ext[0, 3 + a] = ext[1, 3 + a] = -np.inf
    p = np.empty((3, 3))
    for i in range(i0, i1):
        for c in range(3):
            k = f[i, c]
            for a in range(3):
                p[c, a] = np.float64(v[k, a])
        normals[i, 0], normals[i, 1], normals[i, 2] = unit_normal(
            p[1, 0] - p[0, 0], p[1, 1] - p[0, 1], p[1, 2] - p[0, 2], p[2, 0] - p[0, 0], p[2, 1] - p[0, 1],
            p[2, 2] - p[0, 2])
        for a in range(3):
            x, y, z = p[0, a], p[1, a], p[2, a]
            b_lo, b_hi = min(x, y, z), max(x, y, z)
            cen = 0.5 * (b_lo + b_hi)
            ib[i, a], ib[i, 3 + a], ib[i, 6 + a] = b_lo, b_hi, cen
            ext[0, a] = min(ext[0, a], b_lo)
            ext[0, 3 + a] = max(ext[0, 3 + a], b_hi)
            ext[1, a] = min(ext[1, a], cen)
            ext[1, 3 + a] = max(ext[1, 3 + a], cen)
    return ext if i1 > i0 else ext[:0]


@nb.njit(**JIT)
def _narrow_gather(v, f, order, out, j0, j1):
    """out[j] = float32 of the vertices of triangle order[j] (rows of v through f) for j in j0..j1; False if one
    is no float32 value (the caller then keeps float64 leaves)."""
    exact = True
    for j in range(j0, j1):
        t = order[j]
        for c in range(3):
            k = f[t, c]
            for a in range(3):
                x = np.float64(v[k, a])
                y = np.float32(x)
                out[j, 3 * c + a] = y
                if np.float64(y) != x:
                    exact = False
    return exact


@nb.njit(**JIT)
def _wide_gather(v, f, order, out, j0, j1):
    """out[j] = the vertices of triangle order[j] (float64), through f, for j in j0..j1."""
    for j in range(j0, j1):
        t = order[j]
        for c in range(3):
            k = f[t, c]
            for a in range(3):
                out[j, 3 * c + a] = v[k, a]


def indexed_leaves(v: np.ndarray, f: np.ndarray, order: np.ndarray, narrow: bool) -> tuple[np.ndarray, np.ndarray]:
    """leaf_prim and leaf_tri (M, 9) of a mesh v[f] in leaf order (no spheres); float32 when `narrow` and every
    vertex read is a float32 value (the traversal then reads half the bytes and answers the same), else
    float64. One gather, no float64 copy on the way to float32; large meshes in pieces on every thread."""
    leaf_prim = order.astype(np.int32, copy=False)
    threads = None if len(order) >= PARALLEL_ITEMS else 1
    if narrow:
        out = np.empty((len(order), 9), np.float32)
        if all(map_pieces(_narrow_gather, len(order), v, f, order, out, threads=threads)):
            return leaf_prim, out
    out64 = np.empty((len(order), 9))
    map_pieces(_wide_gather, len(order), v, f, order, out64, threads=threads)
    return leaf_prim, out64
