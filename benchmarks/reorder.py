"""Reordering incoherent rays before tracing (issue 9, item 3): does sorting pay, net of the sort?

Key: the direction's octant, then the Morton code of the origin's cell in a grid over the batch's origins
(kernels/point_order's grid size and bit interleaving: about 4 rays a cell, up to 2^5 cells an axis); a counting
sort (two O(N) passes), the rays gathered in that order, traced, and the answers scattered back. Batches:

* the incoherent bunny rays (benchmarks/raycases.random_rays), closest hit and any hit;
* the path tracer's secondary rays (every closest_hit and shadow any_hit after the camera rays), captured while
  rendering examples/cornell_box.xml and the same box with the Stanford bunny in place of the tall block.

    NUMBA_NUM_THREADS=1 python benchmarks/reorder.py [--rays 1048576] [--res 128] [--spp 4] [--repeat 7]

Each batch is traced four ways: through the accelerator (BVHAccelerator.closest_hit / any_hit, which takes any
16 consecutive rays that look coherent as a packet) as given and sorted, and one ray at a time (the one-ray path of
those kernels, single.blas_closest / blas_any, in a loop) as given and sorted (with and without the sort's
cost). Figures: CPU seconds (time.process_time) of one thread, median over --repeat rounds, the runs alternating;
a sorted figure includes the key, the sort, the gather and the scatter unless it says "trace only".
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numba as nb
import numpy as np
from raycases import SHARED, load_mesh, random_rays

import durer
from durer.accel.bvh import BVHAccelerator
from durer.accel.compile import compile_scene
from durer.kernels.bvh.single import blas_any, blas_closest, planes_closest
from durer.kernels.points.order import _spread_bits, grid_bits
from durer.rendering import path as path_module
from durer.scene.graph import Group, Scene
from durer.scene.shapes import TriangleMesh

ROOT = Path(__file__).resolve().parents[1]


@nb.njit(cache=True)
def ray_order(o, d, bits, lo, scale, order):
    """order = the rays sorted by (direction octant, Morton code of the origin's cell), stably: a counting sort."""
    n = o.shape[0]
    cells = 1 << bits
    keys = np.empty(n, np.int64)
    counts = np.zeros(8 << (3 * bits), np.int64)
    for i in range(n):
        key = 0
        for a in range(3):
            c = min(max(int((o[i, a] - lo[a]) * scale[a]), 0), cells - 1)
            key |= _spread_bits(c) << a
        octant = (d[i, 0] < 0.0) + 2 * (d[i, 1] < 0.0) + 4 * (d[i, 2] < 0.0)
        key |= octant << (3 * bits)
        keys[i] = key
        counts[key] += 1
    total = 0
    for k in range(counts.shape[0]):
        c = counts[k]
        counts[k] = total
        total += c
    for i in range(n):
        j = counts[keys[i]]
        counts[keys[i]] = j + 1
        order[j] = i


@nb.njit(cache=True)
def one_by_one(o, d, lo, hi, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, pl_normal,
               pl_offset, stack_size, closest, out):
    """Every ray alone, as closest_hit_bvh / any_hit_bvh trace a chunk that is not coherent (planes, then the
    tree): the one-ray path whatever the order, so sorting shows what it does to that path's cache use.
    out = t (closest) or 1.0 / 0.0 (any)."""
    stack_node, stack_t = np.empty(stack_size, np.int32), np.empty(stack_size)
    for i in range(o.shape[0]):
        ox, oy, oz, dx, dy, dz = o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2]
        best, pprim = planes_closest(pl_normal, pl_offset, ox, oy, oz, dx, dy, dz, lo[i], hi[i])
        if closest:
            t = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, ox, oy, oz,
                             dx, dy, dz, lo[i], best, stack_node, stack_t)[0]
            out[i] = min(t, best)
        elif pprim >= 0 or blas_any(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                    ox, oy, oz, dx, dy, dz, lo[i], hi[i], stack_node):
            out[i] = 1.0
        else:
            out[i] = 0.0


