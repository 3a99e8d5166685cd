"""The course's uniform grid (assignments 5-6): building the cell lists and marching rays with 3D-DDA.

A grid covers the scene's bounding box with nx x ny x nz equal cells. Each cell holds the bounded primitives
that may overlap it, as CSR arrays: the items of cell c are items[start[c]:start[c + 1]], an item k >= 0 being
triangle k and k < 0 sphere -k - 1. Planes are unbounded and never stored: every ray tests them beside the grid.

Rays walk the cells with Amanatides & Woo's 3D-DDA. The closest-hit walk keeps the nearest hit found so far
(tested over the ray's whole [t_min, best) range, so a primitive shared by several cells is never lost) and
stops only once that hit lies before the end of the current cell: no unvisited cell can then hold a closer
one. Ties in t go to the (kind, index) that the brute-force loop would keep, so the results are identical.

The kernels take the grid's origin `lo`, cell `size` and `dims`, and `box` (2,3): the box rays are clipped to.
Every kernel takes `count`: when True it writes per-ray counts of primitive tests and cells visited into
`n_tests` / `n_cells` (one slot per ray, summed by the caller, so parallel rays never share a counter); when
False those arrays may be empty and nothing is counted.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..common import MISS, PLANE, SPHERE, TRIANGLE
from ..intersect import intersect_plane, intersect_triangle, sphere_hit_in_object_space

# The walk stops when the best hit lies this far (relative to the grid's size along the ray) before the end of
# the current cell, so a hit computed a rounding error outside its cell cannot end the walk too early.
SLACK = 1e-9
# A box is closed: one whose face lies on a cell boundary goes into the cells on both sides, as the course's
# images show (scenes 5_10, 5_12, 6_11). "On" is up to this fraction of a cell: the course computed in single
# precision, and the rotated diamond of 6_12 only matches with a tolerance well above double rounding.
TOUCH = 1e-5


# --- building ------------------------------------------------------------------------------------------------
@nb.njit(cache=True, inline="always")
def _index(x, lo, size, n, nudge=0.0):
    """Cell index along one axis of coordinate x (moved by `nudge` cells first), clamped to [0, n - 1]."""
    i = int(math.floor((x - lo) / size + nudge))
    if i < 0:
        return 0
    if i > n - 1:
        return n - 1
    return i


@nb.njit(cache=True)
def _tri_box_overlap(tri, bmin, bmax):
    """Does triangle `tri` (3,3) meet the closed box [bmin, bmax]? The separating-axis test (Akenine-Moller):
    the box's 3 axes (already known to overlap: the cell range comes from the triangle's box), the
    triangle's normal, and the 9 edge cross products. A small tolerance keeps it conservative."""
    c0 = 0.5 * (bmin[0] + bmax[0])
    c1 = 0.5 * (bmin[1] + bmax[1])
    c2 = 0.5 * (bmin[2] + bmax[2])
    h = np.empty(3)
    h[0] = 0.5 * (bmax[0] - bmin[0])
    h[1] = 0.5 * (bmax[1] - bmin[1])
    h[2] = 0.5 * (bmax[2] - bmin[2])
    v = np.empty((3, 3))
    for k in range(3):
        v[k, 0] = tri[k, 0] - c0
        v[k, 1] = tri[k, 1] - c1
        v[k, 2] = tri[k, 2] - c2
    e = np.empty((3, 3))
    for a in range(3):
        e[0, a] = v[1, a] - v[0, a]
        e[1, a] = v[2, a] - v[1, a]
        e[2, a] = v[0, a] - v[2, a]
    eps = 1e-9 * (h[0] + h[1] + h[2])
    # triangle normal
    nx = e[0, 1] * e[1, 2] - e[0, 2] * e[1, 1]
    ny = e[0, 2] * e[1, 0] - e[0, 0] * e[1, 2]
    nz = e[0, 0] * e[1, 1] - e[0, 1] * e[1, 0]
    d = nx * v[0, 0] + ny * v[0, 1] + nz * v[0, 2]
    r = h[0] * abs(nx) + h[1] * abs(ny) + h[2] * abs(nz)
    if abs(d) > r + eps * (abs(nx) + abs(ny) + abs(nz)):
        return False
    # edge x box-axis cross products
    for i in range(3):
        for a in range(3):
            # axis = unit_a x e_i
            ax = 0.0
            ay = 0.0
            az = 0.0
            if a == 0:
                ay, az = -e[i, 2], e[i, 1]
            elif a == 1:
                ax, az = e[i, 2], -e[i, 0]
            else:
                ax, ay = -e[i, 1], e[i, 0]
            p0 = ax * v[0, 0] + ay * v[0, 1] + az * v[0, 2]
            p1 = ax * v[1, 0] + ay * v[1, 1] + az * v[1, 2]
            p2 = ax * v[2, 0] + ay * v[2, 1] + az * v[2, 2]
            pmin = min(p0, min(p1, p2))
            pmax = max(p0, max(p1, p2))
            rad = h[0] * abs(ax) + h[1] * abs(ay) + h[2] * abs(az)
            tol = eps * (abs(ax) + abs(ay) + abs(az))
            if pmin > rad + tol or pmax < -rad - tol:
                return False
    return True


