"""The query API's shading normals: a mesh's vertex normals kept per triangle corner, and what cast_rays returns as
primitive_normals with primitive_normals="interpolated": their barycentric mix at each hit, taken to world space by
the geometry's transform and made unit (Mitsuba's shading normal, si.sh_frame.n). The default, "face", is Open3D's:
the triangle's own unit normal by its winding (Mitsuba's si.n)."""

from __future__ import annotations

import numpy as np

from .query_args import array

MODES = ("face", "interpolated")


def check_mode(mode: str) -> str:
    if mode not in MODES:
        raise ValueError(f"primitive_normals must be 'face' (Open3D's) or 'interpolated' (the mesh's vertex normals "
                         f"mixed at the hit, as Mitsuba shades), got {mode!r}")
    return mode


def vertex_normals(mesh) -> np.ndarray | None:
    """(V, 3) vertex normals of an Open3D triangle mesh (tensor-based or legacy) or a trimesh mesh that has them
    (trimesh: read from the file or given, or computed already: durer does not make trimesh compute them); None
    for anything else."""
    module = type(mesh).__module__ or ""
    if module.startswith("open3d"):
        if hasattr(mesh, "vertex"):  # open3d.t.geometry.TriangleMesh
            return array(mesh.vertex["normals"]) if "normals" in mesh.vertex else None
        if getattr(mesh, "has_vertex_normals", lambda: False)():
            return np.asarray(mesh.vertex_normals)
        return None
    cache = getattr(mesh, "_cache", None)
    if cache is not None and "vertex_normals" in cache:
        return np.asarray(mesh.vertex_normals)
    return None


def corner_normals(normals, triangles: np.ndarray, count: int) -> np.ndarray:
    """(F, 3, 3) unit object-space normals of each triangle's corners from (V, 3) vertex normals (count = V);
    zero rows where a vertex normal is zero. ValueError for a wrong shape or non-finite values."""
    n = np.asarray(array(normals), dtype=np.float64)
    if n.shape != (count, 3):
        raise ValueError(f"vertex_normals must have shape ({count}, 3) (one per vertex), got {n.shape}")
    if not np.isfinite(n).all():
        raise ValueError("vertex_normals must be finite")
    c = n[triangles]
    length = np.linalg.norm(c, axis=2, keepdims=True)
    return np.divide(c, length, out=np.zeros_like(c), where=length > 0)


def interpolate(out: dict, corners: dict, instances: list) -> None:
    """Replace out["primitive_normals"] (cast's flat arrays, geometry ids still -1 on a miss) on hits of meshes with
    corner normals (corners: shape index -> (F, 3, 3)) by the barycentric mix of their corners at
    out["primitive_uvs"] (weights of vertex 1 and 2), the corners taken to world space first (the inverse
    transpose of the instance's matrix) and made unit there, as Mitsuba does; a mix of zero length keeps the face
    normal."""
    geometry, prim, uv, normals = (out["geometry_ids"], out["primitive_ids"], out["primitive_uvs"],
                                   out["primitive_normals"])
    for g in np.unique(geometry[geometry >= 0]):
        shape, matrix = instances[int(g)]
        if shape not in corners:
            continue
        rows = np.flatnonzero(geometry == g)
        c = corners[shape][prim[rows]] @ np.linalg.inv(matrix[:3, :3])  # (M^-1)^T n, row by row
        length = np.linalg.norm(c, axis=2, keepdims=True)
        c = np.divide(c, length, out=np.zeros_like(c), where=length > 0)  # unit in world space, as Mitsuba's
        u, v = (uv[rows, k].astype(np.float64)[:, None] for k in (0, 1))
        n = (1.0 - u - v) * c[:, 0] + u * c[:, 1] + v * c[:, 2]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        ok = length[:, 0] > 0
        normals[rows[ok]] = (n[ok] / length[ok]).astype(normals.dtype)
