"""Denoising with Intel Open Image Denoise (OIDN, through the optional `pyoidn` package: `pip install
durer[denoise]`).

OIDN's `RT` filter takes the noisy linear colour (HDR) and two feature images the renderer produces noise-free or
nearly so: the albedo and the shading normal of each pixel's first non-specular hit (kernels/path/bounce.py,
rendering/whitted.py), filtered like the colour. When the features carry noise of their own (a glass's stochastic
Fresnel choice, a solid texture picked per sample), OIDN's recommended "prefiltering" is applied: each feature is
denoised by its own RT filter first, and the colour filter is then told they are clean (`cleanAux`).

The path tracer's colour is denoised without the emission the camera sees directly or through mirrors and glass
(its `emission` output, kernels/path/bounce.py): OIDN takes a light's hard HDR edge for noise and blurs it into
the surfaces around it, so that part goes around the denoiser and is added back to its output. SPLIT names the
outputs kept out: surface emitters only; the environment seen directly stays in (benchmarks/README.md).

The film of a denoised render (units._gather_denoised): the denoiser's inputs (the colour less the split part, the
features) are filtered by a one-pixel box (PIXEL_FILTER), whatever the scene asks for: a wider reconstruction
filter spreads each sample over several pixels, and OIDN takes the correlated noise for detail (the roulette scene
of ../shared, filtered by its tent: 0.0039-0.0050 RMSE at 16 spp, by the box: 0.0030-0.0035). OIDN's output is
then filtered by the scene's filter as an image (refilter: each neighbour pixel weighed by the filter's mean over
it), and the split part, filmed by the scene's filter from its samples, is added back: the denoised image has the
pixel filter of the scene's own render (Mitsuba's default gaussian for most scenes; benchmarks/README.md).
"""

from __future__ import annotations

import atexit
import math
import threading
import time
from dataclasses import dataclass

import numba as nb
import numpy as np

from ..errors import MissingDependency
from ..kernels.common import JIT
from ..options import RenderOptions
from ..scene.bsdfs import Dielectric, Mask, Surface, TwoSided
from ..scene.materials import PhongMaterial
from ..scene.textures import Checkerboard, Texture
from .film import filter_weight, support_radius

INSTALL = 'denoising needs Intel Open Image Denoise\'s Python binding: pip install "durer[denoise]"'
QUALITY = "high"  # OIDN's own default preset; RenderOptions.denoise_quality picks another (benchmarks/README.md)
_QUALITY_CODES = {"high": 6, "balanced": 5, "fast": 4}  # OIDN_QUALITY_HIGH, _BALANCED, _FAST
SPLIT = ("emission",)  # RenderResult outputs kept out of OIDN's input and added back (module docstring)
PIXEL_FILTER = {"filter": "box", "filter_radius": 0.5}  # the film of the denoiser's input (module docstring)
MOMENT = "second_moment"  # a denoised render's output (H, W, 1): each pixel's mean squared norm of the denoiser input
BLEND_RADIUS = 3  # blend's window: the squared differences and variances are averaged over 7 x 7 pixels
BLEND_SCALE = 2.0  # blend's variance factor: scale 1 raised the Cornell box's error 0.3% (benchmarks/README.md)
QUADRATURE = 64  # pixel_weights' points per pixel side (the midpoint rule within 0.05% on the gaussian)


def require_oidn():
    """The pyoidn module, or MissingDependency, one line saying what to install (called before rendering)."""
    try:
        import pyoidn
    except ImportError:
        raise MissingDependency(INSTALL) from None
    return pyoidn


@dataclass
class Denoised:
    """The denoised colour (H, W, 3) float32 and the seconds OIDN took (prefiltering included)."""

    color: np.ndarray
    seconds: float


