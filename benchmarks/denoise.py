"""Denoising (issue 24): the error of OIDN-denoised path-traced renders at 4, 16 and 64 spp next to undenoised
renders at 16-1024 spp, and the denoiser's time.

Scenes: the Cornell box (examples/cornell_box.xml), and the set: every scene of ../shared/scenes/mitsuba/ that durer
loads (the others are listed with the reason) and examples/caustic.xml. Each is rendered with its longer side --res
pixels. Error: RMSE (linear radiance, every channel) against durer's own high-sample reference (--ref-spp, another
seed; cached in benchmarks/out/), with the emitters' own pixels left out (pixels where some sample of a max_depth=1
render sees an emitter: they are far brighter than anything else and not what a denoiser is for). Targets: denoised
at 16 spp below undenoised at 128 spp on the Cornell box and on the median scene of the set (the ratio of the two
errors, median over the set, the upper one for an even count); the denoiser under 10% of a 16-spp render's time at
512 x 512 (Cornell box). --picture writes the side-by-side image of the README.

    PYTHONPATH=src python benchmarks/denoise.py [--quick] [--res 96] [--ref-spp 4096] [--picture PNG]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import durer
from durer.errors import SceneError
from durer.rendering.denoise import QUALITY

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "out"
# ../shared beside the repository (a worktree in wt/ has it one folder further up)
SHARED = next((p / "shared" / "scenes" / "mitsuba" for p in (ROOT.parent, ROOT.parent.parent)
               if (p / "shared" / "scenes" / "mitsuba").is_dir()), ROOT.parent / "shared" / "scenes" / "mitsuba")
CORNELL = ROOT / "examples" / "cornell_box.xml"
DENOISED_SPP = (4, 16, 64)
NOISY_SPP = (16, 32, 64, 128, 256, 512, 1024)


def scene_set() -> tuple[list[Path], list[str]]:
    """The set's scene files durer loads, and a line for each it does not."""
    found, skipped = [], []
    for path in sorted(SHARED.glob("**/*.xml")) + [ROOT / "examples" / "caustic.xml"]:
        if {"fragments", "include"} & set(path.parts):
            continue
        try:
            durer.load(path)
            found.append(path)
        except (SceneError, ValueError, OSError) as e:
            skipped.append(f"{path.relative_to(SHARED) if SHARED in path.parents else path.name}: "
                           f"{str(e).splitlines()[0][-90:]}")
    return found, skipped


def size(scene: durer.Scene, res: int) -> tuple[int, int]:
    """The scene's film aspect with the longer side res pixels."""
    d = scene.render_defaults
    w, h = d.get("width", res), d.get("height", res)
    s = res / max(w, h)
    return max(1, round(w * s)), max(1, round(h * s))


def reference(path: Path, scene: durer.Scene, res: int, spp: int) -> np.ndarray:
    cache = OUT / f"denoise_ref_{path.stem}_{res}_{spp}.npy"
    if cache.exists():
        return np.load(cache)
    start = time.perf_counter()
    img = np.zeros(size(scene, res)[::-1] + (3,))
    chunk = min(spp, 1024)
    for k in range(spp // chunk):  # chunks of independent seeds: the same estimator, bounded memory
        img += durer.render(scene, *size(scene, res), samples=chunk, seed=1000 + k).color / (spp // chunk)
    print(f"# reference {path.stem}: {spp} spp at {res} px, {time.perf_counter() - start:.0f} s")
    OUT.mkdir(parents=True, exist_ok=True)
    np.save(cache, img)
    return img


def emitter_pixels(scene: durer.Scene, res: int) -> np.ndarray:
    """Pixels where some of 16 samples sees an emitter directly (max_depth 1 shows emitters only)."""
    seen = durer.render(scene, *size(scene, res), samples=16, max_depth=1, seed=5).color
    return seen.max(axis=2) > 0


def rmse(a: np.ndarray, b: np.ndarray, keep: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a[keep] - b[keep]) ** 2)))


def errors(path: Path, res: int, ref_spp: int, noisy_spp, denoised_spp) -> dict:
    """RMSE of noisy renders {spp: e} and denoised ones {spp: e} against the reference, and the mean denoise time."""
    scene = durer.load(path)
    ref = reference(path, scene, res, ref_spp)
    keep = ~emitter_pixels(scene, res)
    noisy = {n: rmse(durer.render(scene, *size(scene, res), samples=n, seed=1).color, ref, keep) for n in noisy_spp}
    denoised, seconds = {}, []
    for n in denoised_spp:
        r = durer.render(scene, *size(scene, res), samples=n, seed=1, denoise=True)
        denoised[n] = rmse(r.color, ref, keep)
        seconds.append(r.denoise_seconds)
    return dict(noisy=noisy, denoised=denoised, seconds=float(np.mean(seconds)), kept=float(keep.mean()))


