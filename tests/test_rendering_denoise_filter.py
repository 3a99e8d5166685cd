"""Issue 24, third round: the pixel filter of a denoised render. OIDN gets box-filtered inputs; its output is
filtered by the scene's filter as an image (denoise.refilter, each neighbour weighed by the filter's mean over it)
and the directly seen emission, filmed by the scene's filter from its samples, is added back."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import durer
from durer.options import RenderOptions
from durer.rendering import film
from durer.rendering.denoise import MOMENT, blend, denoise, pixel_weights, refilter

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
GAUSSIAN = {"filter": "mitsuba_gaussian", "filter_radius": 0.5}  # Mitsuba's default: sigma 0.5, zero at 4 sigma


def _gaussian_mean(i: int, sigma: float = 0.5) -> float:
    """Mitsuba's gaussian (exp(-x^2 / 2 sigma^2) - exp(-8), zero beyond 4 sigma) averaged over [i - 1/2, i + 1/2]."""
    lo, hi = max(i - 0.5, -4 * sigma), min(i + 0.5, 4 * sigma)
    if hi <= lo:
        return 0.0
    s = sigma * math.sqrt(2.0)
    return sigma * math.sqrt(math.pi / 2) * (math.erf(hi / s) - math.erf(lo / s)) - math.exp(-8.0) * (hi - lo)


def test_pixel_weights_are_the_filters_mean_over_each_pixel():
    """The box's weights are its own pixel alone; Mitsuba's separable gaussian's are the products of its
    one-axis means over each pixel (closed form with erf), to the midpoint rule's accuracy."""
    np.testing.assert_array_equal(pixel_weights(RenderOptions()), [[1.0]])
    w = pixel_weights(RenderOptions(**GAUSSIAN))
    assert w.shape == (5, 5)  # support radius 2: the filter reaches 2 pixels
    m = np.array([_gaussian_mean(i) for i in range(-2, 3)])
    np.testing.assert_allclose(w, np.outer(m, m), rtol=2e-3, atol=1e-6)
    np.testing.assert_allclose(w, w.T)


def test_refilter_keeps_constants_and_spreads_an_impulse_by_the_weights():
    rng = np.random.default_rng(3)
    image = rng.random((9, 11, 3)).astype(np.float32)
    assert refilter(image, RenderOptions()) is image  # the box: nothing to do
    options = RenderOptions(**GAUSSIAN)
    flat = np.full((9, 11, 3), 0.75, np.float32)
    np.testing.assert_allclose(refilter(flat, options), flat, rtol=1e-6)  # border pixels included (cropped weights)
    impulse = np.zeros((9, 11, 1))
    impulse[4, 5] = 1.0
    w = pixel_weights(options)
    out = refilter(impulse, options)[..., 0]
    np.testing.assert_allclose(out[2:7, 3:8], w / w.sum(), rtol=1e-6)  # full neighbourhoods inside the image
    assert out[:2].max() == 0 and out[:, :3].max() == 0


@pytest.mark.parametrize("kw", [GAUSSIAN, {"filter": "lanczos", "filter_radius": 2.0},
                                {"filter": "tent", "filter_radius": 1.5}])
def test_refilter_is_the_direct_weighted_mean_of_the_neighbours(kw):
    """refilter (by rows then columns for a separable filter, by every tap for the course's radial tent) against
    the weighted mean written out with NumPy: each pixel the pixel_weights-weighted sum of the neighbours inside
    the image over their weights' sum (the lanczos' negative lobes included)."""
    options = RenderOptions(**kw)
    image = np.random.default_rng(11).random((13, 17, 3))
    w = pixel_weights(options)
    r = w.shape[0] // 2
    expected = np.empty_like(image)
    for y in range(13):
        for x in range(17):
            num, den = np.zeros(3), 0.0
            for a in range(-r, r + 1):
                for b in range(-r, r + 1):
                    if 0 <= y + a < 13 and 0 <= x + b < 17:
                        num += w[a + r, b + r] * image[y + a, x + b]
                        den += w[a + r, b + r]
            expected[y, x] = num / den
    np.testing.assert_allclose(refilter(image, options), expected, rtol=1e-12, atol=1e-12)


