"""Issue 24: the denoiser's features (albedo and shading normal of the first non-specular hit, through mirrors),
their outputs (--aov, multi-layer EXR, Mitsuba's aov integrator), and Open Image Denoise (--denoise)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import MITSUBA_SCENES

import durer
from durer.cli import main
from durer.errors import MissingDependency
from durer.rendering.denoise import clean_features

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RED, GREEN, WHITE = (0.570068, 0.0430135, 0.0443706), (0.105421, 0.37798, 0.076425), (0.885809, 0.698859, 0.666422)


@pytest.fixture(scope="module")
def cornell():
    return durer.load(EXAMPLES / "cornell_box.xml")


def test_albedo_of_the_cornell_box_walls_is_their_reflectance(cornell):
    """Pixels wholly on a diffuse wall have that wall's reflectance as albedo, and its normal as shading normal
    (unit, the same as RenderResult.normals there); the colour is the one rendered without features, to the bit."""
    r = durer.render(cornell, 32, 32, samples=4, aovs=True)
    for (row, col), rho, n in (((16, 2), RED, (1, 0, 0)), ((16, 29), GREEN, (-1, 0, 0)), ((2, 16), WHITE, (0, -1, 0))):
        np.testing.assert_allclose(r.albedo[row, col], rho, rtol=1e-6)
        np.testing.assert_allclose(r.shading_normals[row, col], n, atol=1e-6)
        np.testing.assert_allclose(r.normals[row, col], n, atol=1e-6)
    assert r.albedo.max() <= 1.0 and r.albedo.min() >= 0.0
    plain = durer.render(cornell, 32, 32, samples=4)
    assert plain.albedo is None and plain.shading_normals is None
    np.testing.assert_array_equal(plain.color, r.color)


def mirror_scene() -> durer.Scene:
    """A half-silvered mirror plane (kr 0.5) facing the camera, which sees in it a diffuse plane behind the
    camera (kd 0.2, 0.4, 0.6; normal -z); one directional light."""
    cam = durer.PerspectiveCamera((0, 0, 0), (0, 0, -1), (0, 1, 0), 30)
    mirror = durer.PhongMaterial(diffuse_color=(0, 0, 0), reflective_color=(0.5, 0.5, 0.5))
    wall = durer.PhongMaterial(diffuse_color=(0.2, 0.4, 0.6))
    group = durer.Group([durer.Plane((0, 0, 1), -5.0, 0), durer.Plane((0, 0, -1), -5.0, 1)])
    return durer.Scene(camera=cam, group=group, materials=[mirror, wall],
                       lights=[durer.DirectionalLight((0, 0, 1), (1, 1, 1))])


@pytest.mark.parametrize("kw", [dict(integrator="whitted", bounces=2, shadows=True),
                                dict(integrator="path", samples=2, max_depth=4)])
def test_albedo_seen_through_a_mirror_is_tinted_by_it(kw):
    """Whitted and the path tracer: the albedo is the mirror's tint times the reflected wall's reflectance, and
    the shading normal is the wall's; RenderResult.normals stays the first hit's (the mirror's)."""
    r = durer.render(mirror_scene(), 8, 8, aovs=True, **kw)
    np.testing.assert_allclose(r.albedo, np.broadcast_to((0.1, 0.2, 0.3), r.albedo.shape), rtol=1e-6)
    np.testing.assert_allclose(r.shading_normals, np.broadcast_to((0, 0, -1), r.albedo.shape), atol=1e-6)
    np.testing.assert_allclose(r.normals, np.broadcast_to((0, 0, 1), r.albedo.shape), atol=1e-6)


def test_a_normal_maps_perturbed_normal_is_the_normal_feature(tmp_path):
    """Under Mitsuba's normalmap the shading normal feature is the map's normal (2 rgb - 1 in the frame of dp/du,
    dp/dv and n), which OIDN needs to keep the map's detail, while RenderResult.normals stays the surface's."""
    from PIL import Image

    rgb = np.array([191, 128, 238], np.uint8)
    Image.fromarray(np.broadcast_to(rgb, (4, 4, 3)).copy()).save(tmp_path / "n.png")
    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0"><integrator type="path"/>'
        '<sensor type="perspective"><float name="fov" value="20"/><transform name="to_world">'
        '<lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>'
        '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>'
        '<emitter type="constant"/><shape type="rectangle"><bsdf type="normalmap">'
        '<texture name="normalmap" type="bitmap"><boolean name="raw" value="true"/>'
        '<string name="filename" value="n.png"/></texture><bsdf type="diffuse"/></bsdf></shape></scene>')
    r = durer.render(durer.load(tmp_path / "s.xml"), 8, 8, samples=4, aovs=True)
    m = 2.0 * rgb / 255.0 - 1.0
    np.testing.assert_allclose(r.shading_normals, np.broadcast_to(m / np.linalg.norm(m), r.albedo.shape), atol=1e-5)
    np.testing.assert_allclose(r.normals, np.broadcast_to((0, 0, 1), r.albedo.shape), atol=1e-6)


