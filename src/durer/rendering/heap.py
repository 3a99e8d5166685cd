"""Freed memory kept by the C heap for reuse, so a render's arrays do not page-fault on every render.

A render allocates its per-unit arrays (film points, rays, the path tracer's wavefront state: a few MB each,
bounded by units.UNIT_SAMPLES) and frees them; glibc serves blocks above its mmap threshold (128 kB, raised
dynamically) with fresh pages and returns freed heap above its trim threshold to the kernel, so each render
touched its ~35 MB anew: 8.7k minor page faults per 16-spp render of the Mitsuba `simple` scene, ~25% of its CPU
on this VM (benchmarks/README.md). keep_freed_memory raises both thresholds once per process (glibc's mallopt:
blocks up to 32 MB come from the heap, and up to 256 MB of freed heap stay mapped), unless the user set
glibc's malloc tunables or MALLOC_*_ variables (theirs win) or DURER_KEEP_HEAP=0. Elsewhere (not glibc) it does
nothing.
"""

from __future__ import annotations

import ctypes
import os
import sys
import threading

M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h
MMAP_THRESHOLD = 32 << 20   # glibc's largest (DEFAULT_MMAP_THRESHOLD_MAX on 64-bit)
TRIM_THRESHOLD = 256 << 20  # freed heap kept mapped at most (process-wide)

_lock = threading.Lock()
_done: list[bool] = []


def keep_freed_memory() -> bool:
    """Raise glibc's mmap and trim thresholds once per process (the first render); True when they were set."""
    if _done:
        return _done[0]
    with _lock:
        if not _done:
            _done.append(_set())
    return _done[0]


def _set() -> bool:
    user = any(k.startswith("MALLOC_") for k in os.environ) or "malloc" in os.environ.get("GLIBC_TUNABLES", "")
    if user or os.environ.get("DURER_KEEP_HEAP", "1") == "0" or not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None)
        if not hasattr(libc, "gnu_get_libc_version"):  # musl and others: their allocators differ
            return False
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD))
