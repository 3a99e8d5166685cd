"""Ray-primitive intersection tests (Numba), each returning the ray parameter t of its hit or inf.

A hit counts when t_min < t < t_max. Directions are not assumed unit length, so t is in the ray's own units.
These are the per-primitive building blocks; closest_hit_all loops over every primitive (the lecture's
"for every object"), and the BVH in kernels/bvh.py calls the same tests.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from .common import DISK_CODE

INF = np.inf
_U3, _U6 = np.uint64(3), np.uint64(6)
EDGE_ON = 2.0 ** -49  # edge_on's factor: 16 units of float64 rounding, twice the first-order bound's 8


@nb.njit(cache=True, inline="always")
def ordered_roots(a, b, c):
    """(real, t0, t1): the roots t0 <= t1 of a t^2 + 2 b t + c = 0 in the numerically stable pair q / a, c / q with
    q = -(b + sign(b) sqrt(b^2 - a c)); real is False (roots inf) when there are none or a = 0, and q = 0 gives
    t0 = t1 = 0. Shared by the sphere and the cylinder."""
    disc = b * b - a * c
    if disc < 0.0 or a == 0.0:
        return False, INF, INF
    sq = math.sqrt(disc)
    q = -(b + sq) if b >= 0.0 else -(b - sq)
    if q == 0.0:
        return True, 0.0, 0.0
    t0, t1 = q / a, c / q
    if t0 > t1:
        t0, t1 = t1, t0
    return True, t0, t1


@nb.njit(cache=True, inline="always")
def intersect_sphere(ox, oy, oz, dx, dy, dz, cx, cy, cz, r, t_min, t_max):
    """Smallest root t of |o + t d - c| = r with t_min < t < t_max (the algebraic method of the lecture)."""
    px, py, pz = ox - cx, oy - cy, oz - cz
    a = dx * dx + dy * dy + dz * dz
    b = px * dx + py * dy + pz * dz  # half of the lecture's b
    c = px * px + py * py + pz * pz - r * r
    real, t0, t1 = ordered_roots(a, b, c)
    if not real:
        return INF
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


@nb.njit(cache=True, inline="always", error_model="numpy")
def shear_axes(dx, dy, dz):
    """The watertight test's axis permutation (kx, ky, kz): z is the direction's largest component, and x, y
    are swapped when that component is negative, which keeps the triangles' winding."""
    ax, ay, az = abs(dx), abs(dy), abs(dz)
    if ax >= ay and ax >= az:
        kz = 0
    elif ay >= az:
        kz = 1
    else:
        kz = 2
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    dkz = dx if kz == 0 else (dy if kz == 1 else dz)
    if dkz < 0.0:
        kx, ky = ky, kx
    return kx, ky, kz


@nb.njit(cache=True, inline="always", error_model="numpy")
def ray_shear(dx, dy, dz):
    """Per-ray constants of the watertight test: the axis permutation of shear_axes and the shear sx, sy, sz
    that maps the direction onto (0, 0, 1)."""
    kx, ky, kz = shear_axes(dx, dy, dz)
    d = (dx, dy, dz)
    dkz = d[kz]
    return kx, ky, kz, d[kx] / dkz, d[ky] / dkz, 1.0 / dkz


@nb.njit(cache=True, inline="always", error_model="numpy")
def edge_sign(e, px, py, qx, qy):
    """Whether the edge function e of the sheared edge p -> q (e = qx py - qy px) counts as positive, a zero
    decided as if the ray were moved by (eps, eps^2) in the sheared frame: e then becomes eps (qy - py) -
    eps^2 (qx - px), positive iff q lies above p, or level with it and to its left. The two triangles sharing an
    edge traverse it in opposite directions and compute the same e with opposite sign, so a ray on the edge is
    inside exactly one of them; all tests of one ray move it the same way, so a ray through a vertex is inside
    exactly one triangle of a fan around it. Comparisons only: exact for any float (no rounding to disagree on)."""
    return e > 0.0 or (e == 0.0 and (qy > py or (qy == py and qx < px)))


