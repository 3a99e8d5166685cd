"""Issue 24, second round: the path tracer's directly seen emission (RenderResult.emission from surface emitters,
.environment from the environment: the light a camera ray finds before its first non-specular hit, directly or
through mirrors), and the denoiser's split: OIDN denoises the colour without it and it is added back."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import durer
from durer.rendering.denoise import MOMENT, SPLIT, blend, denoise, split_part

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RADIANCE = (2.0, 3.0, 4.0)

SCENE = """<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="{depth}"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, -1" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    {shapes}
</scene>"""
LIGHT = """<shape type="rectangle">
        <transform name="to_world"><scale value="50"/>{turn}<translate z="{z}"/></transform>
        <emitter type="area"><rgb name="radiance" value="2, 3, 4"/></emitter>
    </shape>"""
MIRROR = """<shape type="rectangle">
        <transform name="to_world"><scale value="50"/><translate z="-5"/></transform>
        <bsdf type="conductor"><string name="material" value="none"/>
            <rgb name="specular_reflectance" value="0.5, 0.25, 0.125"/></bsdf>
    </shape>"""
SKY = '<emitter type="constant"><rgb name="radiance" value="0.5, 0.25, 1"/></emitter>'


def load(tmp_path: Path, shapes: str, depth: int = 4) -> durer.Scene:
    (tmp_path / "scene.xml").write_text(SCENE.format(depth=depth, shapes=shapes))
    return durer.load(tmp_path / "scene.xml")


def test_a_light_seen_directly_is_the_emission_output(tmp_path):
    """A camera ray that meets an area light (a rectangle filling the view, facing the camera) sees its radiance:
    the emission output is the radiance, and all of the colour; the environment output is 0."""
    scene = load(tmp_path, LIGHT.format(turn="", z=-5))
    r = durer.render(scene, samples=2, aovs=True)
    np.testing.assert_allclose(r.emission, np.broadcast_to(RADIANCE, r.color.shape), rtol=1e-6)
    np.testing.assert_array_equal(r.emission, r.color)
    assert not r.environment.any()
    plain = durer.render(scene, samples=2)
    assert plain.emission is None and plain.environment is None


def test_a_light_seen_in_a_mirror_is_tinted_by_it(tmp_path):
    """The camera sees an area light behind it in a smooth conductor (reflectance 0.5, 0.25, 0.125; Fresnel 1):
    the emission output is the radiance times the reflectance; with max_depth 2 that is all of the colour, with 4
    the colour also has the light's own diffuse reflection of the mirror image (not in the output). Without the
    mirror's bounce (max_depth 1) the emitter is not reached and the output is 0."""
    shapes = MIRROR + LIGHT.format(turn='<rotate x="1" angle="180"/>', z=5)
    tinted = np.broadcast_to((1.0, 0.75, 0.5), (6, 8, 3))
    r = durer.render(load(tmp_path, shapes, depth=2), samples=2, aovs=True)
    np.testing.assert_allclose(r.emission, tinted, rtol=1e-6)
    np.testing.assert_allclose(r.color, r.emission, rtol=1e-6)
    r = durer.render(load(tmp_path, shapes, depth=4), samples=2, aovs=True)
    np.testing.assert_allclose(r.emission, tinted, rtol=1e-6)
    assert (r.color > r.emission * 1.01).all()
    assert not durer.render(load(tmp_path, shapes, depth=1), samples=2, aovs=True).emission.any()


def test_the_environment_seen_directly_is_the_environment_output(tmp_path):
    """Camera rays that escape see the constant environment: the environment output is its radiance, the
    emission output 0; seen in the mirror, tinted by it."""
    r = durer.render(load(tmp_path, SKY), samples=2, aovs=True)
    np.testing.assert_allclose(r.environment, np.broadcast_to((0.5, 0.25, 1.0), r.color.shape), rtol=1e-6)
    assert not r.emission.any()
    r = durer.render(load(tmp_path, MIRROR + SKY), samples=2, aovs=True)
    np.testing.assert_allclose(r.environment, np.broadcast_to((0.25, 0.0625, 0.125), r.color.shape), rtol=1e-6)


def test_fused_and_unfused_path_tracers_see_the_same_emission():
    """The emission output to the bit on the one-kernel bounce and on the wavefront of accelerator queries,
    through glass (caustic scene) and of a light seen directly (Cornell box); it is a part of the colour."""
    kw = dict(samples=2, seed=3, aovs=True)
    for name in ("caustic.xml", "cornell_box.xml"):
        scene = durer.load(EXAMPLES / name)
        fused, unfused = durer.render(scene, 16, 12, **kw), durer.render(scene, 16, 12, accel="brute", **kw)
        np.testing.assert_array_equal(fused.emission, unfused.emission)
        np.testing.assert_array_equal(fused.environment, unfused.environment)
        assert (fused.emission <= fused.color * (1 + 1e-6) + 1e-9).all()
    assert fused.emission.max() > 1.0  # the Cornell box's light


def test_split_part_sums_the_named_outputs():
    a, b = np.full((2, 2, 3), 1.0), np.full((2, 2, 3), 2.0)
    np.testing.assert_array_equal(split_part({"emission": a, "environment": b}, ("emission", "environment")), a + b)
    np.testing.assert_array_equal(split_part({"emission": a, "environment": b}, ("emission",)), a)
    assert split_part({"albedo": a}, ("emission",)) is None  # the ray caster and Whitted have no such output
    assert SPLIT == ("emission",)


def rmse(image: np.ndarray, reference: np.ndarray, keep: np.ndarray) -> float:
    return float(np.sqrt(np.mean((image[keep] - reference[keep]) ** 2)))


def test_the_split_denoised_render_beats_the_noisy_one_and_keeps_the_light():
    """Cornell box, 4 spp: the denoised render (the light kept out of OIDN's input) is closer to a 256-spp
    reference than the noisy render, away from the light; at least as close as OIDN on the whole colour; and the
    light's own pixels keep its radiance (OIDN on the whole colour alters them)."""
    pytest.importorskip("pyoidn")
    cornell = durer.load(EXAMPLES / "cornell_box.xml")
    reference = durer.render(cornell, 48, 48, samples=256, seed=7).color
    light = durer.render(cornell, 48, 48, samples=64, max_depth=1, seed=5).color.max(axis=2) > 0
    keep = ~light
    noisy = durer.render(cornell, 48, 48, samples=4)
    split = durer.render(cornell, 48, 48, samples=4, denoise=True)
    r = durer.render(cornell, 48, 48, samples=4, aovs=True, filter="box", filter_radius=0.5)
    whole = denoise(r.color, r.albedo, r.shading_normals).color
    # the render subtracts the emission per sample before filtering (the same up to the sums' rounding), and
    # blends OIDN's output with that noisy colour by the film's second moment (denoise.blend)
    oidn = denoise(r.color, r.albedo, r.shading_normals, direct=r.emission).color - r.emission
    expected = blend(oidn, r.color - r.emission, split.aovs[MOMENT], 4) + r.emission
    np.testing.assert_allclose(expected, split.color, rtol=1e-4, atol=1e-5)
    e_noisy, e_split, e_whole = (rmse(c, reference, keep) for c in (noisy.color, split.color, whole))
    assert e_split < 0.6 * e_noisy, (e_split, e_noisy)
    assert e_split <= e_whole * 1.02, (e_split, e_whole)
    glow = r.emission.sum(axis=2)
    inner = glow > 0.99 * glow.max()  # pixels wholly on the light
    assert inner.sum() > 4
    assert np.abs(split.color[inner] - r.color[inner]).max() < np.abs(whole[inner] - r.color[inner]).max()
