"""What a closest hit means for the surface, one pass over the hits: the hit point, the geometric normal and the
shading normal (unit, as the surface defines them, not flipped to the ray; the shading normal is the geometric one,
or on a mesh with vertex normals their barycentric interpolation at the hit, as Mitsuba shades) and the material
slot. The same definitions as
accel/hits.geometric_normals and hit_materials, fused for the path tracer, on a scene without instances
(CompiledScene.flat)."""

from __future__ import annotations

import math

import numba as nb

from ..common import CYLINDER_CODE, DISK_CODE, JIT, PLANE, SPHERE, TRIANGLE


@nb.njit(**JIT, inline="always")
def surface_at(px, py, pz, k, j, tris, tri_mat, w2o, center, radius, normal_matrix, sph_mat, plane_normal,
               plane_mat, tri_n):
    """The unit geometric and shading normals and the material slot at point p of a hit of kind k on primitive j:
    (gx, gy, gz, sx, sy, sz, slot), zeros and -1 on a miss. tri_n (F, 3, 3): unit world vertex normals of each
    triangle's corners (zero rows: the triangle is flat; fewer rows than triangles, e.g. none: every triangle is
    flat). Inlined into hit_surfaces and the path tracer's fused bounce."""
    nx = ny = nz = 0.0
    s = -1
    if k == TRIANGLE:
        ax, ay, az = tris[j, 1, 0] - tris[j, 0, 0], tris[j, 1, 1] - tris[j, 0, 1], tris[j, 1, 2] - tris[j, 0, 2]
        bx, by, bz = tris[j, 2, 0] - tris[j, 0, 0], tris[j, 2, 1] - tris[j, 0, 1], tris[j, 2, 2] - tris[j, 0, 2]
        nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
        s = tri_mat[j]
        ln = math.sqrt(nx * nx + ny * ny + nz * nz)
        if ln > 0:
            nx, ny, nz = nx / ln, ny / ln, nz / ln
        if j < tri_n.shape[0] and (tri_n[j, 0, 0] != 0 or tri_n[j, 0, 1] != 0 or tri_n[j, 0, 2] != 0):
            qx, qy, qz = px - tris[j, 0, 0], py - tris[j, 0, 1], pz - tris[j, 0, 2]
            d11, d12, d22 = ax * ax + ay * ay + az * az, ax * bx + ay * by + az * bz, bx * bx + by * by + bz * bz
            q1, q2 = qx * ax + qy * ay + qz * az, qx * bx + qy * by + qz * bz
            det = d11 * d22 - d12 * d12
            if det > 0:
                b1, b2 = (d22 * q1 - d12 * q2) / det, (d11 * q2 - d12 * q1) / det
                b0 = 1.0 - b1 - b2
                sx = b0 * tri_n[j, 0, 0] + b1 * tri_n[j, 1, 0] + b2 * tri_n[j, 2, 0]
                sy = b0 * tri_n[j, 0, 1] + b1 * tri_n[j, 1, 1] + b2 * tri_n[j, 2, 1]
                sz = b0 * tri_n[j, 0, 2] + b1 * tri_n[j, 1, 2] + b2 * tri_n[j, 2, 2]
                ls = math.sqrt(sx * sx + sy * sy + sz * sz)
                if ls > 1e-12:
                    return nx, ny, nz, sx / ls, sy / ls, sz / ls, s
    elif k == SPHERE:
        qx = w2o[j, 0, 0] * px + w2o[j, 0, 1] * py + w2o[j, 0, 2] * pz + w2o[j, 0, 3] - center[j, 0]
        qy = w2o[j, 1, 0] * px + w2o[j, 1, 1] * py + w2o[j, 1, 2] * pz + w2o[j, 1, 3] - center[j, 1]
        qz = w2o[j, 2, 0] * px + w2o[j, 2, 1] * py + w2o[j, 2, 2] * pz + w2o[j, 2, 3] - center[j, 2]
        if radius[j] == DISK_CODE:  # analytic shapes (kernels/common.py): the disk's +z, the cylinder's radial
            qx, qy, qz = 0.0, 0.0, 1.0
        elif radius[j] == CYLINDER_CODE:
            qz = 0.0
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
    return nx, ny, nz, nx, ny, nz, s


