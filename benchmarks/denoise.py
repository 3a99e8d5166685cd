"""Denoising (issue 24): the error of OIDN-denoised path-traced renders at 4, 16 and 64 spp next to undenoised
renders at 16-1024 spp, and the denoiser's time.

Scenes: the Cornell box (examples/cornell_box.xml), and the set: every scene of ../shared/scenes/mitsuba/ that durer
loads (the others are listed with the reason; the 21 of tests/test_project_mitsuba_scenes.LOADABLE). Each is
rendered with its longer side --res pixels. Error: RMSE (linear radiance, every channel) against durer's own
high-sample reference (--ref-spp, other seeds; cached in benchmarks/out/), the mean over --seeds renders up to 128 spp
(one render's error at low spp is set by a few firefly pixels), with the emitters' own pixels left out (every pixel
where one of 1024 samples of a max_depth=1 render sees an emitter). Targets: denoised at 16 spp below undenoised at
128 spp on the Cornell box and on the median scene of the set (the ratio of the two errors, median over the set, the
upper one for an even count); the denoiser under 10% of a 16-spp render's time at 512 x 512 (Cornell box; CPU time,
as the machine is shared). --picture writes the side-by-side image of the README. --noisy picks the undenoised
sample counts (the set of 21 scenes at every count and a 4096-spp reference is hours on a loaded 2-core machine).

    PYTHONPATH=src python benchmarks/denoise.py [--quick] [--res 128] [--ref-spp 4096] [--seeds 3] [--noisy 16 128]
        [--quality high balanced fast] [--denoised 16] [--only TEXT ...] [--jsonl FILE] [--timing-only]
        [--timing-set] [--picture PNG]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

import durer
from durer.errors import SceneError
from durer.rendering.denoise import PIXEL_FILTER, QUALITY, clean_features, denoise, split_part
from durer.rendering.renderer import denoise_result, make_context, render_in, resolve

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "out"
# ../shared beside the repository (a worktree in wt/ has it one folder further up)
SHARED = next((p / "shared" / "scenes" / "mitsuba" for p in (ROOT.parent, ROOT.parent.parent)
               if (p / "shared" / "scenes" / "mitsuba").is_dir()), ROOT.parent / "shared" / "scenes" / "mitsuba")
CORNELL = ROOT / "examples" / "cornell_box.xml"
DENOISED_SPP = (4, 16, 64)
NOISY_SPP = (16, 32, 64, 128, 256, 512, 1024)
# the ways of filming a denoised render, both measured on the same samples: "box", the previous round's (every
# output box-filtered, the directly seen emission kept out of OIDN's input and added back); "scene", durer's
# (rendering/denoise.py: OIDN's box-filtered output filtered by the scene's filter, the emission filmed by it)
WAYS = ("box", "scene")


def scene_set() -> tuple[list[Path], list[str]]:
    """The set's scene files durer loads, and a line for each it does not."""
    found, skipped = [], []
    for path in sorted(SHARED.glob("**/*.xml")):
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


