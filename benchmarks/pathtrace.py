"""The path tracer against Mitsuba 3 on the same Mitsuba XML scenes (examples/cornell_box.xml, examples/caustic.xml).

For each scene: a high-sample Mitsuba reference (cached in benchmarks/out/), then durer, Mitsuba scalar_rgb and
Mitsuba llvm_ad_rgb at 4, 16, 64 and 256 samples per pixel, each count rendered with several independent seeds
(--seeds, --seeds-last for the largest count): RMSE against the reference (all pixels and channels) as the mean
over the seeds with its standard deviation (one run's RMSE at low spp is set by a few firefly pixels), the
log-log slope of the mean RMSE against spp, the mean image ratio against the reference over the largest count's
renders (bias), and seconds per sample per pixel, median over all timed renders, as wall time and as the
process's CPU time over all its threads (warm: each renderer renders once before it is timed). Prints a
Markdown table.

    PYTHONPATH=src python benchmarks/pathtrace.py [--res 128] [--ref-spp 4096] [--spp 4 16 64 256] [--seeds 4]

llvm_ad_rgb needs Debian's libllvm19 (apt-get install -y libllvm19); DRJIT_LIBLLVM_PATH is set to it when present.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
if os.path.exists(LLVM):
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)

import numpy as np  # noqa: E402

import durer  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "out"
SCENES = ("cornell_box", "caustic")


def mitsuba_render(variant: str, xml: Path, res: int, spp: int, seed: int) -> tuple[np.ndarray, float, float]:
    """Mitsuba's image, wall seconds and CPU seconds of the render."""
    import mitsuba as mi

    mi.set_variant(variant)
    scene = mi.load_file(str(xml), res=res, spp=spp)
    start, cpu = time.perf_counter(), time.process_time()
    img = np.array(mi.render(scene, seed=seed, spp=spp))
    return img[..., :3].astype(np.float64), time.perf_counter() - start, time.process_time() - cpu


def durer_render(scene, res: int, spp: int, seed: int) -> tuple[np.ndarray, float, float]:
    """durer's image, wall seconds and CPU seconds of the render."""
    start, cpu = time.perf_counter(), time.process_time()
    img = durer.render(scene, res, res, samples=spp, seed=seed).color.astype(np.float64)
    return img, time.perf_counter() - start, time.process_time() - cpu


def reference(name: str, res: int, spp: int) -> np.ndarray:
    path = OUT / f"{name}_ref_{res}_{spp}.npy"
    if path.exists():
        return np.load(path)
    import mitsuba as mi

    variant = "llvm_ad_rgb" if "llvm_ad_rgb" in mi.variants() and os.path.exists(LLVM) else "scalar_rgb"
    img, sec, _ = mitsuba_render(variant, ROOT / "examples" / f"{name}.xml", res, spp, seed=987654)
    print(f"# reference {name}: Mitsuba {variant}, {res}x{res}, {spp} spp, {sec:.1f} s")
    OUT.mkdir(parents=True, exist_ok=True)
    np.save(path, img)
    return img


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)))


def slope(spps, errors) -> float:
    return float(np.polyfit(np.log(spps), np.log(errors), 1)[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--spp", type=int, nargs="+", default=[4, 16, 64, 256])
    ap.add_argument("--seeds", type=int, default=4, help="independent renders per sample count")
    ap.add_argument("--seeds-last", type=int, default=2, help="independent renders at the largest count")
    ap.add_argument("--skip-llvm", action="store_true")
    a = ap.parse_args()
    import mitsuba as mi

    renderers = ["durer", "scalar_rgb"] + ([] if a.skip_llvm or "llvm_ad_rgb" not in mi.variants() else
                                            ["llvm_ad_rgb"])
    print(f"{a.res}x{a.res} pixels, box filter, reference {a.ref_spp} spp (Mitsuba); {os.cpu_count()} CPU cores; "
          f"RMSE = mean ± standard deviation over {a.seeds} seeds ({a.seeds_last} at {a.spp[-1]} spp)\n")
    print("| scene | renderer | " + " | ".join(f"RMSE {s}" for s in a.spp) + " | slope | mean ratio @"
          f"{a.spp[-1]} | s/spp wall | s/spp CPU |")
    print("|---|---|" + "---|" * len(a.spp) + "---|---|---|---|")
    for name in SCENES:
        xml = ROOT / "examples" / f"{name}.xml"
        ref = reference(name, a.res, a.ref_spp)
        scene = durer.load(xml)
        for r in renderers:
            def render(spp, seed, r=r, xml=xml, scene=scene):
                return durer_render(scene, a.res, spp, seed) if r == "durer" else mitsuba_render(r, xml, a.res,
                                                                                                 spp, seed)
            render(1, 0)  # warm-up: Numba / LLVM compilation
            means, cells, wall, cpu, ratios = [], [], [], [], []
            for spp in a.spp:
                errors = []
                for k in range(a.seeds_last if spp == a.spp[-1] else a.seeds):
                    img, sec, cpu_sec = render(spp, 1 + 1000 * k + spp)  # independent seeds, never reused
                    errors.append(rmse(img, ref))
                    wall.append(sec / spp)
                    cpu.append(cpu_sec / spp)
                    if spp == a.spp[-1]:
                        ratios.append(img.mean() / ref.mean())
                means.append(float(np.mean(errors)))
                cells.append(f"{means[-1]:.4f} ±{np.std(errors, ddof=1) if len(errors) > 1 else 0.0:.4f}")
            print(f"| {name} | {r if r == 'durer' else 'Mitsuba ' + r} | " + " | ".join(cells)
                  + f" | {slope(a.spp, means):.2f} | {np.mean(ratios):.4f} | {np.median(wall):.4f} | "
                  f"{np.median(cpu):.4f} |", flush=True)


if __name__ == "__main__":
    main()
