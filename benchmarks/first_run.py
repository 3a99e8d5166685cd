"""The first render of each kind after installation, from an empty Numba cache: how long, and what still compiles.

    python benchmarks/first_run.py            # the package copied to a temporary folder, warmed up there
    python benchmarks/first_run.py --wheel    # the real thing: `pip wheel .` (which runs the warm-up, setup.py),
                                              # the wheel installed into a new virtual environment
    python benchmarks/first_run.py --cold     # no warm-up at all: what a first run costs without the cache

Each case runs in a fresh process with NUMBA_DEBUG_CACHE=1 and counts the kernels Numba compiled and saved during
it (0 means every kernel came from the cache). Cases: the ray caster and the Whitted tracer on examples/spheres.txt
(512 x 512), the path tracer on examples/cornell_box.xml (128 x 128, 4 spp), RaycastingScene.cast_rays on the
Stanford bunny (float32 camera rays) and compute_signed_distance on random points.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

QUERY = """
import numpy as np, durer
s = durer.RaycastingScene(); s.add_mesh({bunny!r})
r = durer.RaycastingScene.create_rays_pinhole(60, (0, 0.1, 0), (0, 0.1, 0.3), (0, 1, 0), 640, 480)
s.cast_rays(r.astype(np.float32))
"""
POINTS = """
import numpy as np, durer
s = durer.RaycastingScene(); s.add_mesh({bunny!r})
s.compute_signed_distance(np.random.default_rng(0).uniform(-0.1, 0.2, (10000, 3)).astype(np.float32))
"""


def cases(python: str, out: Path, bunny: str) -> dict[str, list[str]]:
    ex = ROOT / "examples"
    render = [python, "-m", "durer", "render"]
    return {
        "ray caster (spheres.txt, 512x512)": render + [str(ex / "spheres.txt"), "-o", str(out / "a.png"), "--quiet"],
        "Whitted (spheres.txt, --shadows --bounces 3)": render + [str(ex / "spheres.txt"), "-o", str(out / "b.png"),
                                                                  "--shadows", "--bounces", "3", "--quiet"],
        "path tracer (cornell_box.xml, 128x128, 4 spp)": render + [str(ex / "cornell_box.xml"), "-o",
                                                                   str(out / "c.png"), "--size", "128", "128",
                                                                   "--samples", "4", "--quiet"],
        "RaycastingScene.cast_rays (bunny, 640x480 float32)": [python, "-c", QUERY.format(bunny=bunny)],
        "compute_signed_distance (bunny, 10k points)": [python, "-c", POINTS.format(bunny=bunny)],
    }


def measure(python: str, env: dict[str, str], out: Path, bunny: str) -> None:
    env = {**env, "NUMBA_DEBUG_CACHE": "1"}
    print("| case | first run, s wall | kernels compiled during it |\n|---|---|---|")
    for name, argv in cases(python, out, bunny).items():
        start = time.perf_counter()
        proc = subprocess.run(argv, env=env, capture_output=True, text=True)
        seconds = time.perf_counter() - start
        if proc.returncode:
            sys.exit(f"{name} failed:\n{proc.stderr[-3000:]}")
        compiled = sum("data saved" in line for line in (proc.stdout + proc.stderr).splitlines())
        print(f"| {name} | {seconds:.2f} | {compiled} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--wheel", action="store_true", help="build the wheel and install it in a new venv")
    mode.add_argument("--cold", action="store_true", help="no warm-up: the cost of compiling on first use")
    parser.add_argument("--meshes", type=Path, default=ROOT.parent / "shared" / "meshes",
                        help="folder with the Stanford bunny (../shared/meshes)")
    args = parser.parse_args()
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.wheel:
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "-q", "-w", str(tmp)],
                           check=True)
            print(f"pip wheel (with the warm-up): {time.perf_counter() - start:.0f} s")
            subprocess.run([sys.executable, "-m", "venv", str(tmp / "venv")], check=True)
            python = str(tmp / "venv" / "bin" / "python")
            wheel = next(tmp.glob("durer-*.whl"))
            subprocess.run([python, "-m", "pip", "install", "-q", str(wheel)], check=True)
        else:
            shutil.copytree(ROOT / "src" / "durer", tmp / "durer",
                            ignore=shutil.ignore_patterns("*.nbi", "*.nbc", "*.pyc"))
            env["PYTHONPATH"] = str(tmp)
            python = sys.executable
            if not args.cold:
                start = time.perf_counter()
                subprocess.run([python, "-c", "from durer.warmup import warm_up; warm_up()"], env=env, check=True)
                print(f"warm-up: {time.perf_counter() - start:.0f} s")
        measure(python, env, tmp, str(args.meshes / "bun_zipper.ply"))


if __name__ == "__main__":
    main()