@nb.njit(cache=True)
def _sphere_cell(center, radius, bmin, bmax):
    """The course's sphere rasterisation: a cell is occupied when its centre is within the radius plus half
    the cell's diagonal of the sphere's centre. Conservative (every cell the sphere touches passes), solid
    (inner cells too), and what the reference images of assignment 5 show, cell for cell."""
    dc = 0.0
    hd = 0.0
    for a in range(3):
        x = 0.5 * (bmin[a] + bmax[a]) - center[a]
        h = 0.5 * (bmax[a] - bmin[a])
        dc += x * x
        hd += h * h
    return math.sqrt(dc) <= radius + math.sqrt(hd)


@nb.njit(cache=True, inline="always")
def _cell_box(lo, size, i, j, m, bmin, bmax):
    """The box of cell (i, j, m) into bmin, bmax."""
    bmin[0] = lo[0] + i * size[0]
    bmin[1] = lo[1] + j * size[1]
    bmin[2] = lo[2] + m * size[2]
    bmax[0] = bmin[0] + size[0]
    bmax[1] = bmin[1] + size[1]
    bmax[2] = bmin[2] + size[2]


@nb.njit(cache=True)
def _fill(tris, tri_test, sph_center, sph_radius, sph_lo, sph_hi, sph_as_box, lo, size, dims, start, items,
          counting):
    """One pass over every primitive and every cell its box covers: with counting, add to start[c + 1];
    otherwise write the item at start[c] + (running offset). Both passes take the same decisions."""
    nx, ny, nz = dims[0], dims[1], dims[2]
    fill = np.zeros(nx * ny * nz, dtype=np.int64)
    bmin = np.empty(3)
    bmax = np.empty(3)
    for k in range(tris.shape[0]):
        t = tris[k]
        i0 = _index(min(t[0, 0], min(t[1, 0], t[2, 0])), lo[0], size[0], nx, -TOUCH)
        i1 = _index(max(t[0, 0], max(t[1, 0], t[2, 0])), lo[0], size[0], nx, TOUCH)
        j0 = _index(min(t[0, 1], min(t[1, 1], t[2, 1])), lo[1], size[1], ny, -TOUCH)
        j1 = _index(max(t[0, 1], max(t[1, 1], t[2, 1])), lo[1], size[1], ny, TOUCH)
        k0 = _index(min(t[0, 2], min(t[1, 2], t[2, 2])), lo[2], size[2], nz, -TOUCH)
        k1 = _index(max(t[0, 2], max(t[1, 2], t[2, 2])), lo[2], size[2], nz, TOUCH)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                for m in range(k0, k1 + 1):
                    if tri_test:
                        _cell_box(lo, size, i, j, m, bmin, bmax)
                        if not _tri_box_overlap(t, bmin, bmax):
                            continue
                    c = (m * ny + j) * nx + i
                    if counting:
                        start[c + 1] += 1
                    else:
                        items[start[c] + fill[c]] = k
                        fill[c] += 1
    # a rasterised sphere may take cells just beyond its box (centre within radius + half diagonal)
    half_diag = 0.5 * math.sqrt(size[0] * size[0] + size[1] * size[1] + size[2] * size[2])
    for k in range(sph_radius.shape[0]):
        grow = 0.0 if sph_as_box[k] else half_diag
        i0 = _index(sph_lo[k, 0] - grow, lo[0], size[0], nx, -TOUCH)
        i1 = _index(sph_hi[k, 0] + grow, lo[0], size[0], nx, TOUCH)
        j0 = _index(sph_lo[k, 1] - grow, lo[1], size[1], ny, -TOUCH)
        j1 = _index(sph_hi[k, 1] + grow, lo[1], size[1], ny, TOUCH)
        k0 = _index(sph_lo[k, 2] - grow, lo[2], size[2], nz, -TOUCH)
        k1 = _index(sph_hi[k, 2] + grow, lo[2], size[2], nz, TOUCH)
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                for m in range(k0, k1 + 1):
                    if not sph_as_box[k]:
                        _cell_box(lo, size, i, j, m, bmin, bmax)
                        if not _sphere_cell(sph_center[k], sph_radius[k], bmin, bmax):
                            continue
                    c = (m * ny + j) * nx + i
                    if counting:
                        start[c + 1] += 1
                    else:
                        items[start[c] + fill[c]] = -k - 1
                        fill[c] += 1


