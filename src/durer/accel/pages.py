"""A large tree's arrays on 2 MiB pages (transparent huge pages), so an incoherent walk stops missing the TLB.

An incoherent walk reads a few lines from pages all over the tree. On 4 KiB pages a tree beyond the second-level
TLB's reach (a few thousand entries: 8-12 MB) costs a page walk on many node visits; on 2 MiB pages the 1.1M
bunny's 67 MB tree needs 34 entries. Linux gives an anonymous mapping huge pages where it is madvised
(MADV_HUGEPAGE, the "madvise" mode of /sys/kernel/mm/transparent_hugepage/enabled); NumPy madvises only fresh
allocations of 4 MiB or more, and a build's arrays mostly reuse heap pages already faulted in as 4 KiB ones. So the
finished tree is copied once into a 2 MiB-aligned madvised mapping. Measured (benchmarks/README.md, "Incoherent
`cast_rays`", session 18): 1.1M bunny, 1M incoherent rays, `cast_rays` 0.94x and `count_intersections` 0.93x the
CPU time, camera rays 0.99x; the bunny's 4 MB tree (within the TLB's reach) gained nothing, so trees below
HUGE_FROM keep their arrays.
"""

from __future__ import annotations

import mmap
from pathlib import Path

import numpy as np

HUGE_PAGE = 2 << 20   # bytes of a transparent huge page on x86-64 and arm64 (4 KiB base pages)
HUGE_FROM = 8 << 20   # tree bytes from which its arrays move (the bunny's 4.2 MB: no gain measured)
_THP_MODE = Path("/sys/kernel/mm/transparent_hugepage/enabled")


def huge_pages_available() -> bool:
    """True where madvise(MADV_HUGEPAGE) can give a mapping huge pages: Linux with THP in "always" or "madvise"
    mode (not "[never]", and not where the file or the madvise flag is missing: macOS, Windows)."""
    if not hasattr(mmap, "MADV_HUGEPAGE"):
        return False
    try:
        return "[never]" not in _THP_MODE.read_text()
    except OSError:
        return False


def on_huge_pages(arrays: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """C-contiguous, writable copies of `arrays`, one after the other (each at a 64-byte boundary) in one
    anonymous mapping that starts on a 2 MiB boundary and is advised MADV_HUGEPAGE: the pages fault in as huge
    pages as the copy writes them where the kernel has them free, else as ordinary pages (the same arrays either
    way). One mapping rounds the tree up to whole huge pages once (under 2 MiB resident more), not once an array.
    The mapping lives as long as any of the arrays (their base)."""
    offsets, end = [], 0
    for a in arrays:
        offsets.append(end)
        end += -(-a.nbytes // 64) * 64
    size = -(-max(end, 1) // HUGE_PAGE) * HUGE_PAGE
    region = mmap.mmap(-1, size + HUGE_PAGE, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    raw = np.frombuffer(region, np.uint8)
    start = -raw.ctypes.data % HUGE_PAGE
    region.madvise(mmap.MADV_HUGEPAGE, start, size)
    out = []
    for a, off in zip(arrays, offsets, strict=True):
        copy = raw[start + off:start + off + a.nbytes].view(a.dtype).reshape(a.shape)
        copy[...] = a
        out.append(copy)
    return tuple(out)


def tree_on_huge_pages(arrays: tuple[np.ndarray, ...], min_bytes: int = HUGE_FROM) -> tuple[np.ndarray, ...]:
    """The tree's arrays (nodes, child codes, leaf items) copied onto huge pages (on_huge_pages) when together they
    hold at least `min_bytes` and the system gives huge pages; else the same arrays."""
    if sum(a.nbytes for a in arrays) < min_bytes or not huge_pages_available():
        return arrays
    return on_huge_pages(arrays)
