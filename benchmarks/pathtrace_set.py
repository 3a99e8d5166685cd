"""The path tracer against Mitsuba 3 on every real Mitsuba scene durer reads (issue 21, item 5).

Every scene of tests/test_project_mitsuba_scenes.LOADABLE (../shared/scenes/mitsuba) is rendered by durer, Mitsuba 3
`scalar_rgb` and Mitsuba 3 `llvm_ad_rgb` from the same file at the same size (--res pixels on the longer side) and
the same samples per pixel (--spp), with the scene's own integrator, max_depth and emitters. The film is made that
size in a copy of the file that defines it, inside a mirror of the folder tree (symlinks:
tools/mitsuba_references.mirror), so both renderers read the same edited file and every <include>, <path> and mesh
resolves as in the original; this handles scenes with a `res` parameter and scenes with literal film sizes alike.

Each renderer renders each scene once first (warm: Numba's and LLVM's compilation), then --rounds times, the engines
interleaved and their order rotated per round, each timed render after a rest of --rest seconds (0.3): Dr.Jit's
and Mitsuba's worker threads keep spinning for a while after a render, and an engine timed right after another
shares the cores with them (measured: durer on `simple` 3.5 ms/spp wall right after an llvm_ad_rgb render,
2.2 ms/spp after a 0.5 s rest; its process CPU 7.1 against 3.9 ms, the difference being Mitsuba's threads).
Timed: durer.render and mi.render. durer keeps the scene's build
(compile, tables, BVH) from the warm render while the scene is unchanged (rendering/builds.py; its check, the
scene's fingerprint, is timed), as Mitsuba builds its tree once in load_file (not timed). Mitsuba's log goes to
stderr. Reported: median seconds per sample per pixel (the time of one sample for the whole image), wall and
process CPU over all threads, and the ratios durer / scalar_rgb and durer / llvm_ad_rgb of wall time with their
medians over the scenes.

    DURER_SHARED=../shared PYTHONPATH=src python benchmarks/pathtrace_set.py [--res 128] [--spp 16] [--rounds 3]
        [--only WORD ...] [--skip-llvm] [--rest 0.3] [--diffuse]

--diffuse replaces every BSDF of the scene's files by Mitsuba's default `diffuse` (its id kept, so references still
resolve; textures, maps, blends and two-sided wrappers go with it): both engines then do the same walks with
trivial shading, which compares their traversal (issue 21 item 3's split; benchmarks/split_bounce.py).

llvm_ad_rgb needs Debian's libllvm19; DRJIT_LIBLLVM_PATH is set to it when present.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import tempfile
import time
from pathlib import Path

LLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
if os.path.exists(LLVM):
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", LLVM)

import numpy as np  # noqa: E402

import durer  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
sys.path.insert(0, str(ROOT / "tests"))
from mitsuba_references import SCENES, mirror  # noqa: E402
from test_project_mitsuba_scenes import LOADABLE  # noqa: E402

INCLUDE = re.compile(r'<include\s+filename="([^"]+)"')
SIZE = re.compile(r'(<integer\s+name="(width|height)"\s+value=")([^"]+)(")')
DEFAULT = re.compile(r'<default\s+name="(\w+)"\s+value="([^"]+)"')


def film_file(path: Path) -> Path | None:
    """The file (path itself or one it includes, depth first) that holds the scene's <film>."""
    text = path.read_text()
    if "<film" in text:
        return path
    for inc in INCLUDE.findall(text):
        found = film_file(path.parent / inc)
        if found is not None:
            return found
    return None


def resize(scene: Path, longer: int) -> tuple[int, int]:
    """Give the mirrored scene `scene` a film `longer` pixels on its longer side (same aspect, no crop), writing the
    size as literals into a copy of the file that holds the film; returns (width, height)."""
    film = film_file(scene)
    text = film.read_text()
    defaults = dict(DEFAULT.findall(scene.read_text())) | dict(DEFAULT.findall(text))
    start = text.index("<film")
    end = text.index("</film>", start)
    body = text[start:end]
    size = {m.group(2): m.group(3) for m in SIZE.finditer(body)}
    w, h = (int(defaults[v[1:]] if v.startswith("$") else v) for v in (size["width"], size["height"]))
    scale = longer / max(w, h)
    new = {"width": max(1, round(w * scale)), "height": max(1, round(h * scale))}
    body = SIZE.sub(lambda m: f"{m.group(1)}{new[m.group(2)]}{m.group(4)}", body)
    body = re.sub(r'<integer\s+name="crop_\w+"[^>]*/>', "", body)
    text = text[:start] + body + text[end:]
    film.unlink()
    film.write_text(text)
    return new["width"], new["height"]


def diffuse_only(scene: Path) -> None:
    """Rewrite the mirrored scene file and every file it includes with each outermost <bsdf> replaced by a plain
    `diffuse` of the same id and name (Mitsuba's default reflectance 0.5)."""
    import xml.etree.ElementTree as ET

    for inc in INCLUDE.findall(scene.read_text()):
        diffuse_only(scene.parent / inc)
    tree = ET.parse(scene)

    def walk(node):
        for k, child in enumerate(list(node)):
            if child.tag == "bsdf":
                keep = {a: child.attrib[a] for a in ("id", "name") if a in child.attrib}
                node.remove(child)
                node.insert(k, ET.Element("bsdf", {"type": "diffuse", **keep}))
            else:
                walk(child)
    walk(tree.getroot())
    text = ET.tostring(tree.getroot(), encoding="unicode")
    scene.unlink()
    scene.write_text(text)


