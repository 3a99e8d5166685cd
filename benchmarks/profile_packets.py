"""Where the packet walk's time goes on camera rays (issue 21 item 1): packets against the one-ray walk, node visits
and leaf tests per packet, and the share of time spent waiting on memory.

    NUMBA_NUM_THREADS=1 python benchmarks/profile_packets.py [--mesh bun_zipper_subdiv2.ply] [--repeat 5]

1024 x 1024 pinhole rays (`raycases.camera_rays`, float32 values as users give them) traced by the one-level
kernels' pieces on one thread (`time.thread_time`, medians of --repeat, every variant interleaved in each round):
the one-ray walk (`single.blas_closest` ray by ray), packets of 16 consecutive rays (16 x 1 strips: width 0) and
4 x 4 tiles (the image width, as `cast_rays` finds it for flat camera rays: `accel/widths.flat_image_width`).
Counts per packet come from a copy of `packet.packet_traverse` with counters. The memory split traces every
packet twice in a row: the second pass finds the packet's nodes and leaves in cache, so (once - repeat) / once is
the share of the first pass spent on cold lines; "nodes only" walks with every ray's final t preset (no leaf
test: a floor on the node work), so full - nodes only is the leaves' part.
"""

from __future__ import annotations

import argparse
import time

import numba as nb
import numpy as np
from raycases import SHARED, camera_rays, load_mesh

from durer import RaycastingScene
from durer.kernels.bvh.chunks import _BEST, chunk_rays, packet_setup
from durer.kernels.bvh.layout import PACKET, leaf_range
from durer.kernels.bvh.packet import (
    _packet_far,
    _packet_leaf,
    packet_extents,
    packet_node,
    packet_pop,
    packet_traverse,
    push_inner,
)
from durer.kernels.bvh.single import blas_closest, load_ray
from durer.kernels.bvh.trace import scratch


@nb.njit
def _counts(o, d, lo, hi, bounds, child, leaf_prim, leaf_tri, sc, sr, sw, pn, po, ssize, width):
    """(packets, chunks, node visits, leaves, leaf items) of packet_traverse's walk, counted."""
    stack_node, stack_t, rr, key, order, idx, _, spread = scratch(ssize, bounds, child)
    n = o.shape[0]
    chunks = (n + PACKET - 1) // PACKET
    packets = visits = leaves = items = 0
    for c in range(chunks):
        m = chunk_rays(c, n, width, idx)
        coherent, nrx, nry, nrz, kx, ky, kz = packet_setup(o, d, lo, hi, idx, m, rr, spread)
        if not (coherent and m == PACKET):
            continue
        packets += 1
        ext = packet_extents(rr, nrx, nry, nrz)
        stack_node[0], stack_t[0], sp = 0, -np.inf, 1
        far = _packet_far(rr)
        while True:
            node, sp = packet_pop(stack_node, stack_t, sp, far)
            if node < 0:
                break
            visits += 1
            n_in = packet_node(bounds, child, node, nrx, nry, nrz, ext, far, key, order)
            for q in range(n_in):
                code = child[node, order[q]]
                if code < 0:
                    first, end = leaf_range(code)
                    leaves += 1
                    items += end - first
                    _packet_leaf(code, leaf_prim, leaf_tri, sc, sr, sw, kx, ky, kz, rr, False)
                    far = _packet_far(rr)
            sp = push_inner(child, node, key, order, n_in, stack_node, stack_t, sp)
    return packets, chunks, visits, leaves, items


@nb.njit
def _one_ray(o, d, lo, hi, bounds, child, leaf_prim, leaf_tri, sc, sr, sw, pn, po, ssize, t):
    stack_node, stack_t = np.empty(ssize, np.int32), np.empty(ssize)
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = load_ray(o, d, i)
        t[i] = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, sc, sr, sw, ox, oy, oz, dx, dy, dz, lo[i], hi[i],
                            stack_node, stack_t)[0]


