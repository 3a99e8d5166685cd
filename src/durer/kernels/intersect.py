"""Ray-primitive intersection tests (Numba), each returning the ray parameter t of its hit or inf.

A hit counts when t_min < t < t_max. Directions are not assumed unit length, so t is in the ray's own units.
These are the per-primitive building blocks; closest_hit_all loops over every primitive (the lecture's
"for every object"), and the BVH in kernels/bvh.py calls the same tests.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

INF = np.inf


@nb.njit(cache=True, inline="always")
def intersect_sphere(ox, oy, oz, dx, dy, dz, cx, cy, cz, r, t_min, t_max):
    """Smallest root t of |o + t d - c| = r with t_min < t < t_max (the algebraic method of the lecture)."""
    px, py, pz = ox - cx, oy - cy, oz - cz
    a = dx * dx + dy * dy + dz * dz
    b = px * dx + py * dy + pz * dz  # half of the lecture's b
    c = px * px + py * py + pz * pz - r * r
    disc = b * b - a * c
    if disc < 0.0 or a == 0.0:
        return INF
    sq = math.sqrt(disc)
    # numerically stable pair of roots
    q = -(b + sq) if b >= 0.0 else -(b - sq)
    if q == 0.0:
        t0 = t1 = 0.0
    else:
        t0 = q / a
        t1 = c / q
    if t0 > t1:
        t0, t1 = t1, t0
    if t_min < t0 < t_max:
        return t0
    if t_min < t1 < t_max:
        return t1
    return INF


@nb.njit(cache=True, inline="always")
def intersect_plane(ox, oy, oz, dx, dy, dz, nx, ny, nz, offset, t_min, t_max):
    """t where dot(o + t d, n) = offset; a ray parallel to the plane misses it."""
    denom = nx * dx + ny * dy + nz * dz
    if denom == 0.0:
        return INF
    t = (offset - (nx * ox + ny * oy + nz * oz)) / denom
    if t_min < t < t_max:
        return t
    return INF


@nb.njit(cache=True, inline="always")
def intersect_triangle(ox, oy, oz, dx, dy, dz, tri, t_min, t_max):
    """Moller-Trumbore: (t, u, v) of the hit with barycentrics u, v (weights of vertex1, vertex2), or t = inf."""
    ax, ay, az = tri[0, 0], tri[0, 1], tri[0, 2]
    e1x, e1y, e1z = tri[1, 0] - ax, tri[1, 1] - ay, tri[1, 2] - az
    e2x, e2y, e2z = tri[2, 0] - ax, tri[2, 1] - ay, tri[2, 2] - az
    px = dy * e2z - dz * e2y
    py = dz * e2x - dx * e2z
    pz = dx * e2y - dy * e2x
    det = e1x * px + e1y * py + e1z * pz
    if det == 0.0:
        return INF, 0.0, 0.0
    inv = 1.0 / det
    sx, sy, sz = ox - ax, oy - ay, oz - az
    u = (sx * px + sy * py + sz * pz) * inv
    if u < 0.0 or u > 1.0:
        return INF, 0.0, 0.0
    qx = sy * e1z - sz * e1y
    qy = sz * e1x - sx * e1z
    qz = sx * e1y - sy * e1x
    v = (dx * qx + dy * qy + dz * qz) * inv
    if v < 0.0 or u + v > 1.0:
        return INF, 0.0, 0.0
    t = (e2x * qx + e2y * qy + e2z * qz) * inv
    if t_min < t < t_max:
        return t, u, v
    return INF, 0.0, 0.0


@nb.njit(cache=True, inline="always")
def sphere_hit_in_object_space(o, d, center, radius, w2o, t_min, t_max):
    """Intersect a sphere seen through the affine world-to-object matrix w2o (3x4); t stays in world units."""
    ox = w2o[0, 0] * o[0] + w2o[0, 1] * o[1] + w2o[0, 2] * o[2] + w2o[0, 3]
    oy = w2o[1, 0] * o[0] + w2o[1, 1] * o[1] + w2o[1, 2] * o[2] + w2o[1, 3]
    oz = w2o[2, 0] * o[0] + w2o[2, 1] * o[1] + w2o[2, 2] * o[2] + w2o[2, 3]
    dx = w2o[0, 0] * d[0] + w2o[0, 1] * d[1] + w2o[0, 2] * d[2]
    dy = w2o[1, 0] * d[0] + w2o[1, 1] * d[1] + w2o[1, 2] * d[2]
    dz = w2o[2, 0] * d[0] + w2o[2, 1] * d[1] + w2o[2, 2] * d[2]
    return intersect_sphere(ox, oy, oz, dx, dy, dz, center[0], center[1], center[2], radius, t_min, t_max)
