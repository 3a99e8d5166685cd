"""Issue 24, fifth round: the second moment a denoised render films (MOMENT) and the variance-guided blend of
OIDN's output with the noisy colour (denoise.blend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import durer
from durer.rendering import denoise as denoise_module
from durer.rendering.denoise import MOMENT, blend, window_mean
from durer.rendering.renderer import make_context, render_in, resolve
from durer.rendering.units import prepare, render_unit

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_the_second_moment_is_the_mean_of_each_samples_square():
    """A denoised render's MOMENT output is, per pixel, the mean over its samples of the squared norm of the
    denoiser input (the colour less the directly seen emission), one channel: each sample's value is the
    one-sample unit of that sample alone (render_unit over range(i, i + 1), box film)."""
    scene = durer.load(EXAMPLES / "cornell_box.xml")
    width, height, options = resolve(scene, 12, 10, samples=4, denoise=True)
    result = render_in(make_context(scene, options), width, height)
    job = prepare(scene, width, height, options)
    per_sample = []
    for i in range(4):
        acc = render_unit(job, job.tile, range(i, i + 1))
        per_sample.append(acc.sums[..., :3] / acc.weight[..., None])
    per_sample = np.array(per_sample)
    np.testing.assert_allclose(result.color, per_sample.mean(axis=0), rtol=1e-6, atol=1e-7)
    assert result.aovs[MOMENT].shape == (height, width, 1)
    np.testing.assert_allclose(result.aovs[MOMENT][..., 0], (per_sample ** 2).sum(axis=-1).mean(axis=0), rtol=1e-5,
                               atol=1e-7)
    assert (per_sample.var(axis=0) > 0).any()  # the render is noisy: the test compares real variances
    plain = durer.render(scene, width, height, samples=4, aovs=True)
    assert MOMENT not in plain.aovs  # only a denoised render films it
    assert result.environment is None and plain.environment is not None  # nothing reads it in a denoised render
    both = render_in(make_context(scene, resolve(scene, 12, 10, samples=4, denoise=True, aovs=True)[2]), 12, 10)
    np.testing.assert_array_equal(both.environment, plain.environment)  # unless the outputs are asked for


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 9), st.integers(1, 9), st.integers(0, 3), st.integers(0, 2**32 - 1))
def test_window_mean_is_the_mean_over_the_cropped_window(h, w, radius, seed):
    a = np.random.default_rng(seed).random((h, w))
    out = window_mean(a, radius)
    for r in range(h):
        for c in range(w):
            window = a[max(0, r - radius):r + radius + 1, max(0, c - radius):c + radius + 1]
            assert abs(out[r, c] - window.mean()) < 1e-12


def test_blend_weights_are_the_mse_optimal_ones():
    """One pixel, no window: noisy n, denoised d, samples of variance s2 (so the pixel mean's is s2 / (N - 1)
    with the sample-variance estimate): the bias estimate b2 = max(0, (d - n)^2 - v) and the noisy pixel's weight
    b2 / (b2 + v)."""
    n, d, s2, samples = 0.5, 0.2, 0.09, 10  # one channel carries everything, the others agree exactly
    noisy = np.array([[[n, 1.0, 1.0]]])
    denoised = np.array([[[d, 1.0, 1.0]]])
    moment = noisy ** 2 + np.array([[[s2, 0.0, 0.0]]])
    v = s2 / (samples - 1)
    b2 = (d - n) ** 2 - v
    w = b2 / (b2 + v)
    out = blend(denoised, noisy, moment, samples, radius=0, scale=1.0)
    np.testing.assert_allclose(out[0, 0], [d + w * (n - d), 1.0, 1.0], rtol=1e-12)
    v2 = 2 * v  # durer's scale: the variance doubled
    w2 = ((d - n) ** 2 - v2) / (d - n) ** 2
    np.testing.assert_allclose(blend(denoised, noisy, moment, samples, radius=0, scale=2.0)[0, 0, 0],
                               d + w2 * (n - d), rtol=1e-12)
    # a difference the noise explains keeps the denoised value; no noise at all keeps the noisy one
    np.testing.assert_array_equal(blend(denoised, noisy, noisy ** 2 + 1.0, samples, radius=0), denoised)
    np.testing.assert_allclose(blend(denoised, noisy, noisy ** 2, samples, radius=0), noisy)
    assert blend(denoised, noisy, moment, 1) is denoised  # one sample: no variance estimate
    # the film's one channel, the mean squared norm, gives the same variance sum
    np.testing.assert_allclose(blend(denoised, noisy, moment.sum(axis=-1, keepdims=True), samples, radius=0,
                                     scale=1.0), out, rtol=1e-12)


def test_blend_keeps_an_unbiased_denoisers_output_and_undoes_a_biased_one():
    """Noisy pixels of a known variance around a smooth truth: a denoiser that returns the truth is kept (the
    differences are the noise), one that returns a constant far off the truth is moved back to the noisy
    image (the differences are far beyond the noise), each over the blend's window."""
    rng = np.random.default_rng(7)
    samples, sigma = 16, 0.2
    truth = np.broadcast_to(np.linspace(0.2, 1.0, 32)[None, :, None], (24, 32, 3))
    draws = truth[None] + sigma * rng.standard_normal((samples, 24, 32, 3))
    noisy, moment = draws.mean(axis=0), (draws ** 2).mean(axis=0)
    kept = blend(truth, noisy, moment, samples)
    assert np.sqrt(np.mean((kept - truth) ** 2)) < 0.2 * np.sqrt(np.mean((noisy - truth) ** 2))
    wrong = np.full_like(truth, 3.0)
    undone = blend(wrong, noisy, moment, samples)
    assert np.abs(undone - noisy).max() < 0.05 * np.abs(wrong - noisy).max()


def test_a_denoised_render_blends_with_its_own_noisy_colour_and_moment(monkeypatch):
    """render(denoise=True) hands blend OIDN's output, the box-filtered noisy colour less the emission, the film's
    second moment and the sample count, and its colour is the blended image refiltered plus the emission."""
    pytest.importorskip("pyoidn")
    calls = []

    def spy(denoised, noisy, moment, samples, *args, **kwargs):
        calls.append((noisy.copy(), moment.copy(), samples))
        return np.zeros_like(denoised)

    monkeypatch.setattr(denoise_module, "blend", spy)
    scene = durer.load(EXAMPLES / "cornell_box.xml")
    d = durer.render(scene, 12, 10, samples=4, denoise=True)
    box = durer.render(scene, 12, 10, samples=4, aovs=True)
    (noisy, moment, samples), = calls
    assert samples == 4
    np.testing.assert_allclose(noisy, box.color - box.emission, rtol=1e-6, atol=1e-7)
    square = (noisy ** 2).sum(axis=-1)
    assert (moment[..., 0] >= square * (1 - 1e-5) - 1e-7).all() and (moment[..., 0] > square + 1e-6).any()
    np.testing.assert_allclose(d.color, box.emission, rtol=1e-6)  # the spy's zeros plus the emission