def ray_permutation(o, d) -> np.ndarray:
    """The sort's permutation: sorted[j] = rays[order[j]]."""
    n = len(o)
    bits = grid_bits(n)
    blo, bhi = o.min(axis=0), o.max(axis=0)
    scale = np.divide(1 << bits, bhi - blo, out=np.zeros(3), where=bhi > blo)
    order = np.empty(n, np.int64)
    ray_order(o, d, bits, blo, scale, order)
    return order


def single_plain(acc, o, d, lo, hi, closest: bool) -> np.ndarray:
    out = np.empty(len(o))
    one_by_one(o, d, lo, hi, *acc._args().args, closest, out)
    return out


def single_sorted(acc, o, d, lo, hi, closest: bool) -> np.ndarray:
    """Sort, gather, one ray at a time, scatter back."""
    order = ray_permutation(o, d)
    got = single_plain(acc, np.take(o, order, axis=0), np.take(d, order, axis=0), np.take(lo, order),
                       np.take(hi, order), closest)
    out = np.empty(len(o))
    out[order] = got
    return out


def sorted_trace(acc, o, d, lo, hi, closest: bool):
    """Sort, gather, trace, scatter back: the answers in the rays' own order."""
    n = len(o)
    order = ray_permutation(o, d)
    os_, ds = np.take(o, order, axis=0), np.take(d, order, axis=0)
    los, his = np.take(lo, order), np.take(hi, order)
    if closest:
        h = acc.closest_hit(os_, ds, los, his)
        t = np.empty(n)
        t[order] = h.t
        prim = np.empty(n, np.int32)
        prim[order] = h.prim
        kind = np.empty(n, np.int8)
        kind[order] = h.kind
        u, v = np.empty(n), np.empty(n)
        u[order], v[order] = h.u, h.v
        return t
    out = np.empty(n, np.bool_)
    out[order] = acc.any_hit(os_, ds, los, his)
    return out


def compare(label: str, acc, batches: list, closest: bool, repeat: int) -> None:
    """Time the batches as given and sorted, through the accelerator (packets where a chunk looks coherent) and one
    ray at a time; check the answers agree; print a table row. Runs alternate, figures are medians."""
    def api(o, d, lo, hi):
        return acc.closest_hit(o, d, lo, hi).t if closest else acc.any_hit(o, d, lo, hi)

    pre = []  # the batches sorted beforehand: what the one-ray walk gains, without the sort's cost
    for o, d, lo, hi in batches:
        order = ray_permutation(o, d)
        pre.append((o[order], d[order], lo[order], hi[order]))
    fns = {
        "api": lambda: [api(*b) for b in batches],
        "api sorted": lambda: [sorted_trace(acc, *b, closest) for b in batches],
        "one": lambda: [single_plain(acc, *b, closest) for b in batches],
        "one sorted": lambda: [single_sorted(acc, *b, closest) for b in batches],
        "one presorted": lambda: [single_plain(acc, *b, closest) for b in pre],
    }
    ref = fns["api"]()
    for name in ("api sorted", "one", "one sorted"):
        for x, y in zip(ref, fns[name](), strict=True):
            y = y if closest or name == "api sorted" else y > 0.0
            assert np.array_equal(x, y), f"{name}: the answers must not change"
    times: dict[str, list[float]] = {name: [] for name in fns}
    names = list(fns)
    for r in range(repeat):
        for name in names[r % len(names):] + names[:r % len(names)]:
            start = time.process_time()
            fns[name]()
            times[name].append(time.process_time() - start)
    m = {k: float(np.median(v)) for k, v in times.items()}
    n = sum(len(b[0]) for b in batches)
    print(f"| {label} | {'closest' if closest else 'any'} | {len(batches)} | {n:,} | {m['api']:.3f} | "
          f"{m['api sorted']:.3f} | {m['one']:.3f} | {m['one presorted']:.3f} | {m['one sorted']:.3f} | "
          f"{m['one'] / m['one sorted']:.2f}x |")


