"""Insertion into a short sorted list (Numba): how traversals order a node's four children before pushing them."""

from __future__ import annotations

import numba as nb

from .common import JIT


@nb.njit(**JIT, inline="always")
def insert_ascending(keys, items, n, key, item):
    """Insert (key, item) into keys[:n] / items[:n], kept ascending by key; equal keys keep their arrival order.
    Returns the new length n + 1 (the arrays need room for it)."""
    j = n
    while j > 0 and keys[j - 1] > key:
        keys[j] = keys[j - 1]
        items[j] = items[j - 1]
        j -= 1
    keys[j] = key
    items[j] = item
    return n + 1