def time_call(fn) -> tuple[object, float, float]:
    start, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - start, time.process_time() - cpu


def mitsuba_log_to_stderr(mi) -> None:
    """Mitsuba's log lines (WARN on loading some scenes) to stderr: on stdout they landed inside the Markdown table.
    The logger is the process's (render threads log through it too)."""

    class ToStderr(mi.Appender):
        def append(self, level, text):
            print(text, file=sys.stderr, flush=True)

        def log_progress(self, progress, name, formatted, eta, ptr=None):
            pass

    logger = mi.logger() if hasattr(mi, "logger") else mi.Thread.thread().logger()
    logger.clear_appenders()
    logger.add_appender(ToStderr())


def mitsuba_renderer(variant: str, xml: Path, spp: int):
    """A function rendering the scene with Mitsuba `variant` (loaded once, untimed) and returning its image."""
    import mitsuba as mi

    mi.set_variant(variant)
    mitsuba_log_to_stderr(mi)
    scene = mi.load_file(str(xml))

    def render(seed: int):
        mi.set_variant(variant)
        return np.array(mi.render(scene, seed=seed, spp=spp))[..., :3]
    return render


def durer_renderer(xml: Path, spp: int):
    scene = durer.load(xml)

    def render(seed: int):
        return durer.render(scene, samples=spp, seed=seed).color
    return render


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--res", type=int, default=128, help="pixels on the film's longer side")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=3, help="timed renders per engine and scene")
    ap.add_argument("--only", nargs="*", default=[], help="scenes whose path contains one of these words")
    ap.add_argument("--skip-llvm", action="store_true")
    ap.add_argument("--diffuse", action="store_true", help="every BSDF replaced by a plain diffuse in both engines")
    ap.add_argument("--rest", type=float, default=0.3, help="seconds of rest before each timed render (the previous "
                    "engine's worker threads go idle)")
    a = ap.parse_args()
    import mitsuba as mi

    engines = ["durer", "scalar_rgb"] + ([] if a.skip_llvm or "llvm_ad_rgb" not in mi.variants() else
                                         ["llvm_ad_rgb"])
    names = [n for n in LOADABLE if not a.only or any(w in n for w in a.only)]
    load, now = os.getloadavg()[0], time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    print(f"{a.res} px on the longer side, {a.spp} spp, {a.rounds} rounds, {a.rest} s rest before each, median s/spp "
          f"wall / CPU; "
          f"{os.cpu_count()} CPU cores, load {load:.1f} at the start, {now}\n")
    head = " | ".join(f"{e} wall / CPU" for e in engines)
    llvm = "llvm_ad_rgb" in engines
    print(f"| scene | size | {head} | durer / scalar wall (CPU) |" + (" durer / llvm wall (CPU) |" if llvm else ""))
    print("|---|---|" + "---|" * len(engines) + "---|" + ("---|" if llvm else ""), flush=True)
    ratios = {k: [] for k in ("scalar wall", "scalar cpu", "llvm wall", "llvm cpu")}
    for name in names:
        with tempfile.TemporaryDirectory() as tmp:
            root = mirror(Path(tmp) / "scenes", SCENES)
            xml = root / name
            w, h = resize(xml, a.res)
            if a.diffuse:
                diffuse_only(xml)
            render = {e: durer_renderer(xml, a.spp) if e == "durer" else mitsuba_renderer(e, xml, a.spp)
                      for e in engines}
            for e in engines:
                render[e](0)  # warm: compilation, first touch
            wall = {e: [] for e in engines}
            cpu = {e: [] for e in engines}
            for r in range(a.rounds):
                for e in engines[r % len(engines):] + engines[:r % len(engines)]:
                    time.sleep(a.rest)
                    _, sec, cpu_sec = time_call(lambda f=render[e], r=r: f(1 + r))
                    wall[e].append(sec / a.spp)
                    cpu[e].append(cpu_sec / a.spp)
        med = {e: float(np.median(wall[e])) for e in engines}
        mcpu = {e: float(np.median(cpu[e])) for e in engines}
        cells = " | ".join(f"{med[e]:.4f} / {mcpu[e]:.4f}" for e in engines)
        row = f"| {name.split('/')[-1]} | {w}x{h} | {cells} |"
        for other, key in (("scalar_rgb", "scalar"), ("llvm_ad_rgb", "llvm")):
            if other in engines:
                ratios[key + " wall"].append(med["durer"] / med[other])
                ratios[key + " cpu"].append(mcpu["durer"] / mcpu[other])
                row += f" {ratios[key + ' wall'][-1]:.2f} ({ratios[key + ' cpu'][-1]:.2f}) |"
        print(row, flush=True)
    tail = f"| **median** ({len(names)} scenes) | |" + " |" * len(engines)
    for key in ("scalar", "llvm") if llvm else ("scalar",):
        tail += f" **{np.median(ratios[key + ' wall']):.2f}** ({np.median(ratios[key + ' cpu']):.2f}) |"
    print(tail)
    print(f"\nload {os.getloadavg()[0]:.1f} at the end; durer / scalar wall {min(ratios['scalar wall']):.2f}-"
          f"{max(ratios['scalar wall']):.2f}, CPU {min(ratios['scalar cpu']):.2f}-{max(ratios['scalar cpu']):.2f}"
          + (f"; durer / llvm wall {min(ratios['llvm wall']):.2f}-{max(ratios['llvm wall']):.2f}, CPU "
             f"{min(ratios['llvm cpu']):.2f}-{max(ratios['llvm cpu']):.2f}" if llvm else ""))


if __name__ == "__main__":
    main()
