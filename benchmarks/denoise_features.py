"""The features' cost (issue 24): CPU time of a 16-spp Cornell box render without features, with them (aovs=True),
with the film of a denoised render (render_in with denoise=True: box-filtered inputs, the second moment and the
split emission; OIDN itself not run) and the whole denoised render (durer.render(denoise=True) at each --quality:
film, OIDN, blend and refilter), interleaved round by round in one process, and the ratios to the plain render.

    PYTHONPATH=src python benchmarks/denoise_features.py [--res 512] [--rounds 4] [--quality fast balanced high]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import durer
from durer.rendering.renderer import make_context, render_in, resolve

CORNELL = Path(__file__).resolve().parents[1] / "examples" / "cornell_box.xml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--quality", nargs="*", default=["fast", "balanced", "high"], choices=("fast", "balanced", "high"),
                    help="OIDN presets of the whole denoised renders timed (none: the film only)")
    a = ap.parse_args()
    scene = durer.load(CORNELL)

    def film(res: int, samples: int):
        width, height, options = resolve(scene, res, res, samples=samples, denoise=True)
        return render_in(make_context(scene, options), width, height)

    ways = {"plain": lambda res, n: durer.render(scene, res, res, samples=n),
            "features": lambda res, n: durer.render(scene, res, res, samples=n, aovs=True),
            "denoised film": film}
    for q in a.quality:
        ways[f"denoised {q}"] = lambda res, n, q=q: durer.render(scene, res, res, samples=n, denoise=True,
                                                                 denoise_quality=q)
    for f in ways.values():  # compile
        f(32, 2)
    cpu = {k: [] for k in ways}
    for r in range(a.rounds):
        for k, f in ways.items():
            start = time.process_time()
            f(a.res, 16)
            cpu[k].append(time.process_time() - start)
        print(f"# round {r}: " + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in cpu.items()), flush=True)
    plain = np.array(cpu["plain"])
    for k in list(ways)[1:]:
        ratio = np.array(cpu[k]) / plain
        print(f"{k}: +{100 * (np.median(ratio) - 1):.1f}% CPU (median of the rounds' ratios; best against best "
              f"+{100 * (min(cpu[k]) / plain.min() - 1):.1f}%)")


if __name__ == "__main__":
    main()