def test_the_ray_caster_takes_the_first_hit():
    """No secondary rays: the mirror's own reflectance (kd + ks + kr + kt) and normal."""
    r = durer.render(mirror_scene(), 8, 8, integrator="raycast", aovs=True)
    np.testing.assert_allclose(r.albedo, np.broadcast_to((0.5, 0.5, 0.5), r.albedo.shape), rtol=1e-6)
    np.testing.assert_allclose(r.shading_normals, r.normals, atol=1e-6)


def test_fused_and_unfused_path_tracers_give_the_same_features():
    """The features through glass and mirrors (caustic scene) to the bit, on the one-kernel bounce and on the
    wavefront of accelerator queries."""
    scene = durer.load(EXAMPLES / "caustic.xml")
    kw = dict(samples=2, seed=3, aovs=True)
    fused = durer.render(scene, 16, 12, **kw)
    unfused = durer.render(scene, 16, 12, accel="brute", **kw)  # no tree to walk: the wavefront of queries
    for a, b in ((fused.color, unfused.color), (fused.albedo, unfused.albedo),
                 (fused.shading_normals, unfused.shading_normals)):
        np.testing.assert_array_equal(a, b)
    assert fused.albedo.max() > 0


def test_clean_features_only_without_random_choices(cornell):
    assert clean_features(cornell.materials, path=True)
    caustic = durer.load(EXAMPLES / "caustic.xml")  # glass: reflect or refract, chosen per sample
    assert not clean_features(caustic.materials, path=True)
    assert clean_features(caustic.materials, path=False)


@pytest.mark.skipif(not (MITSUBA_SCENES / "mitsuba-data").is_dir(), reason=f"Mitsuba scenes not found at "
                    f"{MITSUBA_SCENES} (set DURER_SHARED)")
def test_a_checkerboards_features_are_clean():
    """Mitsuba's checkerboard picks one of its two materials per point with weight 0 or 1, the same for every
    sample: its features are handed to OIDN as clean. Away from the squares' edges the path tracer's albedo is one
    of the two reflectances, whatever the seed; a blending solid texture (marble) is not clean."""
    from durer.scene.textures import Marble

    scene = durer.load(MITSUBA_SCENES / "mitsuba-data/tests/scenes/orthographic_sensor/test_orthographic_path.xml")
    assert clean_features(scene.materials, path=True)
    assert not clean_features([*scene.materials, Marble(material1=0, material2=0)], path=True)
    a, b = (durer.render(scene, 200, 120, samples=4, seed=k, aovs=True, filter="box", filter_radius=0.5).albedo
            for k in (1, 2))
    on = a.max(axis=2) > 0  # the checkerboard rectangle (the background escapes: albedo 0)
    square = ((np.abs(a - 0.4) < 1e-6) | (np.abs(a - 0.2) < 1e-6)).all(axis=2)  # Mitsuba's colours 0.4 and 0.2
    same = np.all(a == b, axis=2)
    assert on.sum() > 5000 and (square & same).sum() > 0.75 * on.sum()  # all but the squares' edge pixels


