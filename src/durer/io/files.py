"""Reading a user's file, with the one-line error every reader gives when it cannot."""

from __future__ import annotations

import os

from ..errors import SceneError


def read_bytes(path: str, what: str) -> bytes:
    """The bytes of `path`, or SceneError naming the file and why (`what`: "scene file", "model file", ...)."""
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as e:
        raise SceneError(f"cannot read {what}: {e.strerror}", path) from None


def find_mesh(name: str, scene_path: str, mesh_path: list[str]) -> str:
    """The file a scene's mesh `name` is: next to the scene, in the working directory, then in `mesh_path`'s
    folders; SceneError saying where it looked (and how to look elsewhere) if none has it."""
    here = os.path.join(os.path.dirname(os.path.abspath(scene_path)), name)
    for candidate in [here, name] + [os.path.join(d, name) for d in mesh_path]:
        if os.path.isfile(candidate):
            return candidate
    where = f"looked in {os.path.dirname(here) or '.'}, in the working directory {os.getcwd()}"
    where += f" and in {os.pathsep.join(mesh_path)}" if mesh_path else " and in no other folder"
    raise SceneError(f"mesh file '{name}' not found ({where}); add folders to search with --mesh-path DIR or "
                     f"the DURER_MESH_PATH environment variable", scene_path)


def mesh_search_path(extra: list[str] | None = None) -> list[str]:
    """Folders searched for mesh files after the scene's own folder and the working directory:
    `extra`, then the entries of the DURER_MESH_PATH environment variable (os.pathsep-separated)."""
    env = [d for d in os.environ.get("DURER_MESH_PATH", "").split(os.pathsep) if d]
    return list(extra or []) + env
