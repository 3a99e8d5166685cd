"""BSDFs of the path tracer: energy conservation, sampling against the pdf (chi-square), reciprocity, Fresnel
closed forms, and eval/pdf against Mitsuba 3's own plugins when Mitsuba is installed."""

from __future__ import annotations

import math

import numpy as np
import pytest

from durer.kernels.path.microfacet import fresnel1, fresnel_conductor1
from durer.rendering import bsdfs as R
from durer.scene import bsdfs as S
from durer.scene.materials import PhongMaterial

ALL = {
    "diffuse": S.Diffuse([0.2, 0.5, 0.9]),
    "dielectric": S.Dielectric(1.5),
    "thindielectric": S.ThinDielectric(1.5, specular_transmittance=[0.9, 0.8, 0.7]),
    "conductor": S.Conductor.named("Au"),
    "mirror": S.Conductor(),
    "roughconductor": S.RoughConductor.named("Cu", alpha_u=0.3, alpha_v=0.3),
    "anisotropic": S.RoughConductor.named("Al", alpha_u=0.1, alpha_v=0.5),
    "beckmann": S.RoughConductor.named("Al", alpha_u=0.05, alpha_v=0.3, distribution="beckmann"),
    "beckmann_rough": S.RoughConductor.named("Cu", alpha_u=0.6, alpha_v=0.6, distribution="beckmann"),
    "roughplastic_beckmann": S.RoughPlastic([0.2, 0.5, 0.8], alpha=0.2, distribution="beckmann"),
    "roughdielectric": S.RoughDielectric(1.5, alpha_u=0.3, alpha_v=0.3),
    "roughdielectric_beckmann": S.RoughDielectric(1.33, alpha_u=0.3, alpha_v=0.5, distribution="beckmann"),
    "plastic": S.Plastic([0.2, 0.5, 0.8]),
    "roughplastic": S.RoughPlastic([0.2, 0.5, 0.8], alpha=0.2),
    "twosided": S.TwoSided(S.Diffuse(0.8)),
    "course_glass": PhongMaterial((0.1, 0.1, 0.1), (1, 1, 1), 100.0, (0.3, 0.3, 0.3), (0.7, 0.7, 0.7), 2.0),
}
SMOOTH = ["diffuse", "roughconductor", "anisotropic", "beckmann", "beckmann_rough", "plastic", "roughplastic",
          "roughplastic_beckmann", "twosided", "phong"]


def _table(m):
    return R.BSDFTable.from_materials([m])


def _dirs(rng, n, upper=True):
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if upper:
        v[:, 2] = np.abs(v[:, 2])
    return v


@pytest.mark.parametrize("name", list(ALL))
def test_sampling_weights_never_create_energy(name):
    """E[weight] = directional albedo <= 1 for every incident angle (mean over 4000 samples, 4 sigma slack)."""
    rng = np.random.default_rng(1)
    t = _table(ALL[name])
    for cos in (0.05, 0.3, 0.7, 1.0):
        n = 4000
        wi = np.tile([math.sqrt(1 - cos * cos), 0.0, -cos if name in ("twosided", "course_glass") else cos], (n, 1))
        _, w, _, _, _ = R.sample(t, np.zeros(n, int), wi, rng.random(n), rng.random((n, 2)))
        mean, err = w.mean(0), w.std(0) / math.sqrt(n)
        assert (mean <= 1.0 + 4 * err + 1e-9).all(), (cos, mean)
        assert mean.max() > 0.01


def _chi2_z(observed, expected) -> float:
    """Wilson-Hilferty z score of the chi-square statistic over bins with expected count >= 5."""
    keep = expected >= 5
    chi2 = ((observed[keep] - expected[keep]) ** 2 / expected[keep]).sum()
    k = keep.sum() - 1
    return ((chi2 / k) ** (1 / 3) - (1 - 2 / (9 * k))) / math.sqrt(2 / (9 * k))


TRANSMITTING = ["roughdielectric", "roughdielectric_beckmann"]  # not reciprocal in radiance: no reciprocity test


