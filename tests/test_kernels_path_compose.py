"""Mitsuba's composed BSDFs in durer's kernels (kernels/path/compose.py, kernels/path/textures.shading_frame)
against Mitsuba 3's own values in scalar_rgb: blendbsdf and mask eval, pdf and sample (constant and textured
weights), and the shading frames of normalmap and bumpmap through a diffuse BSDF's eval."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from durer.io.images import read_texture
from durer.rendering.bsdfs import BSDFTable, eval_pdf, sample
from durer.scene import bsdfs as B
from durer.scene.textures import Bitmap


def _mitsuba():
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the independent reference for the BSDF values")
    mi.set_variant("scalar_rgb")
    return mi


def _dirs(n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) + 0.05
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def grey_png(tmp_path_factory):
    path = tmp_path_factory.mktemp("compose") / "w.png"
    Image.fromarray((np.random.default_rng(5).random((8, 8)) * 255).astype(np.uint8), mode="L").save(path)
    return str(path)


def _cases(grey_png):
    rough = {"type": "roughconductor", "alpha": 0.3, "distribution": "ggx"}
    return [
        ({"type": "blendbsdf", "weight": 0.3, "a": {"type": "diffuse", "reflectance": 0.5}, "b": rough},
         B.Blend(B.Diffuse(0.5), B.RoughConductor(alpha_u=0.3, alpha_v=0.3), 0.3)),
        ({"type": "blendbsdf", "weight": {"type": "bitmap", "filename": grey_png},
          "a": {"type": "roughplastic", "alpha": 0.2, "distribution": "ggx", "diffuse_reflectance": 0.3},
          "b": {"type": "conductor"}},
         B.Blend(B.RoughPlastic(0.3, alpha=0.2), B.Conductor(), Bitmap(read_texture(grey_png)))),
        ({"type": "mask", "opacity": 0.35, "a": {"type": "diffuse", "reflectance": 0.7}},
         B.Mask(B.Diffuse(0.7), 0.35)),
        ({"type": "mask", "opacity": {"type": "bitmap", "filename": grey_png},
          "a": {"type": "twosided", "b": {"type": "diffuse", "reflectance": 0.2}}},
         B.Mask(B.TwoSided(B.Diffuse(0.2)), Bitmap(read_texture(grey_png)))),
    ]


@pytest.mark.parametrize("case", range(4))
def test_blend_and_mask_match_mitsuba(grey_png, case):
    mi = _mitsuba()
    mdict, ours = _cases(grey_png)[case]
    b = mi.load_dict(mdict)
    table = BSDFTable.from_materials([ours])
    n = 40
    wi, wo = _dirs(n, 1), _dirs(n, 2)
    wi[::5, 2] *= -1  # some from behind: one-sided and two-sided children differ there
    uv = np.random.default_rng(3).random((n, 2))
    ctx = mi.BSDFContext()
    u1 = np.random.default_rng(4).random(n)
    u2 = np.random.default_rng(5).random((n, 2))
    slot = np.zeros(n, np.int64)
    d_wo, d_w, d_pdf, d_delta, _ = sample(table, slot, wi, u1, u2, uv)

    def si_at(a, t):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(a)
        si.uv = mi.Point2f(*t)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        return si

    mv, mp = [], []
    for k in range(n):
        si = si_at(wi[k], uv[k])
        mv.append(list(b.eval(ctx, si, mi.Vector3f(wo[k]))))
        mp.append(b.pdf(ctx, si, mi.Vector3f(wo[k])))
        if d_delta[k]:  # the same lobe picked by the same number: the same direction, weight and probability
            bs, w = b.sample(ctx, si, float(u1[k]), mi.Point2f(*u2[k]))
            if not np.any(d_w[k] > 0):  # nothing sampled (from behind a one-sided BSDF)
                assert not np.any(np.array(list(w)) > 0)
                continue
            assert np.allclose(list(bs.wo), d_wo[k], atol=1e-5)
            assert np.allclose(list(w), d_w[k], rtol=3e-3) and bs.pdf == pytest.approx(d_pdf[k], rel=3e-3)
        elif d_pdf[k] > 0:  # a direction of a smooth lobe: Mitsuba's eval / pdf there (its warps are its own)
            pdf = b.pdf(ctx, si, mi.Vector3f(d_wo[k]))
            assert d_pdf[k] == pytest.approx(pdf, rel=3e-3, abs=1e-6)
            assert np.allclose(d_w[k], np.array(list(b.eval(ctx, si, mi.Vector3f(d_wo[k])))) / pdf, rtol=3e-3)
    value, pdf = eval_pdf(table, slot, wi, wo, uv)
    assert np.allclose(value, mv, rtol=3e-3, atol=1e-5)  # (durer's rough plastic tables: 3e-4 from Mitsuba's)
    assert np.allclose(pdf, mp, rtol=3e-3, atol=1e-5)
    assert (d_pdf[~d_delta] > 0).sum() >= 5  # the checks above saw smooth samples
