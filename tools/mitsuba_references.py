"""High-sample Mitsuba 3 references for tests/test_project_mitsuba_scenes.py's error-at-equal-samples check.

    DURER_SHARED=../shared PYTHONPATH=src python tools/mitsuba_references.py [ID ...] [--missing] [--list]

For each scene id of the test's RENDERS (all when none is named; `--missing`: only those without a reference), it
renders the scene at the test's size with Mitsuba 3 (llvm_ad_rgb when LLVM is found, else scalar_rgb) at
max(4096, 32 x the test's spp) samples per pixel, in chunks with seeds 1000, 1001, ... (the test's own Mitsuba
render uses seed 11), and writes the mean as float16 to tests/data/mitsuba/ID.npz (a few kB). The test then
checks RMSE(durer, reference) <= 1.25 x RMSE(Mitsuba at the same spp, reference) (issue 20, item 6). A scene added
to RENDERS needs its reference made here before the test passes.

The helpers that make a scene small (a mirror of the folder tree with one file's film shrunk) live here so the
test and this script render the same file.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
SCENES = Path(os.environ.get("DURER_SHARED", REPO.parent / "shared")) / "scenes" / "mitsuba"
REFERENCES = REPO / "tests" / "data" / "mitsuba"
LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
CHUNK = 1024  # samples per pixel of one Mitsuba render call


def mirror(dst: Path, scenes: Path = SCENES) -> Path:
    """The scene tree as folders of symlinks under dst, so one file can be replaced by an edited copy."""
    for folder, _, files in os.walk(scenes):
        out = dst / Path(folder).relative_to(scenes)
        out.mkdir(parents=True, exist_ok=True)
        for f in files:
            (out / f).symlink_to(Path(folder) / f)
    return dst


def shrink(path: Path, width: int = 48) -> None:
    """Replace a mirrored scene file by a copy whose film is `width` pixels wide, same aspect, no crop."""
    text = path.read_text()
    w = int(re.search(r'name="width"\s+value="(\d+)"', text).group(1))
    h = int(re.search(r'name="height"\s+value="(\d+)"', text).group(1))
    text = re.sub(r'(name="width"\s+value=")\d+', rf"\g<1>{width}", text)
    text = re.sub(r'(name="height"\s+value=")\d+', rf"\g<1>{max(1, round(h * width / w))}", text)
    text = re.sub(r'<integer name="crop_\w+"[^>]*/>', "", text)
    path.unlink()
    path.write_text(text)


def small_scene(tmp: Path, name: str, shrunk: str | None) -> Path:
    """The path of scene `name` as the test renders it: the original, or inside a mirror under tmp with the file
    `shrunk` given a small film."""
    if not shrunk:
        return SCENES / name
    root = mirror(tmp / "scenes")
    shrink(root / shrunk)
    return root / name


def reference_path(scene_id: str) -> Path:
    return REFERENCES / f"{scene_id}.npz"


def load_reference(scene_id: str) -> np.ndarray | None:
    """The reference image (H, W, 3) float64 of a RENDERS id, or None where none was made."""
    path = reference_path(scene_id)
    if not path.is_file():
        return None
    with np.load(path) as f:
        return f["image"].astype(np.float64)


def rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((np.asarray(a, np.float64) - b) ** 2)))


def _variant() -> str:
    import mitsuba as mi

    if "llvm_ad_rgb" in mi.variants() and Path(os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)).is_file():
        try:
            mi.set_variant("llvm_ad_rgb")
            return "llvm_ad_rgb"
        except Exception:  # noqa: BLE001 - no usable LLVM: the scalar variant gives the same image, slower
            pass
    mi.set_variant("scalar_rgb")
    return "scalar_rgb"


def render_reference(path: Path, params: dict, spp: int) -> np.ndarray:
    """Mitsuba's image of the scene at `spp` samples per pixel: the mean of CHUNK-spp renders, seeds 1000, 1001..."""
    import mitsuba as mi

    scene = mi.load_file(str(path), **params)
    chunks = -(-spp // CHUNK)
    total = None
    for k in range(chunks):
        img = np.array(mi.render(scene, spp=CHUNK, seed=1000 + k), dtype=np.float64)[..., :3]
        total = img if total is None else total + img
    return total / chunks


def renders() -> dict:
    """The test's RENDERS as {id: (scene name, file to shrink, parameters, spp)}."""
    sys.path.insert(0, str(REPO / "tests"))
    from test_project_mitsuba_scenes import RENDERS

    return {p.id: tuple(p.values) for p in RENDERS}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("ids", nargs="*", help="RENDERS ids of tests/test_project_mitsuba_scenes.py (default: all)")
    ap.add_argument("--missing", action="store_true", help="only the ids without a reference file")
    ap.add_argument("--list", action="store_true", help="list the ids and whether each has a reference")
    args = ap.parse_args(argv)
    table = renders()
    if args.list:
        for i, (name, _, _, spp) in table.items():
            print(f"{i:28s} {'ok     ' if reference_path(i).is_file() else 'missing'} {spp:5d} spp  {name}")
        return 0
    unknown = [i for i in args.ids if i not in table]
    if unknown:
        print(f"unknown ids: {', '.join(unknown)} (use one of {', '.join(table)})", file=sys.stderr)
        return 2
    ids = args.ids or list(table)
    if args.missing:
        ids = [i for i in ids if not reference_path(i).is_file()]
    variant = _variant()
    REFERENCES.mkdir(parents=True, exist_ok=True)
    for i in ids:
        name, shrunk, params, spp = table[i]
        ref_spp = max(4096, 32 * spp)
        start = time.perf_counter()
        with tempfile.TemporaryDirectory() as tmp:
            image = render_reference(small_scene(Path(tmp), name, shrunk), params, ref_spp)
        np.savez_compressed(reference_path(i), image=image.astype(np.float16), spp=ref_spp, variant=variant,
                            scene=name)
        print(f"{i}: {image.shape[1]}x{image.shape[0]}, {ref_spp} spp ({variant}), mean {image.mean():.5f}, "
              f"{time.perf_counter() - start:.1f} s, {reference_path(i).stat().st_size / 1024:.1f} kB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