@pytest.mark.parametrize("name", SMOOTH + TRANSMITTING)
@pytest.mark.parametrize("cos_i", [0.25, 0.8])
def test_chi_square_sampling_matches_pdf(name, cos_i):
    """Histogram of sampled non-delta directions over (cos theta, phi) bins vs the pdf integrated over each bin."""
    m = PhongMaterial((0.3, 0.3, 0.3), (0.5, 0.5, 0.5), 20.0) if name == "phong" else ALL[name]
    t = _table(m)
    rng = np.random.default_rng(2)
    n = 40000
    wi = np.tile([math.sqrt(1 - cos_i ** 2), 0.0, cos_i], (n, 1))
    wo, w, pdf, delta, _ = R.sample(t, np.zeros(n, int), wi, rng.random(n), rng.random((n, 2)))
    ok = ~delta & (pdf > 0)
    nt, nphi, sub = 10, 20, 6
    z = np.clip(wo[ok, 2], -1, 1)
    phi = np.mod(np.arctan2(wo[ok, 1], wo[ok, 0]), 2 * np.pi)
    obs = np.zeros((nt, nphi))
    np.add.at(obs, (np.minimum(((z + 1) / 2 * nt).astype(int), nt - 1), (phi / (2 * np.pi) * nphi).astype(int)
                    % nphi), 1)
    # expected: pdf integrated over each bin by the midpoint rule (uniform in z and phi: d omega = dz dphi)
    zs = -1 + (np.arange(nt * sub) + 0.5) * 2 / (nt * sub)
    ps = (np.arange(nphi * sub) + 0.5) * 2 * np.pi / (nphi * sub)
    zz, pp = np.meshgrid(zs, ps, indexing="ij")
    r = np.sqrt(1 - zz ** 2)
    d = np.column_stack([(r * np.cos(pp)).ravel(), (r * np.sin(pp)).ravel(), zz.ravel()])
    _, p = R.eval_pdf(t, np.zeros(len(d), int), np.tile(wi[0], (len(d), 1)), d)
    cell = (2 / (nt * sub)) * (2 * np.pi / (nphi * sub))
    exp = (p * cell).reshape(nt, sub, nphi, sub).sum(axis=(1, 3)) * n
    assert abs(exp.sum() - ok.sum()) < 0.03 * n + 5 * math.sqrt(n)  # the pdf integrates to the non-delta share
    assert _chi2_z(obs, exp) < 3.5


@pytest.mark.parametrize("name", SMOOTH)
def test_reciprocity(name):
    """f(wi, wo) = f(wo, wi): eval (which includes cos theta_o) divided by the cosines is symmetric."""
    m = PhongMaterial((0.3, 0.3, 0.3), (0.5, 0.5, 0.5), 20.0) if name == "phong" else ALL[name]
    t = _table(m)
    rng = np.random.default_rng(3)
    wi, wo = _dirs(rng, 500), _dirs(rng, 500)
    s = np.zeros(500, int)
    a, _ = R.eval_pdf(t, s, wi, wo)
    b, _ = R.eval_pdf(t, s, wo, wi)
    np.testing.assert_allclose(a / wo[:, 2:3], b / wi[:, 2:3], rtol=1e-9 if name != "roughplastic" else 1e-9,
                               atol=1e-12)


def test_fresnel_closed_forms():
    f = [fresnel1(c, 1.5) for c in (1.0, -1.0, 0.1)]
    np.testing.assert_allclose([f[0][0], f[1][0]], ((1.5 - 1) / (1.5 + 1)) ** 2)
    assert f[2][0] > 0.5 and f[0][1] == pytest.approx(-1.0)
    # total internal reflection from inside beyond the critical angle
    assert fresnel1(-0.3, 1.5)[0] == 1.0
    # a perfect mirror (eta 0, k 1) reflects everything; a conductor at normal incidence |(n - 1 + ik)/(n + 1 + ik)|^2
    assert fresnel_conductor1(0.2, 0.0, 1.0) == pytest.approx(1.0) and fresnel_conductor1(1.0, 0.0, 1.0) == 1.0
    eta, k = np.array(S.METALS["Au"][0]), np.array(S.METALS["Au"][1])
    expect = ((eta - 1) ** 2 + k ** 2) / ((eta + 1) ** 2 + k ** 2)
    np.testing.assert_allclose([fresnel_conductor1(1.0, e, kk) for e, kk in zip(eta, k, strict=True)], expect,
                               rtol=1e-12)