def build_cells(tris, tri_test, sph_center, sph_radius, sph_lo, sph_hi, sph_as_box, lo, size, dims):
    """CSR cell lists (start (C+1,) int64, items (M,) int32) of the primitives, cells numbered x fastest."""
    ncell = int(dims[0]) * int(dims[1]) * int(dims[2])
    start = np.zeros(ncell + 1, dtype=np.int64)
    items = np.zeros(0, dtype=np.int32)
    args = (tris, tri_test, sph_center, sph_radius, sph_lo, sph_hi, sph_as_box, lo, size, dims)
    _fill(*args, start, items, True)
    np.cumsum(start, out=start)
    items = np.empty(int(start[-1]), dtype=np.int32)
    _fill(*args, start, items, False)
    return start, items


# --- marching ------------------------------------------------------------------------------------------------
@nb.njit(cache=True, inline="always")
def _better(t, kind, prim, best, bkind, bprim):
    """Would the brute-force loop keep (t, kind, prim) over the current best? Nearer wins; at equal t the
    lower kind (triangles, spheres, planes) and then the lower index, as the loop meets them first."""
    if t < best:
        return True
    if t == best and t < np.inf:
        return kind < bkind or (kind == bkind and prim < bprim)
    return False


@nb.njit(cache=True, inline="always")
def _clip(o, d, lo, hi, t0, t1):
    """[t0, t1] clipped to the box [lo, hi] (slabs); returns (t0, t1, axis of the entry face or -1).
    The kernels clip to the grid box grown by a hair (`box`), so a ray that only touches the box - aimed at
    a vertex on its corner, say - is not lost to rounding; the walk clamps it into the boundary cells."""
    axis = -1
    for a in range(3):
        if d[a] != 0.0:
            inv = 1.0 / d[a]
            ta = (lo[a] - o[a]) * inv
            tb = (hi[a] - o[a]) * inv
            if ta > tb:
                ta, tb = tb, ta
            if ta > t0:
                t0 = ta
                axis = a
            if tb < t1:
                t1 = tb
        elif o[a] < lo[a] or o[a] > hi[a]:
            return 1.0, 0.0, -1
    return t0, t1, axis


@nb.njit(cache=True, inline="always")
def _plane_t(o, d, a, lo, size, idx, step):
    """t where the ray leaves cell idx along axis a (inf when the ray is parallel to that axis' planes).
    Computed from the boundary's position each time, not accumulated, so long walks do not drift."""
    if step == 0:
        return np.inf
    edge = idx + 1 if step > 0 else idx
    return (lo[a] + edge * size[a] - o[a]) / d[a]


@nb.njit(cache=True, inline="always")
def _walk_start(o, d, t0, lo, size, dims, idx, step, tnext):
    """3D-DDA set-up (the course's initializeRayMarch): the cell holding o + t0 d, the step direction along
    each axis and the t of the next boundary along each axis."""
    for a in range(3):
        idx[a] = _index(o[a] + t0 * d[a], lo[a], size[a], dims[a])
        step[a] = 1 if d[a] > 0.0 else (-1 if d[a] < 0.0 else 0)
        tnext[a] = _plane_t(o, d, a, lo, size, idx[a], step[a])


@nb.njit(cache=True, inline="always")
def _walk_axis(tnext):
    """The axis whose boundary the ray meets first (the lowest axis on a tie): the current cell ends there."""
    a = 0
    if tnext[1] < tnext[a]:
        a = 1
    if tnext[2] < tnext[a]:
        a = 2
    return a