def reference(path: Path, scene: durer.Scene, res: int, spp: int, chunks: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(mean, variance of the mean) of a `spp`-sample reference (H, W, 3): `chunks` independent renders (seeds
    1000 + k) of spp / chunks samples each, the variance from their spread (each chunk keeps its own stratified
    stream, so this is the reference's true variance, not an i.i.d. bound); chunks 0: the earlier references
    (chunks of 1024 spp, variance unknown: zeros). Cached in benchmarks/out/."""
    per = spp // chunks if chunks else min(spp, 1024)
    n = spp // per
    cache = OUT / (f"denoise_ref_{path.stem}_{res}_{spp}_k{chunks}.npz" if chunks
                   else f"denoise_ref_{path.stem}_{res}_{spp}.npy")
    if cache.exists():
        if not chunks:
            img = np.load(cache)
            return img, np.zeros_like(img)
        z = np.load(cache)
        return z["mean"], z["var"]
    start = time.perf_counter()
    total, squares = np.zeros(size(scene, res)[::-1] + (3,)), np.zeros(size(scene, res)[::-1] + (3,))
    for k in range(n):  # chunks of independent seeds: the same estimator, bounded memory
        c = durer.render(scene, *size(scene, res), samples=per, seed=1000 + k).color.astype(np.float64)
        total += c
        squares += c * c
    mean = total / n
    var = np.maximum(squares / n - mean * mean, 0.0) / (n - 1) if n > 1 else np.zeros_like(mean)
    print(f"# reference {path.stem}: {spp} spp ({n} x {per}) at {res} px, {time.perf_counter() - start:.0f} s",
          flush=True)
    OUT.mkdir(parents=True, exist_ok=True)
    if chunks:
        np.savez(cache, mean=mean, var=var)
    else:
        np.save(cache, mean)
    return mean, var


def emitter_pixels(path: Path, scene: durer.Scene, res: int) -> np.ndarray:
    """Pixels where some of 1024 samples sees an emitter directly (max_depth 1 shows emitters only): the emitters'
    own pixels, their partly covered edge pixels included (cached beside the reference)."""
    cache = OUT / f"denoise_emitters_{path.stem}_{res}.npy"
    if cache.exists():
        return np.load(cache)
    seen = durer.render(scene, *size(scene, res), samples=1024, max_depth=1, seed=5).color.max(axis=2) > 0
    OUT.mkdir(parents=True, exist_ok=True)
    np.save(cache, seen)
    return seen


def rmse(a: np.ndarray, ref: tuple[np.ndarray, np.ndarray], keep: np.ndarray) -> float:
    """RMSE of a against the reference's mean over the kept pixels, the reference's own variance taken out: for a
    render independent of the reference E|a - r|^2 = MSE(a) + Var(r), so mean |a - r|^2 - mean Var(r) is an
    unbiased estimate of a's MSE against the converged image (0 for a reference without a variance)."""
    mean, var = ref
    return float(np.sqrt(max(0.0, np.mean((a[keep] - mean[keep]) ** 2) - np.mean(var[keep]))))


def denoised_renders(scene: durer.Scene, wh: tuple[int, int], n: int, seed: int, qualities) -> dict:
    """{(quality, way): denoised colour} of one set of samples (WAYS), and {quality: OIDN's seconds} of durer's."""
    out, seconds = {}, {}
    box = durer.render(scene, *wh, samples=n, seed=seed, aovs=True, **PIXEL_FILTER)
    clean = clean_features(scene.materials, path=True)
    width, height, options = resolve(scene, *wh, samples=n, seed=seed, denoise=True)
    ctx = make_context(scene, options)
    raw = render_in(ctx, width, height)
    for q in qualities:
        out[q, "box"] = denoise(box.color, box.albedo, box.shading_normals, clean=clean, quality=q,
                                direct=split_part(box.aovs)).color
        done = denoise_result(replace(raw), ctx.bundle.materials, replace(options, denoise_quality=q))
        out[q, "scene"], seconds[q] = done.color, done.denoise_seconds
    return dict(images=out, seconds=seconds)


def errors(path: Path, res: int, refs, noisy_spp, denoised_spp, qualities, seeds: int, chunks: int = 0) -> dict:
    """RMSE against the reference of noisy renders {spp: e} and of denoised ones {quality: {way: {spp: e}}}
    (WAYS, on the same samples, at each OIDN quality), each the mean over `seeds` seeds (one above 128 spp: one
    run's error at low spp is set by a few firefly pixels), and OIDN's mean seconds (durer's way). `refs`: the
    references' sample counts; the same renders are scored against each (by_ref), the first in noisy/denoised."""
    scene = durer.load(path)
    references = {spp: reference(path, scene, res, spp, chunks) for spp in refs}
    keep = ~emitter_pixels(path, scene, res)
    wh = size(scene, res)
    noisy = {spp: {n: [] for n in noisy_spp} for spp in refs}
    for n in noisy_spp:
        for k in range(1, 1 + (seeds if n <= 128 else 1)):
            image = durer.render(scene, *wh, samples=n, seed=k).color
            for spp, ref in references.items():
                noisy[spp][n].append(rmse(image, ref, keep))
    denoised = {spp: {q: {w: {n: [] for n in denoised_spp} for w in WAYS} for q in qualities} for spp in refs}
    seconds = {q: [] for q in qualities}
    for n in denoised_spp:
        for k in range(1, 1 + seeds):
            d = denoised_renders(scene, wh, n, k, qualities)
            for (q, way), image in d["images"].items():
                for spp, ref in references.items():
                    denoised[spp][q][way][n].append(rmse(image, ref, keep))
            for q, t in d["seconds"].items():
                seconds[q].append(t)
    by_ref = {spp: dict(noisy={n: float(np.mean(v)) for n, v in noisy[spp].items()},
                        denoised={q: {w: {n: float(np.mean(v)) for n, v in e.items()} for w, e in ways.items()}
                                  for q, ways in denoised[spp].items()}) for spp in refs}
    return dict(**by_ref[refs[0]], by_ref=by_ref, seconds={q: float(np.mean(v)) for q, v in seconds.items()},
                ref_chunks=chunks, clean=clean_features(scene.materials, path=True),
                filter=scene.render_defaults.get("filter", "box"))


def oidn_threads(r, quality: str, threads: int) -> None:
    """OIDN's RT filter on r's colour and features (as denoise() with clean features) on a device of its own
    limited to `threads` threads (0: OIDN's default, every core), to time its thread count against the render's."""
    import pyoidn

    images = [np.ascontiguousarray(a, dtype=np.float32) for a in
              (np.maximum(r.color, 0.0), np.clip(r.albedo, 0.0, 1.0), np.clip(r.shading_normals, -1.0, 1.0))]
    out = np.empty_like(images[0])
    with pyoidn.Device() as device:
        device.set_int("numThreads", threads)
        device.commit()
        with pyoidn.Filter(device, pyoidn.OIDN_FILTER_TYPE_RT) as flt:
            for name, image in zip(("color", "albedo", "normal", "output"), images + [out], strict=True):
                flt.set_image(name, image, pyoidn.OIDN_FORMAT_FLOAT3)
            flt.set_bool("hdr", True)
            flt.set_bool("cleanAux", True)
            flt.set_quality({"high": 6, "balanced": 5, "fast": 4}[quality])
            flt.commit()
            flt.execute()


def timing(qualities, res: int = 512, spp: int = 16) -> dict:
    """A 16-spp render of the Cornell box at 512 x 512 without features, with them, and OIDN on it at each quality
    (through denoise(), and on devices of 1 and 2 threads, weights loaded and filter built included): (wall, CPU)
    seconds, the CPU time of every thread of the process (the share that stays put on a shared machine), best of two
    each after a warm-up."""
    scene = durer.load(CORNELL)
    r = durer.render(scene, 32, 32, samples=2, aovs=True)  # compile
    for q in qualities:
        denoise(r.color, r.albedo, r.shading_normals, quality=q)  # load OIDN's weights

    def timed(f):
        start, cpu = time.perf_counter(), time.process_time()
        out = f()
        return out, (time.perf_counter() - start, time.process_time() - cpu)

    plain, featured, oidn = [], [], {q: [] for q in qualities}
    oidn.update({(q, n): [] for q in qualities for n in (1, 2)})
    for _ in range(2):
        plain.append(timed(lambda: durer.render(scene, res, res, samples=spp))[1])
        r, t = timed(lambda: durer.render(scene, res, res, samples=spp, aovs=True))
        featured.append(t)
        for q in qualities:
            oidn[q].append(timed(lambda q=q, r=r: denoise(r.color, r.albedo, r.shading_normals, quality=q))[1])
            for n in (1, 2):
                oidn[q, n].append(timed(lambda q=q, r=r, n=n: oidn_threads(r, q, n))[1])

    def best(ts):
        return min(t[0] for t in ts), min(t[1] for t in ts)

    return dict(plain=best(plain), featured=best(featured), oidn={q: best(v) for q, v in oidn.items()})


def set_timing(paths: list[Path], qualities, res: int = 512, spp: int = 16) -> None:
    """OIDN's CPU time as a share of each scene's 16-spp render (no features, longer side res pixels), denoise() on
    a render with features as denoise=True makes it (features prefiltered where not clean), and the median share
    over the set (the Cornell box left out, as in the error target)."""
    shares = {q: [] for q in qualities}
    for path in paths:
        scene = durer.load(path)
        wh = size(scene, res)
        durer.render(scene, 16, 16, samples=1, aovs=True)  # compile
        cpu = time.process_time()
        durer.render(scene, *wh, samples=spp)
        render = time.process_time() - cpu
        width, height, options = resolve(scene, *wh, samples=spp, denoise=True)
        ctx = make_context(scene, options)
        r = render_in(ctx, width, height)
        clean = clean_features(scene.materials, path=True)
        cells = []
        for q in qualities:
            cpu = time.process_time()
            denoise_result(replace(r), ctx.bundle.materials, replace(options, denoise_quality=q))
            oidn = time.process_time() - cpu
            if path != CORNELL:
                shares[q].append(oidn / render)
            cells.append(f"{q} {oidn:.2f} s = {100 * oidn / render:.1f}%")
        print(f"# {path.stem} {wh[0]}x{wh[1]}: render {render:.2f} s CPU, features "
              f"{'clean' if clean else 'prefiltered'}; OIDN {', '.join(cells)}", flush=True)
    for q, v in shares.items():
        v = sorted(v)
        print(f"OIDN {q}: median share of a {spp}-spp render over the set {100 * v[len(v) // 2]:.1f}%")


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
    ap.add_argument("--res", type=int, default=128, help="longer image side of the error renders (default 128)")
    ap.add_argument("--ref-spp", type=int, nargs="+", default=[4096],
                    help="samples of the reference (default 4096); several: the same renders scored against each")
    ap.add_argument("--ref-chunks", type=int, default=0,
                    help="references as this many independent renders, their variance taken out of each error "
                         "(rmse); 0 (default): chunks of 1024 spp, no variance")
    ap.add_argument("--seeds", type=int, default=3, help="renders (seeds) averaged per error up to 128 spp (default 3)")
    ap.add_argument("--quick", action="store_true", help="64 px, 1024-spp reference, noisy up to 256 spp")
    ap.add_argument("--quality", nargs="+", default=[QUALITY], choices=("fast", "balanced", "high"),
                    help=f"OIDN qualities to measure (default: durer's, {QUALITY})")
    ap.add_argument("--noisy", nargs="+", type=int, default=list(NOISY_SPP), metavar="SPP",
                    help="undenoised sample counts (default: 16 32 64 128 256 512 1024; 128 is the target's)")
    ap.add_argument("--timing-set", action="store_true",
                    help="also OIDN's CPU share of each scene's 16-spp render at 512 px (and its median over the set)")
    ap.add_argument("--only", nargs="+", metavar="TEXT",
                    help="only the scenes whose path contains one of these, in this order")
    ap.add_argument("--denoised", nargs="+", type=int, default=list(DENOISED_SPP), metavar="SPP",
                    help="denoised sample counts (default: 4 16 64; 16 is the target's)")
    ap.add_argument("--jsonl", type=Path, help="also append each scene's figures to this file as it is measured")
    ap.add_argument("--picture", type=Path, help="also write the README's side-by-side PNG here")
    ap.add_argument("--no-timing", action="store_true", help="skip the 512 x 512 timing")
    ap.add_argument("--timing-only", action="store_true", help="only the 512 x 512 timing (and --picture)")
    a = ap.parse_args()
    res, ref_spp, noisy_spp, qualities = a.res, a.ref_spp, tuple(sorted(set(a.noisy))), a.quality
    denoised_spp = tuple(sorted(set(a.denoised)))
    if a.quick:
        res, ref_spp, noisy_spp = 64, [1024], tuple(n for n in noisy_spp if n <= 256)
    if a.timing_only:
        found, skipped = [], []
    else:
        found, skipped = scene_set()
    paths = [] if a.timing_only else [CORNELL] + found
    if a.only:
        paths = [p for t in a.only for p in paths if t in str(p)]
    if not a.timing_only:
        print(f"# {res} px on the longer side; reference {ref_spp} spp (durer, other seeds); RMSE without the "
              f"emitters' own pixels, mean over {a.seeds} seeds up to 128 spp; denoised as durer does (scene); "
              f"ratios: denoised 16 spp / noisy 128 spp, filmed {' / '.join(WAYS)}")
        for line in skipped:
            print(f"# not loaded: {line}")
        head = " | ".join([f"noisy {n}" for n in noisy_spp] + [f"{q} {n}" for q in qualities for n in denoised_spp])
        ratio_head = " | ".join(f"{q} {w}" for q in qualities for w in WAYS)
        print(f"\n| scene | {head} | {ratio_head} | OIDN s ({', '.join(qualities)}) |")
        print("|---" * (len(noisy_spp) + len(qualities) * (len(denoised_spp) + len(WAYS)) + 2) + "|")
    ratios = {(q, w): {} for q in qualities for w in WAYS}
    for path in paths:
        e = errors(path, res, ref_spp, noisy_spp, denoised_spp, qualities, a.seeds, a.ref_chunks)
        base = e["noisy"][128 if 128 in e["noisy"] else max(e["noisy"])]
        at = 16 if 16 in denoised_spp else denoised_spp[0]
        for q, w in ratios:
            ratios[q, w][path] = e["denoised"][q][w][at] / base
        cells = [f"{e['noisy'][n]:.4f}" for n in noisy_spp]
        cells += [f"{e['denoised'][q]['scene'][n]:.4f}" for q in qualities for n in denoised_spp]
        cells += [f"{ratios[q, w][path]:.2f}" for q in qualities for w in WAYS]
        name = path.relative_to(SHARED) if SHARED in path.parents else path.relative_to(ROOT)
        clean = "" if e["clean"] else " (features prefiltered)"
        seconds = " / ".join(f"{e['seconds'][q]:.3f}" for q in qualities)
        print(f"| {name}{clean} | {' | '.join(cells)} | {seconds} |", flush=True)
        if a.jsonl:
            with a.jsonl.open("a") as f:
                f.write(json.dumps(dict(scene=str(name), res=res, ref_spp=ref_spp, seeds=a.seeds, **e)) + "\n")
    print()
    for q, w in [] if a.timing_only else ratios:
        in_set = sorted(ratios[q, w][p] for p in found if p in ratios[q, w])
        median = in_set[len(in_set) // 2] if in_set else float("nan")
        cornell = ratios[q, w].get(CORNELL, float("nan"))
        print(f"Target ({q}, filmed {w}): denoised 16 spp below noisy 128 spp: Cornell box {cornell:.2f} "
              f"({'met' if cornell < 1 else 'NOT met'}), median scene of the set ({len(in_set)} of {len(found)} "
              f"scenes) {median:.2f} ({'met' if median < 1 else 'NOT met'})")
    if not a.no_timing:
        t = timing(qualities)
        (pw, pc), (fw, fc) = t["plain"], t["featured"]
        print(f"\n16-spp 512x512 Cornell box: render {pw:.2f} s wall / {pc:.2f} s CPU, with features {fw:.2f} / "
              f"{fc:.2f} s (+{100 * (fc / pc - 1):.1f}% CPU)")
        for q in qualities:
            ow, oc = t["oidn"][q]
            print(f"Target ({q}): denoiser under 10% of the render: OIDN {ow:.2f} s wall = {100 * ow / pw:.1f}%, "
                  f"{oc:.2f} s CPU = {100 * oc / pc:.1f}% ({'met' if oc / pc < 0.1 else 'NOT met'} by CPU time); "
                  f"with the features' cost {100 * (fc + oc - pc) / pc:.1f}% CPU")
            for n in (1, 2):
                ow, oc = t["oidn"][q, n]
                print(f"    OIDN {q} on {n} thread{'s' * (n > 1)}: {ow:.2f} s wall = {100 * ow / pw:.1f}%, {oc:.2f} s "
                      f"CPU = {100 * oc / pc:.1f}%")
    if a.timing_set:
        set_timing([CORNELL] + (found or scene_set()[0]), qualities)
    if a.picture:
        picture(a.picture)


if __name__ == "__main__":
    main()