MITSUBA_CASES = [
    ({"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}}, S.Diffuse([0.2, 0.5, 0.8]), 1e-5),
    ({"type": "roughconductor", "material": "Au", "alpha": 0.3, "distribution": "ggx"},
     S.RoughConductor.named("Au", alpha_u=0.3, alpha_v=0.3), 1e-5),
    ({"type": "roughconductor", "material": "Cu", "alpha_u": 0.1, "alpha_v": 0.4, "distribution": "ggx"},
     S.RoughConductor.named("Cu", alpha_u=0.1, alpha_v=0.4), 1e-5),
    ({"type": "roughconductor", "material": "Al", "alpha_u": 0.05, "alpha_v": 0.3},  # Beckmann, Mitsuba's default
     S.RoughConductor.named("Al", alpha_u=0.05, alpha_v=0.3, distribution="beckmann"), 1e-5),
    ({"type": "roughconductor", "material": "Cu", "alpha": 0.6, "distribution": "beckmann"},
     S.RoughConductor.named("Cu", alpha_u=0.6, alpha_v=0.6, distribution="beckmann"), 1e-5),
    ({"type": "plastic", "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}},
     S.Plastic([0.2, 0.5, 0.8]), 1e-5),
    ({"type": "plastic", "nonlinear": True, "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}},
     S.Plastic([0.2, 0.5, 0.8], nonlinear=True), 1e-5),
    # the rough plastic's transmittance table is integrated differently (quadrature vs Mitsuba's): 0.3% apart
    ({"type": "roughplastic", "distribution": "ggx", "alpha": 0.2,
      "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}}, S.RoughPlastic([0.2, 0.5, 0.8], alpha=0.2),
     3e-3),
    ({"type": "roughplastic", "alpha": 0.2, "diffuse_reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}},
     S.RoughPlastic([0.2, 0.5, 0.8], alpha=0.2, distribution="beckmann"), 3e-3),
]


@pytest.mark.parametrize("mdict,ours,tol", MITSUBA_CASES,
                         ids=[c[0]["type"] + "-" + c[0].get("distribution", "beckmann" if "rough" in c[0]["type"]
                                                             else "") for c in MITSUBA_CASES])
def test_eval_and_pdf_match_mitsuba(mdict, ours, tol):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the independent reference for the BSDF values")
    mi.set_variant("scalar_rgb")
    b = mi.load_dict(mdict)
    t = _table(ours)
    rng = np.random.default_rng(4)
    wi, wo = _dirs(rng, 60), _dirs(rng, 60)
    v, p = R.eval_pdf(t, np.zeros(60, int), wi, wo)
    ctx = mi.BSDFContext()
    mv, mp = [], []
    for a, c in zip(wi, wo, strict=True):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(a)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        mv.append(list(b.eval(ctx, si, mi.Vector3f(c))))
        mp.append(b.pdf(ctx, si, mi.Vector3f(c)))
    np.testing.assert_allclose(v, np.array(mv), rtol=tol, atol=tol * np.max(mv))
    np.testing.assert_allclose(p, np.array(mp), rtol=tol, atol=tol * np.max(mp))


@pytest.mark.parametrize("distribution,alpha,eta", [("ggx", 0.3, 1.5), ("beckmann", 0.2, 1.33)])
def test_roughdielectric_matches_mitsuba_from_both_sides(distribution, alpha, eta):
    """Reflection and refraction, entering and leaving: eval and pdf equal Mitsuba's roughdielectric."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the independent reference for the BSDF values")
    mi.set_variant("scalar_rgb")
    b = mi.load_dict({"type": "roughdielectric", "distribution": distribution, "alpha": alpha, "int_ior": eta,
                      "ext_ior": 1.0})
    t = _table(S.RoughDielectric(eta, 1.0, alpha_u=alpha, alpha_v=alpha, distribution=distribution))
    rng = np.random.default_rng(5)
    wi, wo = _dirs(rng, 200, upper=False), _dirs(rng, 200, upper=False)
    v, p = R.eval_pdf(t, np.zeros(200, int), wi, wo)
    ctx = mi.BSDFContext()
    mv, mp = [], []
    for a, c in zip(wi, wo, strict=True):
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(a)
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        mv.append(list(b.eval(ctx, si, mi.Vector3f(c))))
        mp.append(b.pdf(ctx, si, mi.Vector3f(c)))
    assert (np.array(mp) > 0).sum() > 50 and ((wi[:, 2] * wo[:, 2]) < 0).sum() > 50
    np.testing.assert_allclose(v, np.array(mv), rtol=1e-4, atol=1e-5 * np.max(mv))
    np.testing.assert_allclose(p, np.array(mp), rtol=1e-4, atol=1e-5 * np.max(mp))


@pytest.mark.parametrize("alpha", [1e-4, 1e-3, 1e-2, 0.1])
def test_near_smooth_beckmann_glass_samples_as_mitsuba(alpha):
    """roughdielectric's sample equals Mitsuba's for the same random numbers, entering and leaving, down to the
    1e-4 floor of alpha (the textured roughdielectric scene's smooth cells): the same lobe (up to Mitsuba's float32
    lobe choice at a boundary), the same mean weight and mean direction, and from alpha 1e-2 up the same direction
    and weight sample by sample (below it both take the normal-incidence branch of the visible-normal inversion,
    which maps the random numbers to other directions of the same lobe)."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the independent reference for the BSDF values")
    mi.set_variant("scalar_rgb")
    b = mi.load_dict({"type": "roughdielectric", "distribution": "beckmann", "alpha": alpha, "int_ior": "bk7",
                      "ext_ior": "air"})
    t = _table(S.RoughDielectric(1.5046, 1.000277, alpha_u=alpha, alpha_v=alpha, distribution="beckmann"))
    rng = np.random.default_rng(6)
    ctx = mi.BSDFContext()
    for cos in (0.9, 0.3, -0.4, -0.9):
        n = 300
        wi = np.tile([math.sqrt(1 - cos * cos), 0.0, cos], (n, 1))
        u1, u2 = rng.random(n), rng.random((n, 2))
        wo, w, _, _, _ = R.sample(t, np.zeros(n, int), wi, u1, u2)
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(wi[0])
        theirs = [b.sample(ctx, si, float(a), mi.Point2f(*c)) for a, c in zip(u1, u2, strict=True)]
        mwo = np.array([list(bs.wo) for bs, _ in theirs])
        mw = np.array([list(ww) for _, ww in theirs])
        assert (np.sign(wo[:, 2]) == np.sign(mwo[:, 2])).mean() >= 0.98
        assert w.mean() == pytest.approx(mw.mean(), rel=0.01)
        np.testing.assert_allclose(wo.mean(0), mwo.mean(0), atol=0.02 + 4 * alpha)
        if alpha >= 1e-2:
            same = (np.abs(wo - mwo).max(1) < 1e-4) & (np.abs(w - mw).max(1) < 1e-4 * (1 + np.abs(mw).max(1)))
            assert same.mean() >= 0.98, (cos, same.mean())


def test_thindielectric_samples_as_mitsuba():
    """thindielectric from both sides: the lobe, direction, weight and pdf of Mitsuba's sample for the same random
    number (reflect with R' = 2R / (1 + R), else straight through), and no value or pdf from eval."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the independent reference for the BSDF values")
    mi.set_variant("scalar_rgb")
    b = mi.load_dict({"type": "thindielectric", "int_ior": 1.7, "ext_ior": 1.1,
                      "specular_reflectance": {"type": "rgb", "value": [0.9, 0.7, 0.5]},
                      "specular_transmittance": {"type": "rgb", "value": [0.6, 0.8, 1.0]}})
    t = _table(S.ThinDielectric(1.7, 1.1, [0.9, 0.7, 0.5], [0.6, 0.8, 1.0]))
    rng = np.random.default_rng(7)
    n = 300
    wi = _dirs(rng, n, upper=False)
    u1, u2 = rng.random(n), rng.random((n, 2))
    wo, w, pdf, delta, eta = R.sample(t, np.zeros(n, int), wi, u1, u2)
    ctx = mi.BSDFContext()
    mwo, mw, mpdf = [], [], []
    for a, u, c in zip(wi, u1, u2, strict=True):
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(a)
        bs, ww = b.sample(ctx, si, float(u), mi.Point2f(*c))
        mwo.append(list(bs.wo))
        mw.append(list(ww))
        mpdf.append(bs.pdf)
        assert not any(b.eval(ctx, si, bs.wo)) and b.pdf(ctx, si, bs.wo) == 0
    np.testing.assert_allclose(wo, mwo, atol=1e-6)
    np.testing.assert_allclose(w, mw, rtol=1e-6)
    np.testing.assert_allclose(pdf, mpdf, rtol=1e-5)
    assert delta.all() and (eta == 1).all() and 30 < (wo[:, 2] * wi[:, 2] > 0).sum() < n - 30
    v, p = R.eval_pdf(t, np.zeros(n, int), wi, wo)
    assert not v.any() and not p.any()
