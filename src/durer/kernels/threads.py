"""Spreading serial, nogil kernels over threads: a shared pool, and the work items of the one-level kernels."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor

import numba as nb

from .bvh.layout import BLOCK, PACKET

_POOLS: dict[int, ThreadPoolExecutor] = {}
# a forked child inherits the pools but not their threads: it must make its own (multiprocessing "fork" workers)
os.register_at_fork(after_in_child=_POOLS.clear)


def thread_pool(threads: int) -> ThreadPoolExecutor:
    """The process's pool of `threads` worker threads (made once, reused by every call)."""
    pool = _POOLS.get(threads)
    if pool is None:
        pool = _POOLS[threads] = ThreadPoolExecutor(threads, thread_name_prefix="durer-bvh")
    return pool


def n_blocks(n_rays: int) -> int:
    """Work items of closest_hit_bvh / any_hit_bvh for n_rays rays."""
    return -(-int(n_rays) // (PACKET * BLOCK))


def run_blocks(kernel, n_rays: int, *args) -> None:
    """kernel(*args, blk0, blk1) over the blocks of n_rays rays (n_blocks), as run_pieces spreads them."""
    run_pieces(kernel, n_blocks(n_rays), *args)


def run_pieces(kernel, total: int, *args, threads: int | None = None) -> None:
    """kernel(*args, k0, k1) over work items 0..total, on `threads` (default numba.get_num_threads()) threads
    (the kernels are nogil): a few pieces per thread from a shared pool, so an unlucky slow piece does not idle
    the other thread. (Numba's parallel=True regions measured fragile on a loaded machine: their OpenMP threads
    wait for each other at the region's end, and one descheduled thread stalls the whole call.)"""
    map_pieces(kernel, total, *args, threads=threads)


def map_pieces(kernel, total: int, *args, threads: int | None = None) -> list:
    """run_pieces, returning each piece's result in the order of its work items (for kernels whose pieces
    produce outputs of sizes known only once they have run)."""
    threads = min(threads or nb.get_num_threads(), total)
    if threads <= 1:
        return [kernel(*args, 0, total)]
    pool = thread_pool(threads)
    pieces = min(total, 8 * threads)
    edges = [total * k // pieces for k in range(pieces + 1)]
    return [f.result() for f in [pool.submit(kernel, *args, edges[k], edges[k + 1]) for k in range(pieces)]]