def timing(res: int = 512, spp: int = 16) -> dict:
    """A 16-spp render of the Cornell box at 512 x 512 without and with --denoise (each after a warm-up)."""
    scene = durer.load(CORNELL)
    durer.render(scene, 32, 32, samples=2, denoise=True)  # compile, load OIDN's weights
    plain, denoised = [], []
    for _ in range(2):
        start = time.perf_counter()
        durer.render(scene, res, res, samples=spp)
        plain.append(time.perf_counter() - start)
        start = time.perf_counter()
        r = durer.render(scene, res, res, samples=spp, denoise=True)
        denoised.append((time.perf_counter() - start, r.denoise_seconds))
    t_plain = min(plain)
    t_all, t_oidn = min(denoised)
    return dict(plain=t_plain, total=t_all, oidn=t_oidn)


def picture(path: Path, res: int = 160, spp: int = 16) -> None:
    """Noisy | denoised at spp | reference (1024 spp), Cornell box, sRGB PNG."""
    from PIL import Image

    scene = durer.load(CORNELL)
    noisy = durer.render(scene, res, res, samples=spp)
    denoised = durer.render(scene, res, res, samples=spp, denoise=True)
    ref = durer.render(scene, res, res, samples=1024, seed=9)
    gap = np.full((res, 4, 3), 255, np.uint8)
    strip = np.concatenate([noisy.to_srgb8(), gap, denoised.to_srgb8(), gap, ref.to_srgb8()], axis=1)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(strip).save(path, optimize=True)
    print(f"# wrote {path}: {spp} spp | {spp} spp denoised | 1024 spp")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=96, help="longer image side of the error renders (default 96)")
    ap.add_argument("--ref-spp", type=int, default=4096, help="samples of the reference (default 4096)")
    ap.add_argument("--quick", action="store_true", help="64 px, 1024-spp reference, noisy up to 256 spp")
    ap.add_argument("--picture", type=Path, help="also write the README's side-by-side PNG here")
    ap.add_argument("--no-timing", action="store_true", help="skip the 512 x 512 timing")
    a = ap.parse_args()
    res, ref_spp, noisy_spp = a.res, a.ref_spp, NOISY_SPP
    if a.quick:
        res, ref_spp, noisy_spp = 64, 1024, tuple(n for n in NOISY_SPP if n <= 256)
    found, skipped = scene_set()
    print(f"# OIDN quality {QUALITY!r}; {res} px on the longer side; reference {ref_spp} spp; RMSE without the "
          "emitters' own pixels")
    for line in skipped:
        print(f"# not loaded: {line}")
    head = " | ".join([f"noisy {n}" for n in noisy_spp] + [f"denoised {n}" for n in DENOISED_SPP])
    print(f"\n| scene | {head} | denoised 16 / noisy 128 | OIDN s |")
    print("|---" * (len(noisy_spp) + len(DENOISED_SPP) + 3) + "|")
    ratios = {}
    for path in [CORNELL] + found:
        e = errors(path, res, ref_spp, noisy_spp, DENOISED_SPP)
        ratio = e["denoised"][16] / e["noisy"][128]
        ratios[path] = ratio
        cells = [f"{e['noisy'][n]:.4f}" for n in noisy_spp] + [f"{e['denoised'][n]:.4f}" for n in DENOISED_SPP]
        name = path.relative_to(SHARED) if SHARED in path.parents else path.relative_to(ROOT)
        print(f"| {name} | {' | '.join(cells)} | {ratio:.2f} | {e['seconds']:.3f} |", flush=True)
    in_set = sorted(ratios[p] for p in found)
    median = in_set[len(in_set) // 2] if in_set else float("nan")
    print(f"\nTarget: denoised 16 spp below noisy 128 spp: Cornell box {ratios[CORNELL]:.2f} "
          f"({'met' if ratios[CORNELL] < 1 else 'NOT met'}), median scene of the set ({len(in_set)}) {median:.2f} "
          f"({'met' if median < 1 else 'NOT met'})")
    if not a.no_timing:
        t = timing()
        share = t["oidn"] / t["plain"]
        print(f"Target: denoiser under 10% of a 16-spp 512x512 render: render {t['plain']:.2f} s, with --denoise "
              f"{t['total']:.2f} s, of which OIDN {t['oidn']:.2f} s = {100 * share:.1f}% "
              f"({'met' if share < 0.1 else 'NOT met'}); whole difference {100 * (t['total'] / t['plain'] - 1):.1f}%")
    if a.picture:
        picture(a.picture)


if __name__ == "__main__":
    main()