def test_aov_normals_match_render_normals_and_are_unit(tmp_path, cornell):
    """`durer render --aov normals,depth` (files beside the image) writes what --normals and --depth write."""
    xml = str(EXAMPLES / "cornell_box.xml")
    out = tmp_path / "img.npy"
    args = ["render", xml, "--size", "16", "16", "--samples", "2", "-q"]
    assert main([*args, "-o", str(out), "--aov", "normals,depth,albedo", "--normals", str(tmp_path / "n.npy")]) == 0
    normals = np.load(tmp_path / "img.normals.npy")
    np.testing.assert_array_equal(normals, np.load(tmp_path / "n.npy"))
    hit = np.isfinite(np.load(tmp_path / "img.depth.npy"))
    assert hit.mean() > 0.5  # the box, open at the front
    np.testing.assert_allclose(np.linalg.norm(normals[hit], axis=1), 1.0, rtol=1e-6)
    assert not normals[~hit].any()
    r = durer.render(cornell, 16, 16, samples=2, aovs=True)
    np.testing.assert_array_equal(np.load(tmp_path / "img.albedo.npy"), r.albedo)
    np.testing.assert_array_equal(np.load(tmp_path / "img.npy"), r.color)


def test_aov_layers_of_an_exr(tmp_path, cornell):
    exr = pytest.importorskip("OpenEXR")
    out = tmp_path / "img.exr"
    assert main(["render", str(EXAMPLES / "cornell_box.xml"), "--size", "16", "12", "--samples", "2", "-q",
                 "-o", str(out), "--aov", "albedo,normals,depth"]) == 0
    r = durer.render(cornell, 16, 12, samples=2, aovs=True)
    with exr.File(str(out), separate_channels=True) as f:
        ch = {k: np.asarray(v.pixels) for k, v in f.channels().items()}
    assert set(ch) == {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "normals.X", "normals.Y", "normals.Z",
                       "depth.Z"}
    np.testing.assert_array_equal(np.stack([ch[c] for c in "RGB"], axis=-1), r.color)
    np.testing.assert_array_equal(np.stack([ch[f"albedo.{c}"] for c in "RGB"], axis=-1), r.albedo)
    np.testing.assert_array_equal(np.stack([ch[f"normals.{c}"] for c in "XYZ"], axis=-1), r.normals)
    np.testing.assert_array_equal(ch["depth.Z"], r.depth)


AOV_XML = """<scene version="3.0.0">
    <integrator type="aov">
        <string name="aovs" value="dd.y:depth,nn:sh_normal,a:albedo"/>
        <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></shape>
</scene>
"""


def test_mitsuba_aov_integrator_maps_onto_the_outputs(tmp_path):
    (tmp_path / "aov.xml").write_text(AOV_XML)
    scene = durer.load(tmp_path / "aov.xml")
    assert scene.render_defaults["aov_outputs"] == ("depth", "normals", "albedo")
    assert scene.render_defaults["max_depth"] == 3
    assert main(["render", str(tmp_path / "aov.xml"), "-o", str(tmp_path / "img.pfm"), "-q"]) == 0
    assert (tmp_path / "img.albedo.pfm").is_file() and (tmp_path / "img.depth.pfm").is_file()
    r = durer.render(scene)
    np.testing.assert_allclose(r.albedo[3, 4], (0.2, 0.4, 0.6), rtol=1e-6)  # the sphere's centre
    # position and uv (real scenes ask for them) are the centre sample's (rendering/hit_aovs.py)
    (tmp_path / "position.xml").write_text(AOV_XML.replace("a:albedo", "p:position"))
    defaults = durer.load(tmp_path / "position.xml").render_defaults
    assert defaults["aov_outputs"] == ("depth", "normals", "position") and defaults["hit_aovs"]


