"""The course's Wavefront OBJ subset (`v x y z`, `f i j k`), read with line-accurate errors.

General mesh files (PLY, STL, glTF, full OBJ) go through trimesh in io/meshes.py; course scenes name OBJ files
whose faces must keep their file order and whose mistakes must be reported as `file:line`, which trimesh cannot.
Faces with more than three corners are fanned into triangles; `v/vt/vn` corners and negative indices are accepted;
other statements (vn, vt, g, o, s, usemtl, mtllib, comments) are ignored.
"""

from __future__ import annotations

import numpy as np

from ..errors import SceneError


def read_obj(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V,3) float64 and 0-based faces (F,3) int64 of an OBJ file."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            lines = f.read().splitlines()
    except OSError as e:
        raise SceneError(f"cannot read mesh file: {e.strerror}", path) from None
    vertices: list[list[float]] = []
    faces: list[tuple[int, int, int]] = []
    face_lines: list[int] = []
    for lineno, line in enumerate(lines, 1):
        parts = line.split("#", 1)[0].split()
        if not parts:
            continue
        if parts[0] == "v":
            if len(parts) < 4:
                raise SceneError("a vertex needs three coordinates: v x y z", path, lineno)
            try:
                vertices.append([float(x) for x in parts[1:4]])
            except ValueError:
                raise SceneError(f"vertex coordinate is not a number: {line.strip()!r}", path, lineno) from None
        elif parts[0] == "f":
            if len(parts) < 4:
                raise SceneError("a face needs at least three vertex indices", path, lineno)
            idx = []
            for corner in parts[1:]:
                try:
                    i = int(corner.split("/")[0])
                except ValueError:
                    raise SceneError(f"face index is not an integer: {corner!r}", path, lineno) from None
                n = len(vertices)
                k = i - 1 if i > 0 else n + i
                if i == 0 or not 0 <= k < n:
                    raise SceneError(
                        f"face index {i} out of range (the file has {n} vertices before this line)", path, lineno
                    )
                idx.append(k)
            for a in range(1, len(idx) - 1):
                faces.append((idx[0], idx[a], idx[a + 1]))
                face_lines.append(lineno)
    if not faces:
        raise SceneError("mesh file has no faces", path)
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if not np.isfinite(v).all():
        bad = int(np.argwhere(~np.isfinite(v).all(axis=1))[0, 0])
        raise SceneError(f"vertex {bad + 1} is not finite", path)
    return v, np.asarray(faces, dtype=np.int64).reshape(-1, 3)


def check_obj_faces(path: str) -> None:
    """SceneError(file, line) at the first face of an OBJ file whose vertex index is 0 or names no vertex (OBJ
    counts from 1 through the file's vertices; negative indices count back from the face): trimesh reads such
    faces silently, wrongly. Only the `v` and `f` statements are looked at."""
    try:
        with open(path, "rb") as f:
            lines = [line.lstrip() for line in f.read().splitlines()]
    except OSError as e:
        raise SceneError(f"cannot read mesh file: {e.strerror}", path) from None
    total = sum(1 for line in lines if line[:2] in (b"v ", b"v\t"))
    seen = 0
    for lineno, line in enumerate(lines, 1):
        if line[:2] in (b"v ", b"v\t"):
            seen += 1
        elif line[:2] in (b"f ", b"f\t"):
            for corner in line.split(b"#", 1)[0].split()[1:]:
                try:
                    i = int(corner.split(b"/")[0])
                except ValueError:
                    raise SceneError(f"face index is not an integer: {corner.decode(errors='replace')!r}", path,
                                     lineno) from None
                if i == 0 or i > total or i < -seen:
                    raise SceneError(f"face index {i} out of range (OBJ counts vertices from 1; the file has "
                                     f"{total} vertices, {seen} before this line)", path, lineno)