@nb.njit(**JIT)
def uv_at(px, py, pz, k, j, tris, tri_uv, w2o, center, radius):
    """Texture coordinates and their derivatives at point p of a hit of kind k on primitive j: (u, v, dp/du (3),
    dp/dv (3)), as Mitsuba's shapes define them (dp/du also orients anisotropic BSDFs: warps.tangent_frame3).
    Triangles: barycentric UVs, dp/du and dp/dv from the edges and UV differences (zeros where the UVs are
    degenerate); a triangle without UVs (all zero, or fewer rows than triangles) has (u, v) = 0 (what a texture
    reads on Mitsuba's sdfgrid; textures on other meshes without UVs are refused at load) and Mitsuba's barycentric
    derivatives, its edges (Mitsuba's UVs are then (b1, b2)), which orient anisotropic BSDFs as Mitsuba's do.
    Analytic shapes (kind SPHERE, the shape code in `radius`): Mitsuba's parametrisations of the object-space point
    q, phi = atan2(qy, qx) in [0, 2 pi): spheres (phi / 2 pi, theta / pi), disks (r, phi / 2 pi), cylinders
    (phi / 2 pi, qz), derivatives taken to world space. Planes and misses: zeros."""
    if k == SPHERE:
        m = w2o[j]
        qx = m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3]
        qy = m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3]
        qz = m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3]
        code = radius[j]
        if code > 0:
            qx, qy, qz = qx - center[j, 0], qy - center[j, 1], qz - center[j, 2]
        phi = math.atan2(qy, qx)
        if phi < 0:
            phi += 2.0 * math.pi
        c, s = math.cos(phi), math.sin(phi)
        two_pi = 2.0 * math.pi
        if code == DISK_CODE:
            r = math.sqrt(qx * qx + qy * qy)
            u, v = r, phi / two_pi
            du, dv = (c, s, 0.0), (-qy * two_pi, qx * two_pi, 0.0)
        elif code == CYLINDER_CODE:
            u, v = phi / two_pi, qz
            du, dv = (-qy * two_pi, qx * two_pi, 0.0), (0.0, 0.0, 1.0)
        else:
            r = max(math.sqrt(qx * qx + qy * qy + qz * qz), 1e-300)
            theta = math.acos(min(max(qz / r, -1.0), 1.0))
            u, v = phi / two_pi, theta / math.pi
            du = (-qy * two_pi, qx * two_pi, 0.0)
            dv = (qz * c * math.pi, qz * s * math.pi, -r * math.sin(theta) * math.pi)
        # object -> world is the inverse of w2o's linear part: its adjugate over its determinant
        c00, c01, c02 = m[1, 1] * m[2, 2] - m[1, 2] * m[2, 1], m[0, 2] * m[2, 1] - m[0, 1] * m[2, 2], \
            m[0, 1] * m[1, 2] - m[0, 2] * m[1, 1]
        c10, c11, c12 = m[1, 2] * m[2, 0] - m[1, 0] * m[2, 2], m[0, 0] * m[2, 2] - m[0, 2] * m[2, 0], \
            m[0, 2] * m[1, 0] - m[0, 0] * m[1, 2]
        c20, c21, c22 = m[1, 0] * m[2, 1] - m[1, 1] * m[2, 0], m[0, 1] * m[2, 0] - m[0, 0] * m[2, 1], \
            m[0, 0] * m[1, 1] - m[0, 1] * m[1, 0]
        det = m[0, 0] * c00 + m[0, 1] * c10 + m[0, 2] * c20
        if det == 0:
            return u, v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        inv = 1.0 / det
        return (u, v, (c00 * du[0] + c01 * du[1] + c02 * du[2]) * inv, (c10 * du[0] + c11 * du[1] + c12 * du[2]) * inv,
                (c20 * du[0] + c21 * du[1] + c22 * du[2]) * inv, (c00 * dv[0] + c01 * dv[1] + c02 * dv[2]) * inv,
                (c10 * dv[0] + c11 * dv[1] + c12 * dv[2]) * inv, (c20 * dv[0] + c21 * dv[1] + c22 * dv[2]) * inv)
    if k != TRIANGLE:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    ax, ay, az = tris[j, 1, 0] - tris[j, 0, 0], tris[j, 1, 1] - tris[j, 0, 1], tris[j, 1, 2] - tris[j, 0, 2]
    bx, by, bz = tris[j, 2, 0] - tris[j, 0, 0], tris[j, 2, 1] - tris[j, 0, 1], tris[j, 2, 2] - tris[j, 0, 2]
    qx, qy, qz = px - tris[j, 0, 0], py - tris[j, 0, 1], pz - tris[j, 0, 2]
    d11, d12, d22 = ax * ax + ay * ay + az * az, ax * bx + ay * by + az * bz, bx * bx + by * by + bz * bz
    q1, q2 = qx * ax + qy * ay + qz * az, qx * bx + qy * by + qz * bz
    det = d11 * d22 - d12 * d12
    b1 = b2 = 0.0
    if det > 0:
        b1, b2 = (d22 * q1 - d12 * q2) / det, (d11 * q2 - d12 * q1) / det
    if j >= tri_uv.shape[0] or (tri_uv[j, 0, 0] == 0 and tri_uv[j, 0, 1] == 0 and tri_uv[j, 1, 0] == 0
                                and tri_uv[j, 1, 1] == 0 and tri_uv[j, 2, 0] == 0 and tri_uv[j, 2, 1] == 0):
        return 0.0, 0.0, ax, ay, az, bx, by, bz  # no UVs: Mitsuba's barycentric derivatives, (u, v) = 0
    b0 = 1.0 - b1 - b2
    u = b0 * tri_uv[j, 0, 0] + b1 * tri_uv[j, 1, 0] + b2 * tri_uv[j, 2, 0]
    v = b0 * tri_uv[j, 0, 1] + b1 * tri_uv[j, 1, 1] + b2 * tri_uv[j, 2, 1]
    du0, dv0 = tri_uv[j, 1, 0] - tri_uv[j, 0, 0], tri_uv[j, 1, 1] - tri_uv[j, 0, 1]
    du1, dv1 = tri_uv[j, 2, 0] - tri_uv[j, 0, 0], tri_uv[j, 2, 1] - tri_uv[j, 0, 1]
    d = du0 * dv1 - dv0 * du1
    if d == 0:
        return u, v, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    inv = 1.0 / d
    return (u, v, (dv1 * ax - dv0 * bx) * inv, (dv1 * ay - dv0 * by) * inv, (dv1 * az - dv0 * bz) * inv,
            (du0 * bx - du1 * ax) * inv, (du0 * by - du1 * ay) * inv, (du0 * bz - du1 * az) * inv)