@nb.njit(cache=True, inline="always")
def _walk_next(o, d, lo, size, dims, idx, step, tnext, a):
    """Step into the next cell across axis a (the course's nextCell); False once the walk leaves the grid."""
    idx[a] += step[a]
    if idx[a] < 0 or idx[a] >= dims[a]:
        return False
    tnext[a] = _plane_t(o, d, a, lo, size, idx[a], step[a])
    return True


@nb.njit(cache=True)
def walk_cells(o, d, t_min, t_max, lo, box, size, dims, cells, t_enter, axis_enter):
    """The cells one ray visits, in order, as every kernel here walks them: fills cells (K,3) with their
    (i, j, k), t_enter (K,) with the t where the ray enters each and axis_enter (K,) with the axis of the face
    it enters through (-1 for a first cell the ray starts in); returns how many (at most K) were written."""
    t0, t1, axis = _clip(o, d, box[0], box[1], t_min, t_max)
    if not (t0 <= t1 and t0 > -np.inf and t1 < np.inf):
        return 0
    idx = np.empty(3, dtype=np.int64)
    step = np.empty(3, dtype=np.int64)
    tnext = np.empty(3)
    _walk_start(o, d, t0, lo, size, dims, idx, step, tnext)
    n = 0
    t = t0
    while n < cells.shape[0]:
        cells[n, 0], cells[n, 1], cells[n, 2] = idx[0], idx[1], idx[2]
        t_enter[n] = t
        axis_enter[n] = axis
        n += 1
        a = _walk_axis(tnext)
        t = tnext[a]
        axis = a
        if t >= t1 or not _walk_next(o, d, lo, size, dims, idx, step, tnext, a):
            break
    return n


@nb.njit(cache=True, inline="always")
def _cell_index(idx, dims):
    """Flat index of cell (i, j, k) = idx: x fastest, then y, then z."""
    return (idx[2] * dims[1] + idx[1]) * dims[0] + idx[0]


@nb.njit(cache=True, parallel=True)
def closest_hit_grid(origins, directions, t_min, t_max, lo, box, size, dims, start, items,
                     tris, sph_center, sph_radius, sph_w2o, pl_normal, pl_offset,
                     t_out, kind_out, prim_out, u_out, v_out, count, n_tests, n_cells):
    """Closest hit of every ray (the outputs of kernels.brute.closest_hit_all), parallel over rays."""
    for r in nb.prange(origins.shape[0]):
        o = origins[r]
        d = directions[r]
        tlo = t_min[r]
        best = t_max[r]
        bkind, bprim, bu, bv = MISS, -1, 0.0, 0.0
        tests = 0
        cells = 0
        # unbounded primitives beside the grid
        for k in range(pl_offset.shape[0]):
            nrm = pl_normal[k]
            t = intersect_plane(o[0], o[1], o[2], d[0], d[1], d[2], nrm[0], nrm[1], nrm[2], pl_offset[k], tlo,
                                np.nextafter(best, np.inf))
            tests += 1
            if _better(t, PLANE, k, best, bkind, bprim):
                best, bkind, bprim = t, PLANE, k
        t0, t1, _ = _clip(o, d, box[0], box[1], tlo, t_max[r])
        if items.shape[0] > 0 and t0 <= t1 and t0 > -np.inf and t1 < np.inf:
            slack = SLACK * (t1 - t0 + 1e-300)
            idx = np.empty(3, dtype=np.int64)
            step = np.empty(3, dtype=np.int64)
            tnext = np.empty(3)
            _walk_start(o, d, t0, lo, size, dims, idx, step, tnext)
            while True:
                cells += 1
                c = _cell_index(idx, dims)
                for p in range(start[c], start[c + 1]):
                    item = items[p]
                    tests += 1
                    cap = np.nextafter(best, np.inf)  # equal t must reach _better, for the tie rule
                    if item >= 0:
                        t, u, v = intersect_triangle(o[0], o[1], o[2], d[0], d[1], d[2], tris[item], tlo, cap)
                        if _better(t, TRIANGLE, item, best, bkind, bprim):
                            best, bkind, bprim, bu, bv = t, TRIANGLE, item, u, v
                    else:
                        s = -item - 1
                        t = sphere_hit_in_object_space(o, d, sph_center[s], sph_radius[s], sph_w2o[s], tlo, cap)
                        if _better(t, SPHERE, s, best, bkind, bprim):
                            best, bkind, bprim, bu, bv = t, SPHERE, s, 0.0, 0.0
                a = _walk_axis(tnext)
                # early exit: the best hit lies inside the cells walked so far, so no later cell can beat it
                if best < tnext[a] - slack or tnext[a] >= t1:
                    break
                if not _walk_next(o, d, lo, size, dims, idx, step, tnext, a):
                    break
        if bkind == MISS:
            t_out[r] = np.inf
        else:
            t_out[r] = best
        kind_out[r] = bkind
        prim_out[r] = bprim
        u_out[r] = bu
        v_out[r] = bv
        if count:
            n_tests[r] = tests
            n_cells[r] = cells


