"""Mitsuba's `serialized` mesh files: one or more meshes, each a little-endian header (uint16 0x041C, uint16
version 3 or 4) and a zlib stream of flags (uint32), the mesh's name (version 4: a NUL-terminated string), vertex
and triangle counts (uint64 each), positions, then, as the flags say, vertex normals, UVs and colours (float32 or
float64), then the triangles' vertex indices (uint32, or uint64 for more than 2^32 vertices). A table at the end
of the file gives each mesh's offset (uint64 in version 4, uint32 in version 3) followed by the mesh count
(uint32)."""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass

import numpy as np

MAGIC = 0x041C
HAS_NORMALS, HAS_UVS, HAS_COLORS, FACE_NORMALS, SINGLE, DOUBLE = 0x0001, 0x0002, 0x0008, 0x0010, 0x1000, 0x2000


@dataclass
class SerializedMesh:
    """One mesh of a serialized file: positions (V, 3), faces (F, 3) and the optional per-vertex attributes."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None
    uvs: np.ndarray | None
    colors: np.ndarray | None
    face_normals: bool


def mesh_count(data: bytes) -> int:
    """How many meshes the file holds (its trailing table's last entry)."""
    if len(data) < 8:
        raise ValueError("file too short for a serialized mesh")
    return struct.unpack_from("<I", data, len(data) - 4)[0]


def read_serialized(data: bytes, index: int = 0) -> SerializedMesh:
    """Mesh number `index` of a serialized file's bytes; a ValueError says what is wrong with the file."""
    magic, version = struct.unpack_from("<HH", data, 0) if len(data) >= 4 else (0, 0)
    if magic != MAGIC:
        raise ValueError("not a Mitsuba serialized mesh (wrong file identifier)")
    if version not in (3, 4):
        raise ValueError(f"serialized format version {version} (durer reads versions 3 and 4)")
    count = mesh_count(data)
    if not 0 <= index < count:
        raise ValueError(f"shape_index {index} out of range: the file holds {count} mesh(es)")
    entry = 8 if version == 4 else 4
    table = len(data) - 4 - entry * count
    if table < 4:
        raise ValueError("corrupt serialized file (offset table)")
    offset = struct.unpack_from("<Q" if version == 4 else "<I", data, table + entry * index)[0]
    if offset + 4 > len(data):
        raise ValueError("corrupt serialized file (mesh offset beyond the end)")
    mesh_version = struct.unpack_from("<HH", data, offset)
    if mesh_version[0] != MAGIC:
        raise ValueError(f"corrupt serialized file (mesh {index} has no header)")
    try:
        raw = zlib.decompressobj().decompress(data[offset + 4:])
    except zlib.error as e:
        raise ValueError(f"corrupt serialized file: {e}") from None
    return _parse(raw, mesh_version[1])


def _parse(raw: bytes, version: int) -> SerializedMesh:
    pos = 0

    def take(dtype, n: int) -> np.ndarray:
        nonlocal pos
        size = np.dtype(dtype).itemsize * n
        if pos + size > len(raw):
            raise ValueError("corrupt serialized file (data shorter than its counts)")
        out = np.frombuffer(raw, dtype=dtype, count=n, offset=pos)
        pos += size
        return out

    flags = int(take("<u4", 1)[0])
    name = ""
    if version == 4:
        end = raw.find(b"\0", pos)
        if end < 0:
            raise ValueError("corrupt serialized file (mesh name)")
        name, pos = raw[pos:end].decode("utf-8", "replace"), end + 1
    n_vertices, n_faces = (int(x) for x in take("<u8", 2))
    if flags & DOUBLE:
        real = "<f8"
    elif flags & SINGLE:
        real = "<f4"
    else:
        raise ValueError("serialized mesh names neither single nor double precision")
    if n_vertices > len(raw) or n_faces > len(raw):
        raise ValueError("corrupt serialized file (counts larger than the data)")
    vertices = take(real, 3 * n_vertices).reshape(-1, 3).astype(np.float64)
    normals = take(real, 3 * n_vertices).reshape(-1, 3).astype(np.float64) if flags & HAS_NORMALS else None
    uvs = take(real, 2 * n_vertices).reshape(-1, 2).astype(np.float64) if flags & HAS_UVS else None
    colors = take(real, 3 * n_vertices).reshape(-1, 3).astype(np.float64) if flags & HAS_COLORS else None
    faces = take("<u8" if n_vertices > 0xFFFFFFFF else "<u4", 3 * n_faces).reshape(-1, 3).astype(np.int64)
    return SerializedMesh(name, vertices, faces, normals, uvs, colors, bool(flags & FACE_NORMALS))
