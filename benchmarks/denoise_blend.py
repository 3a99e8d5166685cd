"""The variance-guided blend (issue 24, denoise.blend), offline: for each scene two seeds' 16-spp denoised films
(the noisy box-filtered colour less the split part, its second moment, OIDN's output, the split part) are cached
in benchmarks/out/, and the blend's window radius and variance scale are varied over them; the error as in
denoise.py (RMSE without the emitters' pixels against the cached 1024-spp reference), as a ratio to noisy 128 spp.

    PYTHONPATH=src python benchmarks/denoise_blend.py --res 64 --only cornell_box simple.xml ...
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import denoise as bench  # noqa: E402  (benchmarks/denoise.py: scenes, references, emitter masks)

import durer  # noqa: E402
from durer.rendering.denoise import MOMENT, blend, clean_features, denoise, refilter, split_part  # noqa: E402
from durer.rendering.renderer import make_context, render_in, resolve  # noqa: E402

VARIANTS = [(r, s) for r in (0, 1, 2, 3) for s in (1.0, 2.0, 4.0)]  # (window radius, variance scale)


def films(path: Path, scene: durer.Scene, wh: tuple[int, int], res: int) -> dict:
    cache = bench.OUT / f"denoise_blend_{path.stem}_{res}.npz"
    if cache.exists():
        return dict(np.load(cache))
    z = {}
    for k in (1, 2):
        width, height, options = resolve(scene, *wh, samples=16, seed=k, denoise=True)
        raw = render_in(make_context(scene, options), width, height)
        z[f"N{k}"], z[f"M{k}"] = raw.color, raw.aovs[MOMENT]
        z[f"D{k}"] = denoise(raw.color, raw.albedo, raw.shading_normals,
                             clean=clean_features(scene.materials, True)).color
        part = split_part(raw.aovs)
        z[f"S{k}"] = np.zeros_like(raw.color) if part is None else np.nan_to_num(part, posinf=0.0)
        z[f"n128_{k}"] = durer.render(scene, *wh, samples=128, seed=k).color
    np.savez(cache, **z)
    return z


def error(z: dict, ref: np.ndarray, keep: np.ndarray, options, variant: tuple[int, float] | None) -> float:
    """The mean over the two seeds of the denoised render's error: OIDN's output, blended by `variant` (window
    radius, variance scale) unless None, refiltered, the split part added back."""
    def image(k: int) -> np.ndarray:
        d = z[f"D{k}"]
        return d if variant is None else blend(d, z[f"N{k}"], z[f"M{k}"], 16, *variant)
    return float(np.mean([bench.rmse(refilter(image(k), options) + z[f"S{k}"], ref, keep) for k in (1, 2)]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=64)
    ap.add_argument("--only", nargs="+", metavar="TEXT", required=True)
    a = ap.parse_args()
    found, _ = bench.scene_set()
    paths = [p for t in a.only for p in [bench.CORNELL] + found if t in str(p)]
    print("| scene | OIDN | " + " | ".join(f"r {r}, x{s:g}" for r, s in VARIANTS) + " |")
    for path in paths:
        scene = durer.load(path)
        wh = bench.size(scene, a.res)
        ref, keep = bench.reference(path, scene, a.res, 1024), ~bench.emitter_pixels(path, scene, a.res)
        z = films(path, scene, wh, a.res)
        options = resolve(scene, *wh, samples=16, denoise=True)[2]
        base = np.mean([bench.rmse(z[f"n128_{k}"], ref, keep) for k in (1, 2)])
        cells = [error(z, ref, keep, options, None) / base]
        cells += [error(z, ref, keep, options, v) / base for v in VARIANTS]
        print(f"| {path.stem} | " + " | ".join(f"{c:.3f}" for c in cells) + " |", flush=True)


if __name__ == "__main__":
    main()
