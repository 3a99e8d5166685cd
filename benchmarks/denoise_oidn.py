"""OIDN's own cost (issue 24), step by step on a 16-spp 512 x 512 Cornell render's colour and features: device
creation and commit, filter creation and commit (the network's weights and its tiling for the image size), execute,
a second execute and a re-commit with the same images, at each preset and OIDN thread count (0: its default),
each step's wall and CPU seconds (CPU: every thread of the process); then durer's denoise() the first time in a
process and later, and its conversions around OIDN. Rounds interleaved; medians.

    PYTHONPATH=src python benchmarks/denoise_oidn.py [--res 512] [--rounds 3] [--threads 0 1 2]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import durer
from durer.rendering import denoise as dn

CORNELL = Path(__file__).resolve().parents[1] / "examples" / "cornell_box.xml"
CODES = {"high": 6, "balanced": 5, "fast": 4}


def timed(f) -> tuple[object, tuple[float, float]]:
    start, cpu = time.perf_counter(), time.process_time()
    out = f()
    return out, (time.perf_counter() - start, time.process_time() - cpu)


def steps(oidn, images: list[np.ndarray], quality: str, threads: int) -> dict[str, tuple[float, float]]:
    """(wall, CPU) of each step of one denoise on a device and filter of its own."""
    t = {}
    out = np.empty_like(images[0])
    device, t["device new+commit"] = timed(lambda: _device(oidn, threads))
    flt, t["filter new+set"] = timed(lambda: _filter(oidn, device, images + [out], quality))
    t["commit"] = timed(flt.commit)[1]
    t["execute"] = timed(flt.execute)[1]
    t["execute again"] = timed(flt.execute)[1]
    for name, image in zip(("color", "albedo", "normal", "output"), images + [out], strict=True):
        flt.set_image(name, image, oidn.OIDN_FORMAT_FLOAT3)  # the same images rebound, as pyoidn.denoise does
    flt.set_quality(CODES[quality])
    t["re-commit, same images"] = timed(flt.commit)[1]
    t["execute after re-commit"] = timed(flt.execute)[1]
    error = device.get_error()
    if error:
        raise RuntimeError(error)
    t["release"] = timed(lambda: (flt.release(), device.release()))[1]
    return t


def _device(oidn, threads: int):
    device = oidn.Device()
    if threads:
        device.set_int("numThreads", threads)
    device.commit()
    return device


def _filter(oidn, device, images: list[np.ndarray], quality: str):
    flt = oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT)
    for name, image in zip(("color", "albedo", "normal", "output"), images, strict=True):
        flt.set_image(name, image, oidn.OIDN_FORMAT_FLOAT3)
    flt.set_bool("hdr", True)
    flt.set_bool("cleanAux", True)
    flt.set_quality(CODES[quality])
    return flt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--quality", nargs="+", default=["high", "balanced", "fast"], choices=tuple(CODES))
    a = ap.parse_args()
    oidn = dn.require_oidn()
    scene = durer.load(CORNELL)
    r = durer.render(scene, a.res, a.res, samples=16, aovs=True)
    _, plain = timed(lambda: durer.render(scene, a.res, a.res, samples=16))
    print(f"# 16-spp {a.res}^2 Cornell render (no features): {plain[0]:.2f} s wall, {plain[1]:.2f} s CPU")
    with oidn.Device() as d:
        d.commit()
        print(f"# OIDN device: numThreads {d.get_int('numThreads')}, setAffinity {d.get_bool('setAffinity')}, "
              f"version {d.get_int('version')}")
    images = [np.ascontiguousarray(x, dtype=np.float32) for x in
              (np.maximum(r.color, 0.0), np.clip(r.albedo, 0.0, 1.0), np.clip(r.shading_normals, -1.0, 1.0))]
    # durer's denoise() in this process: the first call of each preset, then later ones
    for q in a.quality:
        first = timed(lambda q=q: dn.denoise(r.color, r.albedo, r.shading_normals, quality=q))[1]
        later = [timed(lambda q=q: dn.denoise(r.color, r.albedo, r.shading_normals, quality=q))[1] for _ in range(2)]
        print(f"denoise() {q}: first in the process {first[0]:.3f} s wall / {first[1]:.3f} s CPU; later "
              f"{min(x[0] for x in later):.3f} / {min(x[1] for x in later):.3f} s")
    conv = timed(lambda: [np.ascontiguousarray(x, dtype=np.float32) for x in
                          (np.maximum(np.nan_to_num(r.color, posinf=0.0), 0.0), np.clip(r.albedo, 0.0, 1.0),
                           np.clip(r.shading_normals, -1.0, 1.0))])[1]
    print(f"conversions around OIDN (nan_to_num, clamps, float32): {conv[0] * 1e3:.1f} ms wall")
    rows: dict[tuple[str, int], list[dict]] = {(q, n): [] for q in a.quality for n in a.threads}
    for _ in range(a.rounds):
        for key in rows:
            rows[key].append(steps(oidn, images, *key))
    print(f"\n| preset | threads | {' | '.join(rows[next(iter(rows))][0])} |")
    print("|---|---|" + "---|" * len(rows[next(iter(rows))][0]))
    for (q, n), ts in rows.items():
        cells = [f"{np.median([t[k][0] for t in ts]):.3f} / {np.median([t[k][1] for t in ts]):.3f}" for k in ts[0]]
        print(f"| {q} | {n or 'default'} | {' | '.join(cells)} |")
    print(f"\n(wall / CPU seconds, median of {a.rounds} rounds; the render: {plain[0]:.2f} / {plain[1]:.2f} s)")


if __name__ == "__main__":
    main()
