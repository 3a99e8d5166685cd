"""The compiled build of a scene (its SceneBundle and accelerator) kept between renders while the scene does not
change, so a second render of the same Scene pays no compile, table packing or BVH build, as Mitsuba 3 pays them
once in load_file.

"Did not change" is the scene's content fingerprint (scene/fingerprint.py: every attribute, list and array
reachable from it, arrays by their bytes, so in-place edits of NumPy arrays count), taken at every render and
compared with the one the build was made from; the camera is left out (a build does not read it: a new camera
is a new view of the same build). A kept build also serves only renders with the same build options
(context.build_key). Not detected: changes the fingerprint cannot see (files on disk a scene
object names but has not read; an array changed by another thread while a render runs). A scene holding
something the fingerprint cannot read (e.g. a lambda) is rebuilt every render, as before.

Memory: at most one build per scene (a new one replaces the old), dropped when the scene is garbage collected or
by `drop(scene)` (`durer.drop_build`; `drop()` drops every scene's). The build does not refer to the Scene, so
keeping it does not keep the scene alive.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from dataclasses import dataclass

from ..scene.fingerprint import fingerprint
from ..scene.graph import Scene


@dataclass
class _Kept:
    scene: weakref.ref
    digest: bytes
    key: tuple
    build: object
    finalizer: weakref.finalize


_KEPT: dict[int, _Kept] = {}
_LOCK = threading.RLock()  # re-entrant: a scene's finalizer may run inside a locked block (GC)


def kept_build(scene: Scene, key: tuple, make: Callable[[], object]) -> object:
    """The build of `scene` made by `make()` for `key` (the options it depends on): the kept one when the scene's
    fingerprint and the key are those it was made from, else a new one, kept in its place."""
    digest = fingerprint(scene, skip=("camera",))
    if digest is None:
        drop(scene)
        return make()
    with _LOCK:
        old = _KEPT.get(id(scene))
        if old is not None and old.scene() is scene and old.digest == digest and old.key == key:
            return old.build
    build = make()
    with _LOCK:
        old = _KEPT.pop(id(scene), None)
        if old is not None:
            old.finalizer.detach()
        _KEPT[id(scene)] = _Kept(weakref.ref(scene), digest, key, build,
                                 weakref.finalize(scene, _forget, id(scene)))
    return build


def drop(scene: Scene | None = None) -> None:
    """Drop the kept build of `scene`, or of every scene (None): its memory is freed, the next render rebuilds."""
    with _LOCK:
        ids = list(_KEPT) if scene is None else [id(scene)]
        for i in ids:
            old = _KEPT.get(i)
            if old is not None and (scene is None or old.scene() is scene):
                old.finalizer.detach()
                del _KEPT[i]


def _forget(key: int) -> None:
    """The scene was garbage collected: its build goes with it."""
    with _LOCK:
        _KEPT.pop(key, None)


def kept_count() -> int:
    """How many scenes have a kept build (tests, memory checks)."""
    return len(_KEPT)