def clean_features(materials: list, path: bool) -> bool:
    """Are the features noise-free apart from antialiasing, so OIDN may take them as they are (cleanAux)? The ray
    caster's and the Whitted tracer's are (they follow every mirror and refraction ray); the path tracer's are not
    when a path's first non-specular hit is chosen at random: behind a smooth dielectric (reflect or refract, by
    Fresnel) or a course material with both a mirror and a transparent lobe and no smooth one, or on a blending
    solid texture (noise, marble, wood: one of its two materials picked per sample by the blend weight). A
    checkerboard's weight is 0 or 1, so its pick is the same for every sample of a point: clean, and prefiltering
    its scenes' features changed their denoised error by under 1% for two to four times OIDN's time. Mitsuba's
    textures are looked up, not picked (clean); a mask lets a random share of the paths through (not clean)."""
    if not path:
        return True
    for m in materials:
        if isinstance(m, Texture.__args__) and not isinstance(m, Checkerboard):
            return False
        if isinstance(m, Surface):
            m = m.bsdf
        if isinstance(m, Mask):
            return False
        if isinstance(m, TwoSided):
            m = m.bsdf
        if isinstance(m, Dielectric):
            return False
        if isinstance(m, PhongMaterial):
            smooth = max(m.diffuse_color) > 0 or max(m.specular_color) > 0
            if not smooth and max(m.reflective_color) > 0 and max(m.transparent_color) > 0:
                return False
    return True


def split_part(aovs: dict[str, np.ndarray], split: tuple[str, ...] = SPLIT) -> np.ndarray | None:
    """The sum of the render outputs named in split (RenderResult.aovs), the part of the colour denoise() keeps
    out; None when the integrator reports none of them (the ray caster, the Whitted tracer)."""
    parts = [aovs[name] for name in split if aovs.get(name) is not None]
    return sum(parts[1:], parts[0]) if parts else None


def denoise(color: np.ndarray, albedo: np.ndarray, normal: np.ndarray, *, clean: bool = True,
            quality: str = QUALITY, direct: np.ndarray | None = None) -> Denoised:
    """OIDN's RT filter on linear HDR colour (H, W, 3) with albedo and normal features (H, W, 3). `clean` says the
    features are noise-free (else each is prefiltered first); `direct` (H, W, 3), a part of the colour kept out of
    the filter's input and added back to its output (split_part). Raises MissingDependency without pyoidn."""
    oidn = require_oidn()
    start = time.perf_counter()
    color = np.nan_to_num(color, posinf=0.0)
    if direct is not None:
        direct = np.nan_to_num(direct, posinf=0.0)
        color = color - direct
    color = _image(np.maximum(color, 0.0))  # OIDN's HDR input: finite, non-negative
    albedo = _image(np.clip(albedo, 0.0, 1.0))
    normal = _image(np.clip(normal, -1.0, 1.0))
    if not clean:
        albedo, normal = _prefilter(oidn, albedo, normal, quality)
    out = np.asarray(oidn.denoise(color, albedo, normal, hdr=True, clean_aux=True, quality=quality), np.float32)
    if direct is not None:
        out = out + direct.astype(np.float32)
    return Denoised(out, time.perf_counter() - start)


def blend(denoised: np.ndarray, noisy: np.ndarray, moment: np.ndarray, samples: int,
          radius: int = BLEND_RADIUS, scale: float = BLEND_SCALE) -> np.ndarray:
    """The denoised image (H, W, 3) moved toward the noisy one where it differs from it by more than the noise
    of the pixel's own samples explains: the noisy pixel's variance v summed over channels (of its mean, from the
    second moment of its `samples` box-filtered samples, (H, W, 1) the mean squared norm or (H, W, 3) per channel:
    the same sum, times `scale`) against the denoiser's bias b^2 = max(0, (denoised - noisy)^2 -
    v), both averaged over the (2 radius + 1)^2 window around the pixel and summed over channels; the MSE-optimal
    weight of the noisy pixel, b^2 / (b^2 + v), for two estimates with independent errors of those sizes. A scale
    above 1 leaves alone the differences that a 16-sample variance estimate may underrate. Non-finite noisy
    values and moments count as 0 (negative noisy values too: OIDN's input). In Numba (_blend): the NumPy
    version's temporaries took 0.025 s of CPU at 512^2, this 0.011 s (benchmarks/README.md, session 19)."""
    if samples < 2:
        return denoised
    out = np.empty(denoised.shape, np.float64)
    _blend(np.ascontiguousarray(denoised), np.ascontiguousarray(noisy), np.ascontiguousarray(moment),
           float(scale / (samples - 1)), int(radius), out)
    return out.astype(denoised.dtype)


