"""Mitsuba's `sdfgrid` shape: a grid of signed distances (a Mitsuba .vol file, or an array) whose zero level set is the
surface, read as a triangle mesh. Mitsuba intersects the trilinear interpolant of the grid, whose samples sit at i /
(n - 1) of the unit cube [0, 1]^3 in object space (measured: its hits along grid lines fall on the linear zero
crossings there), the array indexed [z, y, x]. durer triangulates that level set instead: each cell is split in two
along every axis (the interpolant's exact values at the new points), then into six tetrahedra each, whose linear
zero sets are the triangles (marching tetrahedra; a triangulation at twice the grid's resolution, watertight, with
vertices on the interpolant's zero set, closed where the surface is). Vertex normals are the grid's central-
difference gradient interpolated like the vertices (Mitsuba's smooth normals), pointing to positive distances
(outside)."""

from __future__ import annotations

import numpy as np

VOL_MAGIC = b"VOL"
_FLOAT32 = 1
# the six tetrahedra of a cube around its diagonal 0 -> 7 (corner bits: x 1, y 2, z 4), each a path 0, a, b, 7
_TETS = np.array([[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]])


def read_vol(data: bytes) -> np.ndarray:
    """The (z, y, x) float grid of a Mitsuba volume file (version 3, one float32 channel)."""
    if len(data) < 48 or data[:3] != VOL_MAGIC or data[3] != 3:
        raise ValueError("not a Mitsuba volume file (version 3 'VOL' header)")
    kind, nx, ny, nz, channels = np.frombuffer(data[4:24], "<i4")
    if kind != _FLOAT32 or channels != 1:
        raise ValueError(f"durer reads one float32 channel, this volume has type {kind} and {channels} channels")
    if min(nx, ny, nz) < 2:
        raise ValueError(f"a grid needs at least 2 samples a side, got {nx} x {ny} x {nz}")
    count = int(nx) * int(ny) * int(nz)
    if len(data) < 48 + 4 * count:
        raise ValueError(f"volume file is truncated: {nx} x {ny} x {nz} floats announced")
    return np.frombuffer(data[48:48 + 4 * count], "<f4").reshape(nz, ny, nx).astype(np.float64)


def _refine(grid: np.ndarray) -> np.ndarray:
    """The trilinear interpolant sampled at twice the resolution (2n - 1 a side): new points are edge, face and
    cell midpoints, whose interpolated values are the means of the 2, 4 and 8 samples around them."""
    for axis in range(3):
        n = grid.shape[axis]
        shape = list(grid.shape)
        shape[axis] = 2 * n - 1
        out = np.empty(shape)
        even = [slice(None)] * 3
        odd = [slice(None)] * 3
        even[axis], odd[axis] = slice(0, None, 2), slice(1, None, 2)
        out[tuple(even)] = grid
        lo = [slice(None)] * 3
        hi = [slice(None)] * 3
        lo[axis], hi[axis] = slice(0, -1), slice(1, None)
        out[tuple(odd)] = 0.5 * (grid[tuple(lo)] + grid[tuple(hi)])
        grid = out
    return grid


def sdf_mesh(grid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (V, 3) in [0, 1]^3, faces (F, 3) facing outside, unit vertex normals (V, 3)) of the zero level
    set of a (z, y, x) grid of signed distances (negative inside)."""
    g = _refine(np.asarray(grid, dtype=np.float64))
    # a sample exactly on the surface counts as just outside, so the triangles around it stay connected (a tiny
    # fan near it, where an exact zero would give each edge into it a vertex of its own at the same place)
    g[g == 0] = 1e-12 * max(float(np.abs(g).max()), 1e-300)
    nz, ny, nx = g.shape
    grad = np.stack(np.gradient(g)[::-1], axis=-1)  # d/dx, d/dy, d/dz at every sample
    cz, cy, cx = np.meshgrid(np.arange(nz - 1), np.arange(ny - 1), np.arange(nx - 1), indexing="ij")
    base = ((cz * ny + cy) * nx + cx).ravel()
    corner = np.array([(b >> 2 & 1) * ny * nx + (b >> 1 & 1) * nx + (b & 1) for b in range(8)])
    ids = base[:, None, None] + corner[_TETS][None]                        # (cells, 6, 4) sample ids
    ids = ids.reshape(-1, 4)
    flat = g.ravel()
    inside = flat[ids] < 0
    count = inside.sum(axis=1)
    tris: list[np.ndarray] = []  # (k, 3, 2): each triangle corner as the edge (sample id, sample id) it lies on
    for n_in in (1, 3):  # one corner apart from the other three: one triangle on its three edges
        sel = ids[count == n_in]
        lone = inside[count == n_in] if n_in == 1 else ~inside[count == n_in]
        k = np.argmax(lone, axis=1)
        a = sel[np.arange(len(sel)), k]
        others = np.array([[j for j in range(4) if j != i] for i in range(4)])[k]
        b = np.take_along_axis(sel, others, axis=1)
        tris.append(np.stack([np.stack([a, b[:, j]], axis=1) for j in range(3)], axis=1))
    sel = ids[count == 2]  # two and two: a quad on the four edges between the pairs, as two triangles
    order = np.argsort(~inside[count == 2], axis=1, kind="stable")  # inside corners first
    s = np.take_along_axis(sel, order, axis=1)
    i0, i1, o0, o1 = s[:, 0], s[:, 1], s[:, 2], s[:, 3]
    quad = [np.stack([i0, o0], 1), np.stack([i0, o1], 1), np.stack([i1, o1], 1), np.stack([i1, o0], 1)]
    tris.append(np.stack([quad[0], quad[1], quad[2]], axis=1))
    tris.append(np.stack([quad[0], quad[2], quad[3]], axis=1))
    edges = np.concatenate(tris).reshape(-1, 2)
    if not len(edges):
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3))
    edges = np.sort(edges, axis=1)
    keys, faces = np.unique(edges[:, 0] * flat.size + edges[:, 1], return_inverse=True)
    a, b = keys // flat.size, keys % flat.size
    w = flat[a] / (flat[a] - flat[b])  # the linear zero crossing on the edge a -> b
    pos = np.stack(np.unravel_index(np.stack([a, b]), g.shape)[::-1], axis=-1).astype(np.float64)  # (2, V, xyz)
    vertices = (pos[0] + w[:, None] * (pos[1] - pos[0])) / (np.array([nx, ny, nz]) - 1.0)
    normals = grad.reshape(-1, 3)[a] * (1 - w[:, None]) + grad.reshape(-1, 3)[b] * w[:, None]
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    faces = faces.reshape(-1, 3)
    v = vertices[faces]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    flip = np.einsum("ij,ij->i", n, normals[faces].sum(axis=1)) < 0  # face the gradient (outside)
    faces[flip] = faces[flip][:, [0, 2, 1]]
    return vertices, faces, normals