def test_denoise_is_refused_without_pyoidn(monkeypatch, tmp_path, capsys, cornell):
    """No pyoidn: render(denoise=True) raises an ImportError saying what to install, and `durer render
    --denoise` says it in one line, exit status 2, before rendering anything (no output file)."""
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # import pyoidn now raises ImportError
    monkeypatch.setattr("durer.rendering.renderer.make_context", lambda *a: pytest.fail("rendered"))
    with pytest.raises(ImportError, match=r'pip install "durer\[denoise\]"'):
        durer.render(cornell, 8, 8, denoise=True)
    out = tmp_path / "img.png"
    assert main(["render", str(EXAMPLES / "cornell_box.xml"), "-o", str(out), "--denoise"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and 'pip install "durer[denoise]"' in err
    assert not out.exists()
    assert issubclass(MissingDependency, ImportError)


def rmse_without_emitters(image: np.ndarray, reference: np.ndarray) -> float:
    keep = reference.max(axis=2) < 1.0  # the light's own pixels are far brighter than anything it lights
    return float(np.sqrt(np.mean((image[keep] - reference[keep]) ** 2)))


def test_denoised_render_is_closer_to_the_reference_than_the_noisy_one(cornell):
    pytest.importorskip("pyoidn")
    reference = durer.render(cornell, 48, 48, samples=256, seed=7).color
    noisy = durer.render(cornell, 48, 48, samples=4)
    denoised = durer.render(cornell, 48, 48, samples=4, denoise=True)
    assert 0 < denoised.denoise_seconds < denoised.seconds
    e_noisy, e_denoised = rmse_without_emitters(noisy.color, reference), rmse_without_emitters(denoised.color,
                                                                                              reference)
    assert e_denoised < 0.6 * e_noisy, (e_denoised, e_noisy)


def test_denoise_quality_is_one_of_oidns_presets(cornell):
    with pytest.raises(ValueError, match="unknown denoise quality 'ultra'"):
        durer.render(cornell, 8, 8, denoise=True, denoise_quality="ultra")
    assert main(["render", str(EXAMPLES / "cornell_box.xml"), "-o", "x.png", "--denoise-quality", "ultra"]) == 2


def _fresh_prefilter(oidn, image: np.ndarray, name: str) -> np.ndarray:
    """One feature prefiltered on a device and filter of its own (what denoise._prefilter did per call)."""
    out = np.empty_like(image)
    with oidn.Device() as device:
        device.commit()
        with oidn.Filter(device, oidn.OIDN_FILTER_TYPE_RT) as flt:
            flt.set_image(name, image, oidn.OIDN_FORMAT_FLOAT3)
            flt.set_image(oidn.OIDN_IMAGE_OUTPUT, out, oidn.OIDN_FORMAT_FLOAT3)
            flt.set_quality(4)
            flt.commit()
            flt.execute()
    return out


def test_kept_prefilters_give_a_fresh_devices_output_across_sizes(cornell):
    """denoise._prefilter keeps its device and a filter per (feature, quality): a second call of another size and
    a third of the first size rebind the images and give what a fresh device gives, on the same device."""
    oidn = pytest.importorskip("pyoidn")
    from durer.rendering import denoise as dn

    devices = []
    for w, h in ((24, 16), (16, 16), (24, 16)):
        r = durer.render(cornell, w, h, samples=2, aovs=True)
        albedo = np.ascontiguousarray(np.clip(r.albedo, 0, 1), np.float32)
        normal = np.ascontiguousarray(np.clip(r.shading_normals, -1, 1), np.float32)
        got = dn._prefilter(oidn, albedo, normal, "fast")
        devices.append(dn._PREFILTERS["device"])
        assert np.array_equal(got[0], _fresh_prefilter(oidn, albedo, "albedo"))
        assert np.array_equal(got[1], _fresh_prefilter(oidn, normal, "normal"))
    assert devices[0] is devices[1] is devices[2]