@nb.njit(cache=True, inline="always")
def edge_tie(e0, e1, e2, ax, ay, bx, by, cx, cy):
    """Whether a ray on an edge or a vertex of the sheared triangle (some edge function exactly 0, none of the
    others of another sign) counts as inside it: edge_sign's tie-break, on all three edges. Two edge functions of
    0 put the ray on their common vertex only when that vertex is at the sheared origin; otherwise the triangle is
    edge-on (its three vertices on one line through the ray, the third edge function a rounding leftover) and its
    "hit" would be a point off the triangle: missed, as an edge-on triangle is. Scalars only, so the packet walks'
    copies of the test inline it without reference counts."""
    if e1 == 0.0 and e2 == 0.0 and (ax != 0.0 or ay != 0.0):
        return False
    if e2 == 0.0 and e0 == 0.0 and (bx != 0.0 or by != 0.0):
        return False
    if e0 == 0.0 and e1 == 0.0 and (cx != 0.0 or cy != 0.0):
        return False
    s0 = edge_sign(e0, bx, by, cx, cy)
    return s0 == edge_sign(e1, cx, cy, ax, ay) and s0 == edge_sign(e2, ax, ay, bx, by)


@nb.njit(cache=True, inline="always")
def edge_on(det, ax, ay, az, bx, by, bz, cx, cy, cz, sx, sy):
    """Whether the determinant det = e0 + e1 + e2 of the sheared triangle is 0 up to its rounding: the ray lies in
    the triangle's plane (an edge-on triangle, whose sheared vertices lie on one line through the origin), and the
    edge functions are leftovers of rounding that may share a sign and pass for a hit off the triangle. Each sheared
    coordinate (x = (X - o) - s z) is within 2u (|x| + 2 |s z|) of its exact value (u = 2^-53, the shear's and the
    subtraction's roundings, those of s and z included), so det is within 8u B of its exact value, B summing
    |P Q'| + |P' Q| over the three edges' vertex pairs (P, Q those bounds of x and y). Beyond that bound the
    triangle's projected area is real, so a genuine hit is missed only at a grazing sine below ~1e-15 (its t the
    quotient of two rounding errors anyway). Scalars only, so the packet walks' copies of the test inline it."""
    tx, ty = 2.0 * abs(sx), 2.0 * abs(sy)
    pa, qa = abs(ax) + tx * abs(az), abs(ay) + ty * abs(az)
    pb, qb = abs(bx) + tx * abs(bz), abs(by) + ty * abs(bz)
    pc, qc = abs(cx) + tx * abs(cz), abs(cy) + ty * abs(cz)
    return abs(det) <= EDGE_ON * ((pc * qb + pb * qc) + (pa * qc + pc * qa) + (pb * qa + pa * qb))


@nb.njit(cache=True, inline="always", error_model="numpy")
def watertight_triangle(tri, base, okx, oky, okz, kx, ky, kz, sx, sy, sz, t_min, t_max):
    """Woop, Benthin & Wald (2013): (t, u, v) of the hit, u, v the weights of vertex1 and vertex2, or t = inf.

    tri[base:base + 9] holds the vertices (v0 xyz, v1 xyz, v2 xyz); okx, oky, okz are the ray origin's
    coordinates permuted by ray_shear.
    Each vertex is moved into the ray's sheared frame on its own, so two triangles sharing an edge compute that
    edge's 2D edge function from identical numbers with exactly opposite sign: a ray can fall on the edge, never
    between. A ray exactly on an edge or a vertex (an edge function of 0) is decided by edge_sign, which gives
    the edge to exactly one of the triangles sharing it and the vertex to one triangle of its fan: each crossing
    of a closed mesh counts once (edge_tie). Edge-on and degenerate triangles (determinant 0 up to its rounding:
    edge_on) are missed. No fused multiply-add (fastmath is off), which would break that symmetry.
    """
    b = np.uint64(base)  # unsigned offsets: no negative-index wraparound on the loads
    ux, uy, uz = np.uint64(kx), np.uint64(ky), np.uint64(kz)
    az = tri[b + uz] - okz
    bz = tri[b + _U3 + uz] - okz
    cz = tri[b + _U6 + uz] - okz
    ax = (tri[b + ux] - okx) - sx * az
    ay = (tri[b + uy] - oky) - sy * az
    bx = (tri[b + _U3 + ux] - okx) - sx * bz
    by = (tri[b + _U3 + uy] - oky) - sy * bz
    cx = (tri[b + _U6 + ux] - okx) - sx * cz
    cy = (tri[b + _U6 + uy] - oky) - sy * cz
    e0 = cx * by - cy * bx
    e1 = ax * cy - ay * cx
    e2 = bx * ay - by * ax
    # mixed signs (the ray passes outside): one test of min and max instead of six branches, which mispredict
    # on incoherent rays
    if min(e0, min(e1, e2)) < 0.0 and max(e0, max(e1, e2)) > 0.0:
        return INF, 0.0, 0.0
    if (e0 == 0.0 or e1 == 0.0 or e2 == 0.0) and not edge_tie(e0, e1, e2, ax, ay, bx, by, cx, cy):  # (rare)
        return INF, 0.0, 0.0
    det = e0 + e1 + e2
    if edge_on(det, ax, ay, az, bx, by, bz, cx, cy, cz, sx, sy):  # (rare: det 0 up to rounding)
        return INF, 0.0, 0.0
    t = sz * (e0 * az + e1 * bz + e2 * cz) / det
    if t_min < t < t_max:
        return t, e1 / det, e2 / det
    return INF, 0.0, 0.0


