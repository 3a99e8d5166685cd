"""Which reader a scene file goes to, by its extension: one table, so every format is reached the same way from
`durer.load`, `durer render` and every other command that takes a scene."""

from __future__ import annotations

import os
from collections.abc import Callable

from ..errors import SceneError
from ..scene.graph import Scene

Loader = Callable[[str, "list[str] | None"], Scene]


def _course(path: str, mesh_path: list[str] | None) -> Scene:
    from .course import load_course_scene

    return load_course_scene(path, mesh_path)


def _model(path: str, mesh_path: list[str] | None) -> Scene:
    from .models import load_model

    return load_model(path, mesh_path)


# extension (lower case, with the dot) -> reader(path, mesh_path); anything else is read as a course scene file
LOADERS: dict[str, Loader] = {
    ".txt": _course,
    # model files, through trimesh (io/models.py)
    ".glb": _model,
    ".gltf": _model,
    ".obj": _model,
    ".off": _model,
    ".ply": _model,
    ".stl": _model,
}


def load_scene(path: str | os.PathLike, mesh_path: list[str] | None = None) -> Scene:
    """Read a scene file with the reader its extension names (course scene files by default)."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext not in LOADERS and _binary(path):  # say what it is not, rather than quote its bytes
        models = " ".join(sorted(e for e, loader in LOADERS.items() if loader is _model))
        raise SceneError(f"not a MIT 6.837 scene file (binary data); model files durer reads end in {models}", path)
    return LOADERS.get(ext, _course)(path, mesh_path)


def _binary(path: str) -> bool:
    """Does the file start with bytes no text file has (NUL, or invalid UTF-8)? False if it cannot be read."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return False
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as e:
        return e.start < len(head) - 4  # not just a character cut at the 4096th byte
    return b"\x00" in head
