"""rendering/heap.py: freed arrays of a render's size are reused by the next allocation without page faults."""

from __future__ import annotations

import resource
import sys

import numpy as np
import pytest

from durer.rendering import heap

glibc = pytest.mark.skipif(not sys.platform.startswith("linux"),
                           reason="glibc's mallopt (Linux)")


def _faults(fn) -> int:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    fn()
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


@glibc
def test_freed_unit_arrays_are_reused_without_page_faults(monkeypatch):
    for name in [k for k in list(__import__("os").environ) if k.startswith("MALLOC_")]:
        monkeypatch.delenv(name)
    monkeypatch.delenv("GLIBC_TUNABLES", raising=False)
    monkeypatch.setattr(heap, "_done", [])
    if not heap.keep_freed_memory():
        pytest.skip("not glibc")
    size = 6 << 20  # a 256k-sample unit's (n, 3) float64 rays

    def touch():  # a unit's arrays, allocated, written (every page) and freed in a unit's mixed order
        a = np.empty(size // 8)
        a[::512] = 1.0
        b = np.empty(size // 16)
        b[::512] = 1.0
        del a
        c = np.empty(size // 4)
        c[::512] = 1.0
        assert b[::512].sum() + c[::512].sum() == (size // 16 + size // 4) // 512

    touch()
    # glibc's defaults map most of them afresh: 1753 faults over these four calls on the 2-core VM
    assert _faults(lambda: [touch() for _ in range(4)]) < 64


def test_user_settings_win(monkeypatch):
    monkeypatch.setattr(heap, "_done", [])
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "1000")
    assert heap.keep_freed_memory() is False
    assert heap.keep_freed_memory() is False  # decided once
    monkeypatch.setattr(heap, "_done", [])
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_")
    monkeypatch.setenv("DURER_KEEP_HEAP", "0")
    assert heap.keep_freed_memory() is False