@nb.njit(cache=True, inline="always", error_model="numpy")
def intersect_triangle(ox, oy, oz, dx, dy, dz, tri, t_min, t_max):
    """Watertight ray-triangle test for one (3, 3) triangle: (t, u, v), u, v the weights of vertex1, vertex2.

    Convenience form of watertight_triangle that derives the per-ray constants itself; the BVH computes them
    once per ray and calls watertight_triangle directly, so both give bit-identical results.
    """
    kx, ky, kz, sx, sy, sz = ray_shear(dx, dy, dz)
    o = (ox, oy, oz)
    return watertight_triangle(tri.reshape(9), 0, o[kx], o[ky], o[kz], kx, ky, kz, sx, sy, sz, t_min, t_max)


@nb.njit(cache=True, inline="always")
def intersect_disk(ox, oy, oz, dx, dy, dz, t_min, t_max):
    """t where the ray meets the unit disk x^2 + y^2 <= 1 of the plane z = 0 (Mitsuba's disk in object space)."""
    if dz == 0.0:
        return INF
    t = -oz / dz
    if not t_min < t < t_max:
        return INF
    x, y = ox + t * dx, oy + t * dy
    if x * x + y * y <= 1.0:
        return t
    return INF


@nb.njit(cache=True, inline="always")
def intersect_cylinder(ox, oy, oz, dx, dy, dz, t_min, t_max):
    """Nearest t with t_min < t < t_max where the ray meets the open cylinder x^2 + y^2 = 1, 0 <= z <= 1
    (Mitsuba's cylinder in object space: no caps, so the far wall shows through the ends)."""
    a = dx * dx + dy * dy
    b = ox * dx + oy * dy
    c = ox * ox + oy * oy - 1.0
    real, t0, t1 = ordered_roots(a, b, c)
    if not real or (t0 == 0.0 and t1 == 0.0):  # a tangent ray from the wall itself
        return INF
    if t_min < t0 < t_max and 0.0 <= oz + t0 * dz <= 1.0:
        return t0
    if t_min < t1 < t_max and 0.0 <= oz + t1 * dz <= 1.0:
        return t1
    return INF


@nb.njit(cache=True, inline="always")
def sphere_hit_in_object_space(o, d, center, radius, w2o, t_min, t_max):
    """Intersect an analytic shape seen through the affine world-to-object matrix w2o (3x4); t stays in world
    units. A positive radius is a sphere (an ellipsoid in the world); DISK_CODE and CYLINDER_CODE name the unit
    disk and cylinder (kernels/common.py)."""
    ox = w2o[0, 0] * o[0] + w2o[0, 1] * o[1] + w2o[0, 2] * o[2] + w2o[0, 3]
    oy = w2o[1, 0] * o[0] + w2o[1, 1] * o[1] + w2o[1, 2] * o[2] + w2o[1, 3]
    oz = w2o[2, 0] * o[0] + w2o[2, 1] * o[1] + w2o[2, 2] * o[2] + w2o[2, 3]
    dx = w2o[0, 0] * d[0] + w2o[0, 1] * d[1] + w2o[0, 2] * d[2]
    dy = w2o[1, 0] * d[0] + w2o[1, 1] * d[1] + w2o[1, 2] * d[2]
    dz = w2o[2, 0] * d[0] + w2o[2, 1] * d[1] + w2o[2, 2] * d[2]
    if radius > 0.0:
        return intersect_sphere(ox, oy, oz, dx, dy, dz, center[0], center[1], center[2], radius, t_min, t_max)
    if radius == DISK_CODE:
        return intersect_disk(ox, oy, oz, dx, dy, dz, t_min, t_max)
    return intersect_cylinder(ox, oy, oz, dx, dy, dz, t_min, t_max)