@nb.njit(**JIT)
def hit_surfaces(o, d, t, kind, prim, tris, tri_mat, w2o, center, radius, normal_matrix, sph_mat, plane_normal,
                 plane_mat, tri_n, tri_uv, p, ng, ns, uvd, slot, i0, i1):
    """p = o + t d (o on a miss), ng and ns (geometric and shading normals) and slot (-1, normals 0 on a miss) of
    hits i0..i1. tris
    (F, 3, 3) world triangles; analytic shapes: world-to-object (S, 3, 4), object centre (S, 3), radius or shape
    code (S,), normal matrix (S, 3, 3);
    planes' unit normals; the *_mat arrays their material slots; tri_n the triangles' vertex normals (surface_at);
    uvd (n, 8) uv_at's texture coordinates and derivatives from the corners' tri_uv (F, 3, 2)."""
    for i in range(i0, i1):
        k = kind[i]
        h = t[i] if k == TRIANGLE or k == SPHERE or k == PLANE else 0.0
        px, py, pz = o[i, 0] + h * d[i, 0], o[i, 1] + h * d[i, 1], o[i, 2] + h * d[i, 2]
        p[i, 0], p[i, 1], p[i, 2] = px, py, pz
        gx, gy, gz, sx, sy, sz, slot[i] = surface_at(px, py, pz, k, prim[i], tris, tri_mat, w2o, center, radius,
                                                     normal_matrix, sph_mat, plane_normal, plane_mat, tri_n)
        ng[i, 0], ng[i, 1], ng[i, 2] = gx, gy, gz
        ns[i, 0], ns[i, 1], ns[i, 2] = sx, sy, sz
        r = uv_at(px, py, pz, k, prim[i], tris, tri_uv, w2o, center, radius)
        for c in range(8):
            uvd[i, c] = r[c]
