"""Run the MIT 6.837 course's own command lines through `durer raycast` and compare every output image with
the course's reference image.

    python tools/course_report.py [--assignments 1 2 ...] [--markdown] [--keep DIR]

For each image it prints the fraction of pixels whose largest channel difference is at most 2/255, the mean
absolute difference and the largest difference, as issues 2 and 4 ask. Needs ../shared (the course scenes).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shlex
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image

COURSE = Path(os.environ.get("DURER_SHARED", Path(__file__).resolve().parents[2] / "shared")) / "scenes" / "mit6837"
OUTPUT_FLAGS = {"-output": 0, "-normals": 0, "-depth": 2, "-render_samples": 0, "-render_filter": 0}


@dataclass
class CourseLine:
    assignment: int
    argv: list[str]          # the command line after `raytracer`
    outputs: list[str]       # output file names it writes

    @property
    def folder(self) -> Path:
        return COURSE / f"assignment{self.assignment}"

    def reference(self, output: str) -> Path:
        """The reference image of one output. Assignment 6 shows one image for runs that differ only by -grid or
        -stats (output6_01a_b.png for output6_01a and output6_01b); a name with no image is returned as is."""
        ref = self.folder / "reference" / (Path(output).stem + ".png")
        if not ref.exists():
            stem = ref.stem
            for candidate in sorted(ref.parent.glob(f"{stem[:-1]}*.png")):
                if stem[-1] in candidate.stem[len(stem) - 1:].split("_"):
                    return candidate
        return ref


def course_lines(assignments: list[int] | None = None) -> list[CourseLine]:
    """Every `raytracer ...` line of COMMANDS.md, in order (comments and [completed] marks stripped)."""
    lines, assignment = [], 0
    for raw in (COURSE / "COMMANDS.md").read_text().splitlines():
        m = re.match(r"## Assignment (\d+)", raw)
        if m:
            assignment = int(m.group(1))
        if not raw.startswith("raytracer "):
            continue
        argv = shlex.split(raw.split("#", 1)[0])[1:]
        outputs = []
        for i, tok in enumerate(argv):
            if tok in OUTPUT_FLAGS:
                outputs.append(argv[i + 1 + OUTPUT_FLAGS[tok]])
        if assignments is None or assignment in assignments:
            lines.append(CourseLine(assignment, argv, outputs))
    return lines


def mesh_path() -> str:
    return os.pathsep.join(str(p) for p in sorted(COURSE.glob("assignment*")))


def run_line(line: CourseLine, outdir: str) -> tuple[int, str, dict[str, str], float]:
    """Run one course line with durer (outputs redirected to outdir); exit code, stderr, output paths, seconds."""
    from durer.cli import main

    argv, written = list(line.argv), {}
    for i, tok in enumerate(argv):
        if tok in OUTPUT_FLAGS:
            k = i + 1 + OUTPUT_FLAGS[tok]
            written[argv[k]] = os.path.join(outdir, argv[k])
            argv[k] = written[argv[k]]
    old = os.getcwd()
    os.environ.setdefault("DURER_MESH_PATH", mesh_path())
    err = io.StringIO()
    start = time.perf_counter()
    try:
        os.chdir(line.folder)
        with contextlib.redirect_stderr(err):
            code = main(["raycast", *argv])
    finally:
        os.chdir(old)
    return code, err.getvalue(), written, time.perf_counter() - start


def compare(image_path: str, reference: Path) -> tuple[float, float, int]:
    """(fraction of pixels within 2/255 in every channel, mean absolute difference /255, largest difference)."""
    mine = np.asarray(Image.open(image_path).convert("RGB")).astype(int)
    ref = np.asarray(Image.open(reference).convert("RGB")).astype(int)
    if mine.shape != ref.shape:
        return 0.0, 255.0, 255
    diff = np.abs(mine - ref)
    return float((diff.max(axis=2) <= 2).mean()), float(diff.mean()), int(diff.max())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--assignments", type=int, nargs="*", default=None)
    ap.add_argument("--markdown", action="store_true", help="print a Markdown table")
    ap.add_argument("--keep", metavar="DIR", help="write the images into DIR (kept) instead of a temporary folder, "
                    "for example to compare two versions of durer byte for byte")
    a = ap.parse_args()
    if not COURSE.is_dir():
        print(f"course scenes not found at {COURSE}", file=sys.stderr)
        return 2
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        tmp = a.keep or scratch
        os.makedirs(tmp, exist_ok=True)
        for line in course_lines(a.assignments):
            code, err, written, secs = run_line(line, tmp)
            for name, path in written.items():
                ref = line.reference(name)
                if not ref.exists():
                    continue
                if code != 0 or not os.path.exists(path):
                    rows.append((line.assignment, Path(name).stem, None, None, None, secs, err.strip()[-80:]))
                    continue
                frac, mad, mx = compare(path, ref)
                rows.append((line.assignment, Path(name).stem, frac, mad, mx, secs, ""))
                print(f"A{line.assignment} {Path(name).stem:28s} {frac * 100:7.2f}%  mean {mad:6.3f}  max {mx:3d}"
                      f"  {secs:5.2f}s", file=sys.stderr)
    if a.markdown:
        print(markdown(rows))
    return 0


def markdown(rows: list[tuple]) -> str:
    """A per-assignment summary, then one row per image."""
    out = ["| assignment | images | all pixels within 2/255 | at least 99% | lowest |", "|---|---|---|---|---|"]
    for asg in sorted({r[0] for r in rows}):
        fr = [r[2] if r[2] is not None else 0.0 for r in rows if r[0] == asg]
        out.append(f"| {asg} | {len(fr)} | {sum(f == 1.0 for f in fr)} | {sum(f >= 0.99 for f in fr)} "
                   f"| {min(fr) * 100:.2f}% |")
    out += ["", "| assignment | image | pixels within 2/255 | mean abs. diff (/255) | max diff |",
            "|---|---|---|---|---|"]
    for asg, name, frac, mad, mx, _, err in rows:
        if frac is None:
            out.append(f"| {asg} | {name} | failed: {err} | | |")
        else:
            out.append(f"| {asg} | {name} | {frac * 100:.2f}% | {mad:.3f} | {mx} |")
    return "\n".join(out)


if __name__ == "__main__":
    sys.exit(main())