def test_refilter_is_the_films_filter_on_an_image_constant_over_each_pixel():
    """Samples whose value is their pixel's (one colour per pixel), filtered by the film with the gaussian, give
    refilter of the per-pixel image: the film's weights over 64 stratified samples against the filter's mean."""
    options = RenderOptions(samples=64, sampler="uniform", **GAUSSIAN)
    w, h = 10, 7
    pixels = np.random.default_rng(5).random((h * w, 3))
    points, pixel = film.sample_points(w, h, options)
    filmed = film.reconstruct(points, pixel, pixels[pixel], w, h, options).reshape(h, w, 3)
    np.testing.assert_allclose(refilter(pixels.reshape(h, w, 3), options), filmed, atol=2e-3)


def test_a_denoised_renders_inputs_are_box_filtered_and_its_emission_is_the_scenes():
    """Cornell box with Mitsuba's gaussian: a denoised render's albedo is the box-filtered render's, its emission
    the gaussian-filtered render's (the same samples, to the bit), and its colour OIDN's output on the box-filtered
    colour less the emission, blended with that colour by its variance (denoise.blend), refiltered by the
    gaussian, plus that emission."""
    pytest.importorskip("pyoidn")
    cornell = durer.load(EXAMPLES / "cornell_box.xml")
    d = durer.render(cornell, 24, 20, samples=4, denoise=True, **GAUSSIAN)
    box = durer.render(cornell, 24, 20, samples=4, aovs=True)
    scene = durer.render(cornell, 24, 20, samples=4, aovs=True, **GAUSSIAN)
    np.testing.assert_array_equal(d.albedo, box.albedo)
    np.testing.assert_array_equal(d.shading_normals, box.shading_normals)
    np.testing.assert_array_equal(d.emission, scene.emission)
    assert d.emission.max() > 1  # the light is in view
    assert not np.array_equal(scene.emission, box.emission)
    noisy = box.color - box.emission
    oidn = denoise(noisy, box.albedo, box.shading_normals).color
    blended = blend(oidn, noisy, d.aovs[MOMENT], 4)
    expected = refilter(blended, RenderOptions(**GAUSSIAN)) + scene.emission
    np.testing.assert_allclose(d.color, expected, rtol=1e-4, atol=1e-5)


@pytest.mark.slow
def test_a_gaussian_scenes_denoised_render_beats_the_noisy_one_and_the_box_film():
    """Cornell box with Mitsuba's gaussian, 4 spp at 48 px: away from the light, the denoised render is closer to
    a 256-spp gaussian-filtered reference than the noisy render, and closer than the previous film (everything
    box-filtered, the emission box-filtered and added back)."""
    pytest.importorskip("pyoidn")
    cornell = durer.load(EXAMPLES / "cornell_box.xml")
    reference = durer.render(cornell, 48, 48, samples=256, seed=7, **GAUSSIAN).color
    keep = durer.render(cornell, 48, 48, samples=64, max_depth=1, seed=5, **GAUSSIAN).color.max(axis=2) == 0
    noisy = durer.render(cornell, 48, 48, samples=4, **GAUSSIAN).color
    denoised = durer.render(cornell, 48, 48, samples=4, denoise=True, **GAUSSIAN).color
    box = durer.render(cornell, 48, 48, samples=4, aovs=True)
    before = denoise(box.color, box.albedo, box.shading_normals, direct=box.emission).color

    def rmse(image):
        return float(np.sqrt(np.mean((image[keep] - reference[keep]) ** 2)))

    assert rmse(denoised) < 0.6 * rmse(noisy), (rmse(denoised), rmse(noisy))
    assert rmse(denoised) < rmse(before), (rmse(denoised), rmse(before))
