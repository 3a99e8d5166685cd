"""The path tracer against Mitsuba 3 on the same Mitsuba XML scenes (examples/cornell_box.xml, examples/caustic.xml).

For each scene: a high-sample Mitsuba reference (cached in benchmarks/out/), then durer, Mitsuba scalar_rgb and
Mitsuba llvm_ad_rgb at 4, 16, 64 and 256 samples per pixel: RMSE against the reference (all pixels and channels),
the mean image ratio against the reference (bias), the log-log slope of RMSE against spp, and seconds per sample
per pixel (warm: each renderer renders once before it is timed). Prints a Markdown table.

    PYTHONPATH=src python benchmarks/pathtrace.py [--res 128] [--ref-spp 4096] [--spp 4 16 64 256]

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


def mitsuba_render(variant: str, xml: Path, res: int, spp: int, seed: int) -> tuple[np.ndarray, float]:
    import mitsuba as mi

    mi.set_variant(variant)
    scene = mi.load_file(str(xml), res=res, spp=spp)
    start = time.perf_counter()
    img = np.array(mi.render(scene, seed=seed, spp=spp))
    return img[..., :3].astype(np.float64), time.perf_counter() - start


def reference(name: str, res: int, spp: int) -> np.ndarray:
    path = OUT / f"{name}_ref_{res}_{spp}.npy"
    if path.exists():
        return np.load(path)
    import mitsuba as mi

    variant = "llvm_ad_rgb" if "llvm_ad_rgb" in mi.variants() and os.path.exists(LLVM) else "scalar_rgb"
    img, sec = mitsuba_render(variant, ROOT / "examples" / f"{name}.xml", res, spp, seed=987654)
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
    ap.add_argument("--skip-llvm", action="store_true")
    a = ap.parse_args()
    import mitsuba as mi

    renderers = ["durer", "scalar_rgb"] + ([] if a.skip_llvm or "llvm_ad_rgb" not in mi.variants() else
                                            ["llvm_ad_rgb"])
    print(f"{a.res}x{a.res} pixels, box filter, reference {a.ref_spp} spp (Mitsuba); {os.cpu_count()} CPU cores\n")
    print("| scene | renderer | " + " | ".join(f"RMSE {s}" for s in a.spp) + " | slope | mean ratio @"
          f"{a.spp[-1]} | s/spp |")
    print("|---|---|" + "---|" * len(a.spp) + "---|---|---|")
    for name in SCENES:
        xml = ROOT / "examples" / f"{name}.xml"
        ref = reference(name, a.res, a.ref_spp)
        scene = durer.load(xml)
        for r in renderers:
            errors, seconds, last = [], [], None
            for i, spp in enumerate([1] + a.spp):  # the first render warms up (Numba / LLVM compilation)
                if r == "durer":
                    start = time.perf_counter()
                    img = durer.render(scene, a.res, a.res, samples=spp, seed=i).color.astype(np.float64)
                    sec = time.perf_counter() - start
                else:
                    img, sec = mitsuba_render(r, xml, a.res, spp, seed=i)
                if i:
                    errors.append(rmse(img, ref))
                    seconds.append(sec / spp)
                    last = img
            ratio = last.mean() / ref.mean()
            print(f"| {name} | {r if r == 'durer' else 'Mitsuba ' + r} | "
                  + " | ".join(f"{e:.4f}" for e in errors)
                  + f" | {slope(a.spp, errors):.2f} | {ratio:.4f} | {np.median(seconds):.4f} |", flush=True)


if __name__ == "__main__":
    main()
