"""Mitsuba's principled and principledthin BSDFs in durer's kernels (kernels/path/principled.py, principledthin.py):
eval, pdf and sample against Mitsuba 3's own values in scalar_rgb from both sides, for constant and textured
parameters (bitmaps and checkerboards on every parameter Mitsuba takes as a texture, at random UVs); sampling
against the pdf (chi-square) and the sampled weights' mean against the integral of eval (unbiased)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image

from durer.io.images import read_texture
from durer.rendering.bsdfs import BSDFTable, eval_pdf, sample
from durer.scene import bsdfs as B
from durer.scene.textures import Bitmap, Checker

# a checkerboard on a number parameter: Mitsuba's eval_1 reads the cell's other colour's channel mean
CHK = ("checker", [0.1, 0.5, 0.3], [0.9, 0.6, 0.8])

CASES = [
    {},
    {"roughness": 0.2, "base_color": [0.8, 0.3, 0.1]},
    {"metallic": 0.7, "base_color": [0.9, 0.6, 0.2], "roughness": 0.3},
    {"spec_trans": 0.8, "roughness": 0.3, "eta": 1.33, "base_color": [0.5, 0.9, 0.7]},
    {"spec_tint": 0.6, "base_color": [0.2, 0.5, 0.9], "specular": 0.8},
    {"sheen": 0.8, "sheen_tint": 0.4, "base_color": [0.9, 0.2, 0.3]},
    {"clearcoat": 0.9, "clearcoat_gloss": 0.3, "roughness": 0.6},
    {"anisotropic": 0.7, "roughness": 0.4, "metallic": 0.5},
    {"spec_trans": 1.0, "sheen": 1.0, "roughness": 0.4},
    {"main_specular_sampling_rate": 0.3, "clearcoat_sampling_rate": 2.0, "diffuse_reflectance_sampling_rate": 0.5,
     "clearcoat": 0.5, "spec_trans": 0.4, "metallic": 0.2, "sheen": 0.3},
    {"eta": 1.0, "roughness": 0.25},
    {"base_color": "rgb.png", "roughness": "grey.png", "metallic": 0.3, "spec_trans": 0.3, "clearcoat": 0.4},
    {"base_color": [0.7, 0.4, 0.2], "roughness": 0.3, "metallic": "grey.png", "spec_trans": "rgb.png",
     "clearcoat": CHK, "clearcoat_gloss": "grey.png", "eta": 1.4},
    {"anisotropic": "grey.png", "sheen": CHK, "sheen_tint": "rgb.png", "spec_tint": "grey.png", "metallic": 0.2,
     "roughness": "grey.png", "base_color": "rgb.png"},
    # principledthin
    {"thin": True},
    {"thin": True, "roughness": 0.3, "base_color": [0.8, 0.3, 0.1], "spec_trans": 0.6, "diff_trans": 0.4},
    {"thin": True, "flatness": 0.6, "diff_trans": 1.3, "spec_trans": 0.2, "roughness": 0.8, "anisotropic": 0.5},
    {"thin": True, "spec_tint": 0.7, "spec_trans": 0.5, "sheen": 0.7, "sheen_tint": 0.4, "eta": 1.3,
     "base_color": [0.2, 0.6, 0.9]},
    {"thin": True, "spec_trans": 0.5, "diff_trans": 0.5, "specular_reflectance_sampling_rate": 0.3,
     "diffuse_transmittance_sampling_rate": 2.0, "specular_transmittance_sampling_rate": 0.7},
    {"thin": True, "base_color": "rgb.png", "roughness": "grey.png", "spec_trans": 0.4, "diff_trans": 0.6},
    {"thin": True, "spec_trans": "grey.png", "diff_trans": ("checker", 0.3, 1.4), "flatness": "rgb.png",
     "eta": ("checker", 1.2, 1.7), "anisotropic": "grey.png", "sheen": "grey.png", "sheen_tint": CHK,
     "spec_tint": "rgb.png", "roughness": 0.4},  # eight textured numbers: every TEX_NUMBERS pair
]


@pytest.fixture(scope="module")
def pngs(tmp_path_factory):
    d = tmp_path_factory.mktemp("principled")
    rng = np.random.default_rng(7)
    Image.fromarray((rng.random((8, 8, 3)) * 255).astype(np.uint8), mode="RGB").save(d / "rgb.png")
    Image.fromarray((rng.random((8, 8)) * 255).astype(np.uint8), mode="L").save(d / "grey.png")
    return d


def _both(case: dict, d) -> tuple[dict, B.Principled | B.PrincipledThin]:
    """Mitsuba's dict and durer's description of one case (a name ending in .png: a bitmap of that file; ("checker",
    color0, color1): a checkerboard; "thin": principledthin)."""
    thin = case.get("thin", False)
    md, kw = {"type": "principledthin" if thin else "principled"}, {}
    for k, v in case.items():
        if k == "thin":
            continue
        if isinstance(v, str):
            md[k], kw[k] = {"type": "bitmap", "filename": str(d / v)}, Bitmap(read_texture(str(d / v)))
        elif isinstance(v, tuple):
            md[k] = {"type": "checkerboard", **{f"color{i}": {"type": "rgb", "value": v[1 + i]} if isinstance(
                v[1 + i], list) else v[1 + i] for i in range(2)}}
            kw[k] = Checker(v[1], v[2])
        else:
            md[k], kw[k] = ({"type": "rgb", "value": v} if isinstance(v, list) else v), v
    return md, (B.PrincipledThin if thin else B.Principled)(**kw)


def _sphere_dirs(n, seed):
    d = np.random.default_rng(seed).normal(size=(n, 3))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


@pytest.mark.parametrize("case", range(len(CASES)))
def test_principled_matches_mitsuba(pngs, case):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the independent reference for the BSDF values")
    mi.set_variant("scalar_rgb")
    mdict, ours = _both(CASES[case], pngs)
    b = mi.load_dict(mdict)
    table = BSDFTable.from_materials([ours])
    n = 150
    wi, wo = _sphere_dirs(n, 1), _sphere_dirs(n, 2)  # both sides, reflection and transmission
    uv = np.random.default_rng(3).random((n, 2))
    u1, u2 = np.random.default_rng(4).random(n), np.random.default_rng(5).random((n, 2))
    slot = np.zeros(n, np.int64)
    value, pdf = eval_pdf(table, slot, wi, wo, uv)
    s_wo, s_w, s_pdf, s_delta, s_eta = sample(table, slot, wi, u1, u2, uv)
    ctx = mi.BSDFContext()
    mv, mp, sampled = [], [], 0
    for k in range(n):
        si = mi.SurfaceInteraction3f()
        si.wi, si.uv, si.sh_frame = mi.Vector3f(wi[k]), mi.Point2f(*uv[k]), mi.Frame3f(mi.Vector3f(0, 0, 1))
        mv.append(list(b.eval(ctx, si, mi.Vector3f(wo[k]))))
        mp.append(b.pdf(ctx, si, mi.Vector3f(wo[k])))
        assert not s_delta[k]
        if s_pdf[k] > 0:  # durer's direction: Mitsuba's pdf and eval / pdf there (the warps are each their own)
            sampled += 1
            p = b.pdf(ctx, si, mi.Vector3f(s_wo[k]))
            assert s_pdf[k] == pytest.approx(p, rel=1e-3)
            np.testing.assert_allclose(s_w[k], np.array(list(b.eval(ctx, si, mi.Vector3f(s_wo[k])))) / p, rtol=1e-3,
                                       atol=1e-6)
            eta = 1.0  # reflected, or through a thin sheet
            if isinstance(ours, B.Principled) and s_wo[k, 2] * wi[k, 2] < 0:
                eta = ours.relative_eta if wi[k, 2] > 0 else 1 / ours.relative_eta
            assert s_eta[k] == pytest.approx(eta)
        else:
            assert not s_w[k].any()
    np.testing.assert_allclose(value, mv, rtol=1e-3, atol=1e-6)
    mp = np.array(mp)
    nan = np.isnan(mp)  # Mitsuba's 0 / 0 from behind where no lobe can be sampled (eta 1, opaque): durer's 0
    assert not pdf[nan].any() and (wi[nan, 2] < 0).all()
    np.testing.assert_allclose(pdf[~nan], mp[~nan], rtol=1e-3, atol=1e-6)
    assert sampled > n // 3 and (np.array(mv).max(1) > 0).sum() > n // 8  # the checks above saw real values


def _sample_dirs(table, cos_i, n, seed):
    rng = np.random.default_rng(seed)
    wi = np.tile([math.sqrt(1 - cos_i ** 2), 0.0, cos_i], (n, 1))
    return wi, sample(table, np.zeros(n, np.int64), wi, rng.random(n), rng.random((n, 2)))


def _grid(nt, nphi):
    """Midpoints of an (nt x nphi) grid uniform in z in [-1, 1] and phi (d omega = dz dphi) and each cell's area."""
    zs = -1 + (np.arange(nt) + 0.5) * 2 / nt
    ps = (np.arange(nphi) + 0.5) * 2 * np.pi / nphi
    zz, pp = np.meshgrid(zs, ps, indexing="ij")
    r = np.sqrt(1 - zz ** 2)
    return np.column_stack([(r * np.cos(pp)).ravel(), (r * np.sin(pp)).ravel(), zz.ravel()]), 4 * np.pi / (nt * nphi)