@nb.njit
def _packets(o, d, lo, hi, t_final, bounds, child, leaf_prim, leaf_tri, sc, sr, sw, pn, po, ssize, width, mode,
             reps):
    """Every chunk reps times in a row as a packet: mode 0 packet_traverse, 1 nodes only (best = final t), 2 the
    packet's setup alone."""
    stack_node, stack_t, rr, key, order, idx, _, spread = scratch(ssize, bounds, child)
    n = o.shape[0]
    acc = 0.0
    for c in range((n + PACKET - 1) // PACKET):
        m = chunk_rays(c, n, width, idx)
        for _ in range(reps):
            _, nrx, nry, nrz, kx, ky, kz = packet_setup(o, d, lo, hi, idx, m, rr, spread)
            if mode == 0:
                packet_traverse(bounds, child, np.int32(0), leaf_prim, leaf_tri, sc, sr, sw, nrx, nry, nrz, kx, ky,
                                kz, rr, stack_node, stack_t, key, order, np.bool_(False))
            elif mode == 1:
                for k in range(PACKET):
                    rr[_BEST + k] = min(t_final[idx[k]] * (1 + 1e-12), 1e300)
                ext = packet_extents(rr, nrx, nry, nrz)
                stack_node[0], stack_t[0], sp = 0, -np.inf, 1
                far = _packet_far(rr)
                while True:
                    node, sp = packet_pop(stack_node, stack_t, sp, far)
                    if node < 0:
                        break
                    n_in = packet_node(bounds, child, node, nrx, nry, nrz, ext, far, key, order)
                    for q in range(n_in):
                        code = child[node, order[q]]
                        if code < 0:
                            acc += leaf_tri[leaf_range(code)[0] * 9]  # the leaf's first line, as a test loads it
                    sp = push_inner(child, node, key, order, n_in, stack_node, stack_t, sp)
            acc += rr[_BEST]
    return acc


def _cpu(f) -> float:
    start = time.thread_time()
    f()
    return time.thread_time() - start


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mesh", default="bun_zipper_subdiv2.ply")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--meshes", default=SHARED / "meshes")
    args = ap.parse_args(argv)
    mesh = load_mesh(args.meshes, args.mesh)
    scene = RaycastingScene()
    scene.add_triangles(mesh.vertices, mesh.faces)
    o, d = camera_rays(mesh, 1024)
    o, d = o.astype(np.float32).astype(np.float64), d.astype(np.float32).astype(np.float64)
    o, d, tree = scene._tree()._one_level(o, d)
    tree = tree.args
    n = len(o)
    lo, hi, t = np.zeros(n), np.full(n, np.inf), np.empty(n)
    _one_ray(o, d, lo, hi, *tree, t)
    print(f"{args.mesh}, {n:,} camera rays, {100 * np.isfinite(t).mean():.1f}% hit, 1 thread, median of "
          f"{args.repeat}")
    for width in (0, 1024):
        packets, chunks, visits, leaves, items = _counts(o, d, lo, hi, *tree, width)
        print(f"- width {width}: {packets / chunks:.1%} of chunks are packets; per packet {visits / packets:.1f} node "
              f"visits, {leaves / packets:.1f} leaves, {items / packets:.1f} leaf items ({items / packets / 16:.2f} "
              "a ray)")
    runs = {"one-ray walk": lambda: _one_ray(o, d, lo, hi, *tree, t)}
    for width in (0, 1024):
        for mode, name in ((0, "full"), (1, "nodes only"), (2, "setup only")):
            for reps in (1, 2):
                runs[(width, name, reps)] = (lambda w=width, m=mode, r=reps:
                                             _packets(o, d, lo, hi, t, *tree, w, m, r))
    for f in runs.values():  # compiles each specialisation before timing
        f()
    times: dict = {k: [] for k in runs}
    for _ in range(args.repeat):
        for k, f in runs.items():
            times[k].append(_cpu(f))
    med = {k: 1e3 * float(np.median(v)) for k, v in times.items()}
    print(f"- one-ray walk: {med['one-ray walk']:.0f} ms")
    for width in (0, 1024):
        for name in ("full", "nodes only", "setup only"):
            once, twice = med[(width, name, 1)], med[(width, name, 2)]
            print(f"- packets, width {width}, {name}: {once:.0f} ms; again in cache {twice - once:.0f} ms; cold lines "
                  f"{(2 * once - twice) / once:.0%} of the first pass")


if __name__ == "__main__":
    main()
