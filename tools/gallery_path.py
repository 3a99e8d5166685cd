"""Render the README's path tracer gallery: the Cornell box and the glass-sphere caustic from their Mitsuba XML
files, and a course scene (assignment 7's glass sphere on a checkerboard) under the path tracer.

    PYTHONPATH=src python tools/gallery_path.py [--size 256] [--samples 128]   # writes docs/images/path_*.png
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from PIL import Image

import durer
from durer.io.images import encode_srgb

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images"
COURSE = ROOT.parent / "shared" / "scenes" / "mit6837"
SCENES = {
    "path_cornell_box": (ROOT / "examples" / "cornell_box.xml", {}),
    "path_caustic": (ROOT / "examples" / "caustic.xml", {}),
    "path_course_7_05": (COURSE / "assignment7" / "scene7_05_glass_sphere.txt", {"max_depth": 12}),
}


def save_small(path: Path, color) -> None:
    """sRGB PNG with an adaptive 256-colour palette: path-traced noise makes full-colour PNGs ~90 KB, this ~40 KB."""
    pixels = Image.fromarray(encode_srgb(color))
    pixels.quantize(256, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(path, optimize=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--samples", type=int, default=128)
    ap.add_argument("--only", nargs="*", default=None, help="render only these images (names without .png)")
    a = ap.parse_args()
    for name, (path, extra) in SCENES.items():
        if a.only and name not in a.only:
            continue
        if not path.exists():
            print(f"{name}: {path} not found (course scenes live in ../shared)", file=sys.stderr)
            continue
        start = time.perf_counter()
        scene = durer.load(path, mesh_path=[str(d) for d in sorted(COURSE.glob("assignment*"))])
        r = durer.render(scene, a.size, a.size, integrator="path", samples=a.samples, **extra)
        save_small(OUT / f"{name}.png", r.color)
        print(f"{name}: {a.size}x{a.size}, {a.samples} spp, {time.perf_counter() - start:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