SAMPLED = [{"roughness": 0.5, "base_color": [0.7, 0.5, 0.3], "clearcoat": 0.6, "sheen": 0.5},
           {"roughness": 0.4, "spec_trans": 0.7, "metallic": 0.2, "eta": 1.4},
           {"roughness": 0.6, "anisotropic": 0.8, "metallic": 0.6, "main_specular_sampling_rate": 0.4},
           {"thin": True, "roughness": 0.5, "spec_trans": 0.5, "diff_trans": 0.8, "flatness": 0.5, "sheen": 0.4}]


def _ours(case: dict):
    kw = {k: v for k, v in case.items() if k != "thin"}
    return B.PrincipledThin(**kw) if case.get("thin") else B.Principled(**kw)


@pytest.mark.parametrize(("case", "cos_i"), [(c, x) for c in range(len(SAMPLED)) for x in (0.3, 0.9)]
                         + [(1, -0.6), (3, -0.6)])
def test_sampling_matches_pdf(case, cos_i):
    """Histogram of sampled directions over (cos theta, phi) bins against the pdf integrated over each bin (from
    behind only where light passes: an opaque principled samples nothing there, as Mitsuba's; a thin one is the
    same from both sides)."""
    table = BSDFTable.from_materials([_ours(SAMPLED[case])])
    n = 40000
    wi, (wo, _, pdf, _, _) = _sample_dirs(table, cos_i, n, 2)
    ok = pdf > 0
    nt, nphi, sub = 10, 20, 16
    z = np.clip(wo[ok, 2], -1, 1)
    phi = np.mod(np.arctan2(wo[ok, 1], wo[ok, 0]), 2 * np.pi)
    obs = np.zeros((nt, nphi))
    np.add.at(obs, (np.minimum(((z + 1) / 2 * nt).astype(int), nt - 1),
                    (phi / (2 * np.pi) * nphi).astype(int) % nphi), 1)
    d, cell = _grid(nt * sub, nphi * sub)
    _, p = eval_pdf(table, np.zeros(len(d), np.int64), np.tile(wi[0], (len(d), 1)), d)
    exp = (p * cell).reshape(nt, sub, nphi, sub).sum(axis=(1, 3)) * n
    assert abs(exp.sum() - ok.sum()) < 0.03 * n + 5 * math.sqrt(n)  # the pdf integrates to what was sampled
    keep = exp >= 5
    chi2 = ((obs[keep] - exp[keep]) ** 2 / exp[keep]).sum()
    k = keep.sum() - 1
    z_score = ((chi2 / k) ** (1 / 3) - (1 - 2 / (9 * k))) / math.sqrt(2 / (9 * k))  # Wilson-Hilferty
    assert z_score < 3.5


@pytest.mark.parametrize("case", range(len(SAMPLED)))
def test_sampled_weights_average_to_the_integral_of_eval(case):
    """E[weight] = the integral of f cos over the sphere (the estimator is unbiased), the integral by quadrature."""
    table = BSDFTable.from_materials([_ours(SAMPLED[case])])
    d, cell = _grid(400, 800)
    for cos_i in (0.5, -0.8) if SAMPLED[case].get("spec_trans") else (0.5,):
        n = 40000
        wi, (_, w, _, _, _) = _sample_dirs(table, cos_i, n, 3)
        value, _ = eval_pdf(table, np.zeros(len(d), np.int64), np.tile(wi[0], (len(d), 1)), d)
        integral = value.sum(0) * cell
        err = w.std(0) / math.sqrt(n)
        assert np.all(np.abs(w.mean(0) - integral) < 4 * err + 0.01 * integral), (cos_i, w.mean(0), integral)
        assert integral.max() > 0.05
