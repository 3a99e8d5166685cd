"""What a closest hit means for the surface, one pass over the hits: the hit point, the geometric normal (unit,
as the surface defines it, not flipped to the ray) and the material slot. The same definitions as
accel/hits.geometric_normals and hit_materials, fused for the path tracer, on a scene without instances
(CompiledScene.flat)."""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT, PLANE, SPHERE, TRIANGLE


@nb.njit(**JIT, inline="always")
def surface_at(px, py, pz, k, j, tris, tri_mat, w2o, center, normal_matrix, sph_mat, plane_normal, plane_mat):
    """The unit geometric normal and material slot at point p of a hit of kind k on primitive j: (nx, ny, nz,
    slot), (0, 0, 0, -1) on a miss. Inlined into hit_surfaces and the path tracer's fused bounce."""
    nx = ny = nz = 0.0
    s = -1
    if k == TRIANGLE:
        ax, ay, az = tris[j, 1, 0] - tris[j, 0, 0], tris[j, 1, 1] - tris[j, 0, 1], tris[j, 1, 2] - tris[j, 0, 2]
        bx, by, bz = tris[j, 2, 0] - tris[j, 0, 0], tris[j, 2, 1] - tris[j, 0, 1], tris[j, 2, 2] - tris[j, 0, 2]
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        s = tri_mat[j]
    elif k == SPHERE:
        qx = w2o[j, 0, 0] * px + w2o[j, 0, 1] * py + w2o[j, 0, 2] * pz + w2o[j, 0, 3] - center[j, 0]
        qy = w2o[j, 1, 0] * px + w2o[j, 1, 1] * py + w2o[j, 1, 2] * pz + w2o[j, 1, 3] - center[j, 1]
        qz = w2o[j, 2, 0] * px + w2o[j, 2, 1] * py + w2o[j, 2, 2] * pz + w2o[j, 2, 3] - center[j, 2]
        m = normal_matrix
        nx = m[j, 0, 0] * qx + m[j, 0, 1] * qy + m[j, 0, 2] * qz
        ny = m[j, 1, 0] * qx + m[j, 1, 1] * qy + m[j, 1, 2] * qz
        nz = m[j, 2, 0] * qx + m[j, 2, 1] * qy + m[j, 2, 2] * qz
        s = sph_mat[j]
    elif k == PLANE:
        nx, ny, nz = plane_normal[j, 0], plane_normal[j, 1], plane_normal[j, 2]
        s = plane_mat[j]
    ln = math.sqrt(nx * nx + ny * ny + nz * nz)
    if ln > 0:
        nx, ny, nz = nx / ln, ny / ln, nz / ln
    return nx, ny, nz, s


@nb.njit(**JIT)
def hit_surfaces(o, d, t, kind, prim, tris, tri_mat, w2o, center, normal_matrix, sph_mat, plane_normal, plane_mat,
                 p, ng, slot, i0, i1):
    """p = o + t d (o on a miss), ng and slot (-1, normal 0 on a miss) of hits i0..i1. tris (F, 3, 3) world
    triangles; spheres: world-to-object (S, 3, 4), object centre (S, 3), normal matrix (S, 3, 3); planes' unit
    normals; the *_mat arrays their material slots."""
    for i in range(i0, i1):
        k = kind[i]
        h = t[i] if k == TRIANGLE or k == SPHERE or k == PLANE else 0.0
        px, py, pz = o[i, 0] + h * d[i, 0], o[i, 1] + h * d[i, 1], o[i, 2] + h * d[i, 2]
        p[i, 0], p[i, 1], p[i, 2] = px, py, pz
        ng[i, 0], ng[i, 1], ng[i, 2], slot[i] = surface_at(px, py, pz, k, prim[i], tris, tri_mat, w2o, center,
                                                           normal_matrix, sph_mat, plane_normal, plane_mat)