@nb.njit(**JIT)
def _blend(denoised, noisy, moment, factor, radius, out):
    """blend's work: per pixel the variance v (times scale / (samples - 1)) and the squared difference d, their
    window means, and denoised - b^2 / (b^2 + v) (denoised - noisy) into out (float64)."""
    h, w = denoised.shape[0], denoised.shape[1]
    var, diff = np.empty((h, w)), np.empty((h, w))
    for i in range(h):
        for j in range(w):
            second, norm, dd = 0.0, 0.0, 0.0
            for c in range(moment.shape[2]):
                m = moment[i, j, c]
                second += m if math.isfinite(m) else 0.0
            for c in range(3):
                x = noisy[i, j, c]
                x = max(x, 0.0) if math.isfinite(x) else 0.0
                norm += x * x
                e = denoised[i, j, c] - x
                dd += e * e
            var[i, j] = max(second - norm, 0.0) * factor
            diff[i, j] = dd
    v, d = np.empty((h, w)), np.empty((h, w))
    _window_mean(var, radius, v)
    _window_mean(diff, radius, d)
    for i in range(h):
        for j in range(w):
            bias = max(d[i, j] - v[i, j], 0.0)
            total = bias + v[i, j]
            k = bias / total if total > 0 else 0.0
            for c in range(3):
                x = noisy[i, j, c]
                x = max(x, 0.0) if math.isfinite(x) else 0.0
                out[i, j, c] = denoised[i, j, c] - k * (denoised[i, j, c] - x)


def window_mean(a: np.ndarray, radius: int) -> np.ndarray:
    """The mean of a (H, W) over the (2 radius + 1)^2 pixels around each pixel, cropped at the border (float64)."""
    out = np.empty(a.shape)
    _window_mean(np.ascontiguousarray(a, dtype=np.float64), int(radius), out)
    return out


@nb.njit(**JIT)
def _window_mean(a, radius, out):
    """window_mean into out: each row's window sums from its running sum, then each column's, over the count of
    the cropped window's pixels (separable, float64)."""
    h, w = a.shape
    rows, run = np.empty((h, w)), np.empty(max(h, w) + 1)
    for i in range(h):
        run[0] = 0.0
        for j in range(w):
            run[j + 1] = run[j] + a[i, j]
        for j in range(w):
            lo, hi = max(0, j - radius), min(w, j + radius + 1)
            rows[i, j] = (run[hi] - run[lo]) / (hi - lo)
    for j in range(w):
        run[0] = 0.0
        for i in range(h):
            run[i + 1] = run[i] + rows[i, j]
        for i in range(h):
            lo, hi = max(0, i - radius), min(h, i + radius + 1)
            out[i, j] = (run[hi] - run[lo]) / (hi - lo)


def pixel_weights(options: RenderOptions) -> np.ndarray:
    """(2R+1, 2R+1) weights of the pixels within the filter's support radius R around a pixel: the filter's mean
    over each (midpoint rule, QUADRATURE^2 points), what a sample-filtered pixel weighs a neighbour by when the
    image is constant over each pixel. The filters are symmetric, so rows may run either way."""
    radius = support_radius(options)
    u = (np.arange(QUADRATURE) + 0.5) / QUADRATURE - 0.5
    x = (np.arange(-radius, radius + 1)[:, None] + u[None, :]).ravel()
    w = filter_weight(options, x[None, :], x[:, None])
    side = 2 * radius + 1
    return w.reshape(side, QUADRATURE, side, QUADRATURE).mean(axis=(1, 3))


def refilter(image: np.ndarray, options: RenderOptions) -> np.ndarray:
    """A box-filtered image (H, W, C) filtered by options' filter as the film filters samples: each pixel the
    pixel_weights-weighted mean of its neighbours, cropped at the border (the weights of the pixels inside the
    image summed). The box itself (a one-pixel support) returns the image unchanged. Numba: a separable filter's
    weights (Mitsuba's gaussian, mitchell, catmullrom, lanczos: an outer product) by rows, then columns (the same
    weighted mean, its cropped weight sum a product too: 2 (2R + 1) taps a pixel, not (2R + 1)^2); others by
    every tap (_refilter)."""
    weights = pixel_weights(options)
    if weights.shape[0] == 1:
        return image
    h, w = image.shape[:2]
    flat = np.ascontiguousarray(image.reshape(h, w, -1), dtype=np.float64)
    out = np.empty(flat.shape)
    u, sv, vt = np.linalg.svd(weights)
    if sv[1] <= 1e-9 * sv[0]:  # rank one: weights = outer(col, row)
        col, row = u[:, 0] * sv[0], vt[0]
        rows = np.empty(flat.shape)
        _refilter_axis(flat, row, 1, rows)
        _refilter_axis(rows, col, 0, out)
    else:
        _refilter(flat, weights, out)
    return out.reshape(image.shape).astype(image.dtype)


