"""Caps that close an open mesh, so that one ray's crossings give its winding number (inside tests on scans).

The generalized winding number is additive over triangles: w_S = w_{S+C} - w_C for any triangles C. Choose C, the
cap, so that S + C has no boundary (every edge, welded by exact coordinates, used as often from a to b as from b to a):
then w_{S+C} is an integer off the surfaces, the signed count of one ray's crossings of S and C
(kernels/points/crossings.py), and w_S = crossings - w_C, where w_C is the winding number of the few cap triangles,
evaluated with the far field and its error bound (kernels/points/winding.py). The cap here is a fan: each boundary
edge a -> b left over (used more often from a to b than back) gets the triangle (b, a, apex), the apex the mean of
its boundary component's vertices, rounded to float32 so the cap's tree keeps float32 leaves; around a boundary
loop the fan's spokes cancel. Any cap gives the same w_S; a small one near the holes keeps w_C cheap and its
far field tight (accel/distance.py decides where its bound is too loose and takes the winding rule there).
"""

from __future__ import annotations

import numpy as np


def _components(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """Connected component label of each of n vertices joined by edges a[i] - b[i] (union-find with path halving:
    boundary edges are few)."""
    parent = list(range(n))

    def find(x: int) -> int:
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        return x

    for x, y in zip(a.tolist(), b.tolist(), strict=True):
        rx, ry = find(x), find(y)
        if rx != ry:
            parent[rx] = ry
    return np.array([find(x) for x in range(n)], np.int64)


def boundary_cap(tris: np.ndarray) -> np.ndarray:
    """The fan cap (C, 9) closing triangles tris (F, 9): empty for a closed, consistently oriented mesh (module
    docstring)."""
    if not len(tris):
        return np.zeros((0, 9))
    verts, ids = np.unique(tris.reshape(-1, 3), axis=0, return_inverse=True)
    f = ids.reshape(-1, 3).astype(np.int64)
    a, b = f.ravel(), np.roll(f, -1, axis=1).ravel()
    n = len(verts)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keys, inv = np.unique(lo * n + hi, return_inverse=True)
    net = np.zeros(len(keys), np.int64)  # uses from the lower vertex to the higher, minus the reverse
    np.add.at(net, inv.ravel(), np.where(a < b, 1, -1))
    left = net != 0
    if not left.any():
        return np.zeros((0, 9))
    ea, eb, count = keys[left] // n, keys[left] % n, net[left]
    ea, eb = np.where(count > 0, ea, eb), np.where(count > 0, eb, ea)  # the edge as the mesh uses it more often
    count = np.abs(count)
    used = np.unique(np.concatenate([ea, eb]))
    local = np.searchsorted(used, ea), np.searchsorted(used, eb)
    label = _components(*local, len(used))
    roots, comp = np.unique(label, return_inverse=True)
    apex = np.zeros((len(roots), 3))
    np.add.at(apex, comp, verts[used])
    apex /= np.bincount(comp, minlength=len(roots))[:, None]
    apex = apex.astype(np.float32).astype(np.float64)
    cap = np.concatenate([verts[eb], verts[ea], apex[comp[local[0]]]], axis=1)
    return np.repeat(cap, count, axis=0)