@nb.njit(cache=True, parallel=True)
def any_hit_grid(origins, directions, t_min, t_max, lo, box, size, dims, start, items,
                 tris, sph_center, sph_radius, sph_w2o, pl_normal, pl_offset, out, count, n_tests, n_cells):
    """out[r] = True when ray r hits anything with t_min < t < t_max; stops at the first hit found."""
    for r in nb.prange(origins.shape[0]):
        o = origins[r]
        d = directions[r]
        tlo = t_min[r]
        thi = t_max[r]
        hit = False
        tests = 0
        cells = 0
        for k in range(pl_offset.shape[0]):
            nrm = pl_normal[k]
            tests += 1
            if intersect_plane(o[0], o[1], o[2], d[0], d[1], d[2], nrm[0], nrm[1], nrm[2], pl_offset[k],
                               tlo, thi) < np.inf:
                hit = True
                break
        t0, t1, _ = _clip(o, d, box[0], box[1], tlo, thi)
        if not hit and items.shape[0] > 0 and t0 <= t1 and t0 > -np.inf and t1 < np.inf:
            idx = np.empty(3, dtype=np.int64)
            step = np.empty(3, dtype=np.int64)
            tnext = np.empty(3)
            _walk_start(o, d, t0, lo, size, dims, idx, step, tnext)
            while not hit:
                cells += 1
                c = _cell_index(idx, dims)
                for p in range(start[c], start[c + 1]):
                    item = items[p]
                    tests += 1
                    if item >= 0:
                        t, _, _ = intersect_triangle(o[0], o[1], o[2], d[0], d[1], d[2], tris[item], tlo, thi)
                    else:
                        s = -item - 1
                        t = sphere_hit_in_object_space(o, d, sph_center[s], sph_radius[s], sph_w2o[s], tlo, thi)
                    if t < np.inf:
                        hit = True
                        break
                a = _walk_axis(tnext)
                if tnext[a] >= t1 or not _walk_next(o, d, lo, size, dims, idx, step, tnext, a):
                    break
        out[r] = hit
        if count:
            n_tests[r] = tests
            n_cells[r] = cells


@nb.njit(cache=True, parallel=True)
def first_occupied_cell(origins, directions, t_min, lo, box, size, dims, start,
                        t_out, axis_out, count_out, n_cells):
    """For -visualize_grid: where each ray enters the first cell holding any primitive.

    t_out is the entry t (inf when no occupied cell is met), axis_out the axis of the face crossed to enter it
    (the grid box's face for the first cell; -1 if the ray starts inside), count_out its number of primitives.
    n_cells (one per ray, or empty) receives the cells visited.
    """
    count = n_cells.shape[0] > 0
    for r in nb.prange(origins.shape[0]):
        o = origins[r]
        d = directions[r]
        t_out[r] = np.inf
        axis_out[r] = -1
        count_out[r] = 0
        cells = 0
        t0, t1, axis = _clip(o, d, box[0], box[1], t_min[r], np.inf)
        if t0 <= t1 and t0 > -np.inf and t1 < np.inf:
            idx = np.empty(3, dtype=np.int64)
            step = np.empty(3, dtype=np.int64)
            tnext = np.empty(3)
            _walk_start(o, d, t0, lo, size, dims, idx, step, tnext)
            t_enter = t0
            while True:
                cells += 1
                c = _cell_index(idx, dims)
                n = start[c + 1] - start[c]
                if n > 0:
                    t_out[r] = t_enter
                    axis_out[r] = axis
                    count_out[r] = n
                    break
                a = _walk_axis(tnext)
                t_enter = tnext[a]
                axis = a
                if t_enter >= t1 or not _walk_next(o, d, lo, size, dims, idx, step, tnext, a):
                    break
        if count:
            n_cells[r] = cells
