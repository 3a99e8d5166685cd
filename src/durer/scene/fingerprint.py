"""A content fingerprint of a scene: the SHA-256 of everything reachable from it, so a render can tell that a scene
did not change since its last build (rendering/builds.py) without the scene announcing its changes.

The Scene is plain mutable dataclasses (graph.py) whose NumPy arrays users may change in place, so no version
counter on setters could see every change; the fingerprint reads the content instead. It covers every object
reachable through attributes, lists, tuples, dicts and sets: each value's type and repr, each array's dtype, shape
and bytes, and which objects are shared (a mesh placed twice is one object: the compiler stores it once, so two
equal copies must not fingerprint the same). An object it cannot read (no attributes and not picklable, e.g. a
lambda) makes the fingerprint None: "unknown", which a caller treats as changed. Its cost is one pass over the
scene's arrays and a Python step per object: an array enters the SHA-256 stream as its 64-bit XXH3 digest
(the `xxhash` package, about 30 GB/s against SHA-256's 1.8 GB/s here; a change goes unseen with probability about
2^-64, which is what "did the scene change" needs), since the fingerprint is taken at every render and hashing
the big bitmaps through SHA-256 was up to 16% of a render.
"""

from __future__ import annotations

import hashlib
import pickle
import types

import numpy as np
import xxhash

_PLAIN = (type(None), bool, int, float, complex, str, bytes)
_CODE = (types.FunctionType, types.MethodType, types.BuiltinFunctionType, types.ModuleType)


def fingerprint(obj: object, skip: tuple[str, ...] = ()) -> bytes | None:
    """SHA-256 digest of the content reachable from `obj` (module docstring), leaving out obj's own attributes
    named in `skip`; None where some reachable object cannot be read. Iterative: nesting depth is no limit."""
    h = hashlib.sha256()
    seen: dict[int, int] = {}
    alive: list[object] = []  # keeps objects made during the walk alive, so their ids are not reused within it
    stack: list[object] = [obj]
    top = True
    while stack:
        x = stack.pop()
        if isinstance(x, _PLAIN):
            h.update(f"{type(x).__name__}:{x!r};".encode())
            continue
        if id(x) in seen:  # a shared object: its place, once
            h.update(f"@{seen[id(x)]};".encode())
            continue
        seen[id(x)] = len(seen)
        alive.append(x)
        if isinstance(x, np.ndarray):
            h.update(f"nd:{x.dtype.str}:{x.shape};".encode())
            if x.dtype.hasobject:
                items = list(x.flat)
                alive.append(items)
                stack.extend(reversed(items))
            else:
                h.update(xxhash.xxh3_64_digest(np.ascontiguousarray(x)))
        elif isinstance(x, np.generic):
            h.update(f"{x.dtype.str}:{x!r};".encode())
        elif isinstance(x, (list, tuple)):
            h.update(f"{type(x).__qualname__}:{len(x)};".encode())
            stack.extend(reversed(x))
        elif isinstance(x, dict):
            h.update(f"{type(x).__qualname__}:{len(x)};".encode())
            for k, v in reversed(list(x.items())):
                stack.extend((v, k))
        elif isinstance(x, (set, frozenset)):
            h.update(f"{type(x).__qualname__}:{sorted(map(repr, x))!r};".encode())
        elif isinstance(x, type):
            h.update(f"class:{x.__module__}.{x.__qualname__};".encode())
        elif hasattr(x, "__dict__") and not isinstance(x, _CODE):
            names = [k for k in vars(x) if not (top and k in skip)]
            h.update(f"obj:{type(x).__module__}.{type(x).__qualname__}:{names!r};".encode())
            stack.extend(vars(x)[k] for k in reversed(names))
            slots = [s for c in type(x).__mro__ for s in getattr(c, "__slots__", ()) if s != "__weakref__"]
            if slots and not _pickled(h, x):
                return None
        elif not _pickled(h, x):
            return None
        top = False
    return h.digest()


def _pickled(h, x: object) -> bool:
    """Add x's pickle to the hash; False where x does not pickle."""
    try:
        h.update(b"pickle:" + pickle.dumps(x, protocol=pickle.HIGHEST_PROTOCOL))
    except Exception:  # noqa: BLE001 - anything unpicklable is "unknown", whatever it raises
        return False
    return True
