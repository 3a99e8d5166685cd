"""Reading a user's file, with the one-line error every reader gives when it cannot."""

from __future__ import annotations

from ..errors import SceneError


def read_bytes(path: str, what: str) -> bytes:
    """The bytes of `path`, or SceneError naming the file and why (`what`: "scene file", "model file", ...)."""
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError as e:
        raise SceneError(f"cannot read {what}: {e.strerror}", path) from None