def capture(xml: Path, res: int, spp: int) -> tuple[BVHAccelerator | None, list, list]:
    """Render the scene with the path tracer, recording the rays of every query after the camera rays:
    (the accelerator, closest-hit batches, any-hit batches), each batch (o, d, t_min, t_max)."""
    closest, shadow, accs = [], [], []
    real_closest, real_any = BVHAccelerator.closest_hit, BVHAccelerator.any_hit

    def per_ray(t, n):
        return np.ascontiguousarray(np.broadcast_to(np.asarray(t, np.float64), (n,)))

    def rec_closest(self, o, d, t_min=0.0, t_max=np.inf, width=0):
        if width == -1:
            accs.append(self)
            closest.append((np.array(o, np.float64), np.array(d, np.float64), per_ray(t_min, len(o)),
                            per_ray(t_max, len(o))))
        return real_closest(self, o, d, t_min, t_max, width)

    def rec_any(self, o, d, t_min=0.0, t_max=np.inf, width=0):
        if width == -1:
            shadow.append((np.array(o, np.float64), np.array(d, np.float64), per_ray(t_min, len(o)),
                           per_ray(t_max, len(o))))
        return real_any(self, o, d, t_min, t_max, width)

    BVHAccelerator.closest_hit, BVHAccelerator.any_hit = rec_closest, rec_any
    # the fused bounce (kernels/path/wavefront.py) walks the tree inside its own kernel: the unfused wavefront, which
    # PathTracer takes for any other accelerator type, makes the same queries through the accelerator's API
    fused_for = path_module.BVHAccelerator
    path_module.BVHAccelerator = type("NotTheBVH", (), {})
    try:
        durer.render(durer.load(xml), res, res, samples=spp, seed=3)
    finally:
        BVHAccelerator.closest_hit, BVHAccelerator.any_hit = real_closest, real_any
        path_module.BVHAccelerator = fused_for
    return (accs[0] if accs else None), closest, shadow


def bunny_box(folder: Path) -> Path:
    """examples/cornell_box.xml with the Stanford bunny (scaled 6x, on the floor) in place of the tall block."""
    text = (ROOT / "examples" / "cornell_box.xml").read_text()
    start = text.index('    <shape type="cube" id="large-box">')
    end = text.index("</shape>", start) + len("</shape>")
    bunny = (f'    <shape type="ply" id="bunny">\n        <string name="filename" '
             f'value="{SHARED / "meshes" / "bun_zipper.ply"}"/>\n        <transform name="to_world">\n'
             '            <matrix value="6 0 0 -0.25  0 6 0 -1.2  0 0 6 -0.2  0 0 0 1"/>\n'
             '        </transform>\n        <ref id="white"/>\n    </shape>')
    path = folder / "bunny_box.xml"
    path.write_text(text[:start] + bunny + text[end:])
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rays", type=int, default=1 << 20)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--repeat", type=int, default=7)
    a = ap.parse_args()
    print("| batch | query | wavefronts | rays | accelerator (CPU s) | accelerator, sorted | one ray at a time | "
          "one ray at a time, sorted (trace only) | (with the sort) | net gain of sorting, one ray at a time |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    bunny = load_mesh(SHARED / "meshes", "bun_zipper.ply")
    acc = BVHAccelerator(compile_scene(Scene(camera=None, group=Group([TriangleMesh(bunny.vertices, bunny.faces)]))))
    o, d = random_rays(bunny, a.rays)
    lo, hi = np.zeros(len(o)), np.full(len(o), np.inf)
    for closest in (True, False):
        compare("bunny, incoherent", acc, [(o, d, lo, hi)], closest, a.repeat)
    with tempfile.TemporaryDirectory() as tmp:
        for label, xml in (("Cornell box, secondary", ROOT / "examples" / "cornell_box.xml"),
                           ("bunny in the box, secondary", bunny_box(Path(tmp)))):
            acc, closest, shadow = capture(xml, a.res, a.spp)
            compare(label, acc, closest, True, a.repeat)
            compare(label + " shadow", acc, shadow, False, a.repeat)


if __name__ == "__main__":
    main()