@nb.njit(**JIT)
def _refilter_axis(image, taps, axis, out):
    """One axis of a separable refilter: out[y, x] the taps-weighted mean of image along `axis` (0 rows, 1
    columns) around (y, x), over the taps inside the image."""
    h, w, channels = image.shape
    radius = len(taps) // 2
    n = h if axis == 0 else w
    for y in range(h):
        for x in range(w):
            at = y if axis == 0 else x
            lo, hi = max(0, radius - at), min(len(taps), n - at + radius)
            total = 0.0
            for k in range(lo, hi):
                total += taps[k]
            for c in range(channels):
                acc = 0.0
                for k in range(lo, hi):
                    if axis == 0:
                        acc += taps[k] * image[y + k - radius, x, c]
                    else:
                        acc += taps[k] * image[y, x + k - radius, c]
                out[y, x, c] = acc / total


@nb.njit(**JIT)
def _refilter(image, weights, out):
    """refilter's sums for any filter: out[y, x] = sum of weights[a, b] image[y + a - R, x + b - R] over the taps
    inside the image, over the sum of those taps' weights."""
    h, w, channels = image.shape
    side = weights.shape[0]
    radius = side // 2
    for y in range(h):
        for x in range(w):
            a0, a1 = max(0, radius - y), min(side, h - y + radius)
            b0, b1 = max(0, radius - x), min(side, w - x + radius)
            total = 0.0
            for a in range(a0, a1):
                for b in range(b0, b1):
                    total += weights[a, b]
            for c in range(channels):
                acc = 0.0
                for a in range(a0, a1):
                    for b in range(b0, b1):
                        acc += weights[a, b] * image[y + a - radius, x + b - radius, c]
                out[y, x, c] = acc / total


def _image(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32)


def _prefilter(oidn, albedo: np.ndarray, normal: np.ndarray, quality: str) -> tuple[np.ndarray, np.ndarray]:
    """Each feature denoised by an RT filter of its own (OIDN's documented prefiltering of noisy auxiliary
    images): the image goes in as the filter's `albedo` or `normal` input and comes back as its output. The device
    and a filter per (feature, quality) are kept for the process (_PREFILTERS), as pyoidn.denoise keeps the colour
    filter's: a fresh device and filter cost about 0.09 s of CPU more per feature at 512 x 512."""
    out = []
    with _PREFILTER_LOCK:
        if "device" not in _PREFILTERS:
            device = oidn.Device()
            device.commit()
            _PREFILTERS["device"] = device
            atexit.register(_release_prefilters)
        device = _PREFILTERS["device"]
        for name, image in (("albedo", albedo), ("normal", normal)):
            result = np.empty_like(image)
            flt = _PREFILTERS.get((name, quality))
            if flt is None:
                flt = _PREFILTERS[name, quality] = oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT)
                flt.set_quality(_QUALITY_CODES[quality])
            flt.set_image(name, image, oidn.OIDN_FORMAT_FLOAT3)
            flt.set_image(oidn.OIDN_IMAGE_OUTPUT, result, oidn.OIDN_FORMAT_FLOAT3)
            flt.commit()  # a new size rebuilds the filter's tiling; the same size costs nothing
            flt.execute()
            error = device.get_error()
            if error:
                flt.release()
                del _PREFILTERS[name, quality]
                raise RuntimeError(f"Open Image Denoise could not prefilter the {name}: {error}")
            out.append(result)
    return out[0], out[1]


_PREFILTERS: dict = {}  # _prefilter's OIDN device ("device") and filters ((feature, quality))
_PREFILTER_LOCK = threading.Lock()


def _release_prefilters() -> None:
    """Release the kept filters before their device (at exit)."""
    with _PREFILTER_LOCK:
        device = _PREFILTERS.pop("device", None)
        for flt in _PREFILTERS.values():
            flt.release()
        _PREFILTERS.clear()
        if device is not None:
            device.release()
