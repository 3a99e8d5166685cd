"""Variants of a denoised render's processing (issue 24, session 19), scored on the same 16-spp renders: the ratio of
the denoised RMSE (mean over --seeds) to a given noisy-128 RMSE, against denoise.py's cached corrected reference
(--res, 256 spp in 8 chunks) without the emitters' pixels. A variant is a preset and modifiers joined by ':':

    blend=S,R   the blend's variance scale S and window radius R (durer: 2,3); noblend: OIDN's output as it is
    prefilter   the features prefiltered by their own RT filters (as for noisy features)
    scale=X     OIDN's inputScale X (durer: OIDN's auto exposure)
    view        the normal feature in camera space (durer: world space)
    clamp=K     the colour's pixels above K times their 7 x 7 window's mean luminance scaled down to it
    demod       the colour divided by the albedo before OIDN (albedo feature 1) and multiplied back after

    PYTHONPATH=src python benchmarks/denoise_variants.py SCENE_TEXT NOISY128_RMSE [--seeds 3] [--res 512]
        [--variants fast fast:view ...]
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np
from denoise import CORNELL, emitter_pixels, reference, rmse, scene_set, size

import durer
from durer.rendering import denoise as dn
from durer.rendering.renderer import denoise_result, make_context, render_in, resolve


def oidn(color, albedo, normal, quality: str, scale: float | None) -> np.ndarray:
    """OIDN's RT filter (clean features) with an optional inputScale, on a device and filter of its own."""
    import pyoidn

    out = np.empty_like(color)
    with pyoidn.Device() as device:
        device.commit()
        with pyoidn.Filter(device, pyoidn.OIDN_FILTER_TYPE_RT) as flt:
            for name, image in (("color", color), ("albedo", albedo), ("normal", normal), ("output", out)):
                flt.set_image(name, image, pyoidn.OIDN_FORMAT_FLOAT3)
            flt.set_bool("hdr", True)
            flt.set_bool("cleanAux", True)
            flt.set_quality(dn._QUALITY_CODES[quality])
            if scale is not None:
                flt.set_float("inputScale", scale)
            flt.commit()
            flt.execute()
    return out


def variant(raw, options, materials, scene, spec: str) -> np.ndarray:
    """The denoised colour of one render under the variant `spec` (module docstring)."""
    quality, *mods = spec.split(":")
    mods = dict(m.split("=") if "=" in m else (m, "") for m in mods)
    saved = dn.clean_features, dn.blend, dn.denoise
    try:
        if "prefilter" in mods:
            dn.clean_features = lambda materials, path: False
        if "noblend" in mods:
            dn.blend = lambda denoised, *args, **kw: denoised
        elif "blend" in mods:
            s, r = mods["blend"].split(",")
            dn.blend = lambda *args, **kw: saved[1](*args, scale=float(s), radius=int(r))
        if {"scale", "view", "clamp", "demod"} & set(mods):
            def custom(color, albedo, normal, *, clean=True, quality=quality, direct=None):
                c = dn._image(np.maximum(np.nan_to_num(color, posinf=0.0), 0.0))
                a, n = dn._image(np.clip(albedo, 0.0, 1.0)), dn._image(np.clip(normal, -1.0, 1.0))
                if "view" in mods:
                    f = np.asarray(scene.camera.direction, float)
                    f /= np.linalg.norm(f)
                    right = np.cross(f, np.asarray(scene.camera.up, float))
                    right /= np.linalg.norm(right)
                    n = dn._image(np.stack([n @ right, n @ np.cross(right, f), -(n @ f)], -1))
                if "clamp" in mods:
                    lum = c.mean(-1)
                    limit = float(mods["clamp"]) * dn.window_mean(lum, 3) + 1e-3
                    c = dn._image(np.where((lum > limit)[..., None], c * (limit / np.maximum(lum, 1e-12))[..., None],
                                           c))
                modulate = np.where(a > 0.01, a, 1.0).astype(np.float32) if "demod" in mods else 1.0
                if "demod" in mods:
                    c, a = dn._image(c / modulate), np.ones_like(a)
                scale = float(mods["scale"]) if "scale" in mods else None
                return dn.Denoised((oidn(c, a, n, quality, scale) * modulate).astype(np.float32), 0.0)
            dn.denoise = custom
        return denoise_result(replace(raw), materials, replace(options, denoise_quality=quality)).color
    finally:
        dn.clean_features, dn.blend, dn.denoise = saved


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", help="text in the scene file's path (the set or the Cornell box)")
    ap.add_argument("noisy128", type=float, help="the noisy 128-spp RMSE the ratios are to (denoise.py's figure)")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--res", type=int, default=512)
    ap.add_argument("--variants", nargs="*", default=["fast", "high", "fast:noblend", "fast:prefilter"])
    a = ap.parse_args()
    path = next(p for p in scene_set()[0] + [CORNELL] if a.scene in str(p))
    scene = durer.load(path)
    ref, keep = reference(path, scene, a.res, 256, 8), ~emitter_pixels(path, scene, a.res)
    errors = {v: [] for v in a.variants}
    for seed in range(1, a.seeds + 1):
        width, height, options = resolve(scene, *size(scene, a.res), samples=16, seed=seed, denoise=True)
        ctx = make_context(scene, options)
        raw = render_in(ctx, width, height)
        for v in a.variants:
            errors[v].append(rmse(variant(raw, options, ctx.bundle.materials, scene, v), ref, keep))
    for v, e in errors.items():
        print(f"{path.stem} {v}: {np.mean(e) / a.noisy128:.4f} ({' '.join(f'{x / a.noisy128:.4f}' for x in e)})")


if __name__ == "__main__":
    main()
