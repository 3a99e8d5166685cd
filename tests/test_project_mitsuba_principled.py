"""Mitsuba's `principled` and `principledthin` BSDFs through the whole pipeline: Mitsuba's material preview object
(the set's docs/scenes/include/matpreview.xml, its film made small) given such a BSDF, read from XML and rendered
by durer and by Mitsuba 3 from the same file: image means within 2%, each channel's within 3%. Four materials
between them exercise every lobe: an anisotropic metal with a clearcoat, a rough glass (transmission), a textured
base colour with sheen, specular tint and anisotropy (the anisotropic ones oriented by the mesh's dp/du, as
Mitsuba does), and a thin sheet passing light diffusely and glossily; two more give number parameters as
checkerboards (metallic and clearcoat; a thin sheet's diff_trans and spec_trans), where the image's mean alone
would not notice the texture read as its mean: their 6x6-pixel blocks are within 1.5x the difference between two
Mitsuba renders of different seeds (measured: 1.08x and 1.24x; the textures' means instead: 1.74x and 2.99x).
Slow: the path tracer's kernels and Mitsuba's render."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MITSUBA_SCENES
from mitsuba_references import mirror, shrink

import durer
from durer.io.mitsuba import load_mitsuba

BSDFS = {  # name: the principled BSDF's parameters (a name starting "thin": principledthin)
    "gold-clearcoat": '<rgb name="base_color" value="0.9 0.6 0.2"/><float name="metallic" value="0.8"/>'
                      '<float name="roughness" value="0.35"/><float name="clearcoat" value="0.7"/>'
                      '<float name="clearcoat_gloss" value="0.6"/><float name="anisotropic" value="0.8"/>',
    "rough-glass": '<rgb name="base_color" value="0.8 0.9 1.0"/><float name="spec_trans" value="0.9"/>'
                   '<float name="roughness" value="0.2"/><float name="eta" value="1.45"/>',
    "textured-sheen": '<texture type="checkerboard" name="base_color"><rgb name="color0" value="0.8 0.2 0.1"/>'
                      '<rgb name="color1" value="0.1 0.3 0.7"/><transform name="to_uv"><scale x="6" y="6"/>'
                      '</transform></texture><float name="roughness" value="0.5"/><float name="sheen" value="0.8"/>'
                      '<float name="sheen_tint" value="0.5"/><float name="spec_tint" value="0.4"/>'
                      '<float name="anisotropic" value="0.6"/><float name="specular" value="0.7"/>',
    "thin-leaf": '<rgb name="base_color" value="0.3 0.7 0.2"/><float name="diff_trans" value="0.9"/>'
                 '<float name="spec_trans" value="0.3"/><float name="flatness" value="0.5"/>'
                 '<float name="roughness" value="0.4"/><float name="sheen" value="0.3"/>',
    "textured-metallic": '<rgb name="base_color" value="0.9 0.5 0.2"/><float name="roughness" value="0.3"/>'
                         '<texture type="checkerboard" name="metallic"><float name="color0" value="0"/>'
                         '<float name="color1" value="1"/><transform name="to_uv"><scale x="6" y="6"/></transform>'
                         '</texture><texture type="checkerboard" name="clearcoat"><float name="color0" value="0.9"/>'
                         '<float name="color1" value="0.1"/><transform name="to_uv"><scale x="3" y="3"/>'
                         '</transform></texture>',
    "thin-textured": '<rgb name="base_color" value="0.4 0.7 0.3"/><float name="roughness" value="0.4"/>'
                     '<texture type="checkerboard" name="diff_trans"><float name="color0" value="1.6"/>'
                     '<float name="color1" value="0.2"/><transform name="to_uv"><scale x="5" y="5"/></transform>'
                     '</texture><texture type="checkerboard" name="spec_trans"><float name="color0" value="0"/>'
                     '<float name="color1" value="0.6"/><transform name="to_uv"><scale x="3" y="3"/></transform>'
                     '</texture><float name="eta" value="1.3"/>',
}


@pytest.fixture(scope="module")
def scenes(tmp_path_factory):
    if not MITSUBA_SCENES.is_dir():
        pytest.skip(f"Mitsuba scenes not found at {MITSUBA_SCENES} (they live in ../shared beside the repository)")
    root = mirror(tmp_path_factory.mktemp("principled") / "scenes", MITSUBA_SCENES)
    shrink(root / "mitsuba-data/docs/scenes/include/matpreview.xml")
    return root / "mitsuba-data/docs/scenes"


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BSDFS))
def test_principled_matpreview_matches_mitsuba(scenes, name):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference")
    mi.set_variant("scalar_rgb")
    path = scenes / f"bsdf_principled_{name}.xml"
    kind = "principledthin" if name.startswith("thin") else "principled"
    path.write_text(f'<scene version="3.0.0"><path value="../../common"/><bsdf type="{kind}" id="object_bsdf">'
                    f'{BSDFS[name]}</bsdf><include filename="include/matpreview.xml"/></scene>')
    image = np.asarray(durer.render(load_mitsuba(str(path)), samples=64).color)[..., :3]
    ref = np.array(mi.render(mi.load_file(str(path)), spp=128, seed=11))[..., :3]
    assert image.shape == ref.shape == (36, 48, 3)
    assert image.mean() == pytest.approx(ref.mean(), rel=0.02)
    assert np.allclose(image.mean(axis=(0, 1)), ref.mean(axis=(0, 1)), rtol=0.03, atol=1e-3)
    if name in ("textured-metallic", "thin-textured"):  # where the pattern shows: block by block
        other = np.array(mi.render(mi.load_file(str(path)), spp=128, seed=12))[..., :3]
        assert np.abs(_blocks(image) - _blocks(ref)).mean() < 1.5 * np.abs(_blocks(other) - _blocks(ref)).mean()


def _blocks(a: np.ndarray, k: int = 6) -> np.ndarray:
    """The image's means over k x k pixel blocks."""
    h, w = a.shape[0] // k * k, a.shape[1] // k * k
    return a[:h, :w].reshape(h // k, k, w // k, k, 3).mean(axis=(1, 3))
