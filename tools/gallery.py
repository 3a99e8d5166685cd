"""Render the README gallery: a few MIT 6.837 course images, made by durer with the course's own command lines.

    python tools/gallery.py        # writes docs/images/gallery/*.png (needs ../shared)
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
from course_report import course_lines, run_line
from PIL import Image

GALLERY = ["output4_04d", "output4_09", "output6_12a", "output6_15", "output6_17b", "output7_05a", "output6_18a"]
OUT = Path(__file__).resolve().parents[1] / "docs" / "images" / "gallery"


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    wanted = set(GALLERY)
    with tempfile.TemporaryDirectory() as tmp:
        for line in course_lines():
            names = [Path(o).stem for o in line.outputs]
            hits = [n for n in names if n in wanted]
            if not hits:
                continue
            code, err, written, secs = run_line(line, tmp)
            if code != 0:
                print(f"{hits[0]}: failed: {err.strip()}", file=sys.stderr)
                return 1
            for name, path in written.items():
                if Path(name).stem in wanted:
                    pixels = np.asarray(Image.open(path).convert("RGB"))
                    Image.fromarray(pixels).save(OUT / f"{Path(name).stem}.png", optimize=True)
                    print(f"{Path(name).stem}: {secs:.2f} s", file=sys.stderr)
                    wanted.discard(Path(name).stem)
    if wanted:
        print(f"not found in COMMANDS.md: {sorted(wanted)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
