"""Which reader a scene file goes to, by its extension: one table, so every format is reached the same way from
`durer.load`, `durer render` and every other command that takes a scene."""

from __future__ import annotations

import os
from collections.abc import Callable

from ..scene.graph import Scene

Loader = Callable[[str, "list[str] | None"], Scene]


def _course(path: str, mesh_path: list[str] | None) -> Scene:
    from .course import load_course_scene

    return load_course_scene(path, mesh_path)


def _mitsuba(path: str, mesh_path: list[str] | None) -> Scene:
    from .mitsuba import load_mitsuba

    return load_mitsuba(path, mesh_path)


# extension (lower case, with the dot) -> reader(path, mesh_path); anything else is read as a course scene file
LOADERS: dict[str, Loader] = {
    ".txt": _course,
    ".xml": _mitsuba,  # Mitsuba 3 scenes (io/mitsuba.py)
}


def load_scene(path: str | os.PathLike, mesh_path: list[str] | None = None) -> Scene:
    """Read a scene file with the reader its extension names (course scene files by default)."""
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    return LOADERS.get(ext, _course)(path, mesh_path)
