"""Mitsuba's composed BSDFs in durer's kernels (kernels/path/compose.py, kernels/path/textures.shading_frame)
against Mitsuba 3's own values in scalar_rgb: blendbsdf and mask eval, pdf and sample (constant and textured
weights), and normalmap and bumpmap (shading_frame, then a diffuse BSDF in that frame) eval, pdf and sample."""

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


@pytest.fixture(scope="module")
def map_pngs(tmp_path_factory):
    """A 6 x 5 normal map (RGB, read raw) leaning every way, and a 7 x 4 height map (grey, sRGB as Mitsuba reads)."""
    d = tmp_path_factory.mktemp("maps")
    rng = np.random.default_rng(11)
    lean = np.concatenate([rng.uniform(0.15, 0.85, (5, 6, 2)), rng.uniform(0.75, 1.0, (5, 6, 1))], axis=2)
    Image.fromarray((lean * 255).astype(np.uint8)).save(d / "normal.png")
    Image.fromarray((rng.random((4, 7)) * 255).astype(np.uint8), mode="L").save(d / "height.png")
    return d


def _map_cases(d, flip: bool, shadow: bool):
    normal, height = str(d / "normal.png"), str(d / "height.png")
    nmap = {"type": "bitmap", "filename": normal, "raw": True}
    bump = {"type": "bitmap", "filename": height}
    rough = {"type": "roughconductor", "alpha_u": 0.1, "alpha_v": 0.5, "distribution": "ggx"}
    opts = {"flip_invalid_normals": flip, "use_shadowing_function": shadow}  # both true by default in Mitsuba
    return [
        ({"type": "normalmap", **opts, "normalmap": nmap, "bsdf": {"type": "diffuse", "reflectance": 0.6}},
         B.NormalMap(B.Diffuse(0.6), Bitmap(read_texture(normal, True)), flip, shadow)),
        ({"type": "normalmap", **opts, "normalmap": nmap, "bsdf": rough},  # anisotropic: the frame's tangent matters
         B.NormalMap(B.RoughConductor(alpha_u=0.1, alpha_v=0.5, distribution="ggx"),
                     Bitmap(read_texture(normal, True)), flip, shadow)),
        ({"type": "bumpmap", **opts, "t": bump, "bsdf": {"type": "diffuse", "reflectance": 0.6}},
         B.BumpMap(B.Diffuse(0.6), Bitmap(read_texture(height)), 1.0, flip, shadow)),
        ({"type": "bumpmap", **opts, "t": bump, "scale": 0.3, "bsdf": rough},  # the bumped frame's tangent too
         B.BumpMap(B.RoughConductor(alpha_u=0.1, alpha_v=0.5, distribution="ggx"), Bitmap(read_texture(height)), 0.3,
                   flip, shadow)),
        ({"type": "bumpmap", **opts, "t": bump, "scale": 0.3, "bsdf": {"type": "diffuse", "reflectance": 0.6}},
         B.BumpMap(B.Diffuse(0.6), Bitmap(read_texture(height)), 0.3, flip, shadow)),
        # seen from both sides (BACK_LIT): a two-sided BSDF inside the map, and glass
        ({"type": "normalmap", **opts, "normalmap": nmap,
          "bsdf": {"type": "twosided", "b": {"type": "diffuse", "reflectance": 0.6}}},
         B.NormalMap(B.TwoSided(B.Diffuse(0.6)), Bitmap(read_texture(normal, True)), flip, shadow)),
        ({"type": "normalmap", **opts, "normalmap": nmap,
          "bsdf": {"type": "roughdielectric", "alpha": 0.3, "distribution": "ggx"}},
         B.NormalMap(B.RoughDielectric(alpha_u=0.3, alpha_v=0.3, distribution="ggx"),
                     Bitmap(read_texture(normal, True)), flip, shadow)),
        # a twosided around the map: Mitsuba mirrors wi and wo before the map sees them
        ({"type": "twosided", "b": {"type": "normalmap", **opts, "normalmap": nmap,
                                    "bsdf": {"type": "diffuse", "reflectance": 0.6}}},
         B.TwoSided(B.NormalMap(B.Diffuse(0.6), Bitmap(read_texture(normal, True)), flip, shadow))),
        ({"type": "twosided", "b": {"type": "bumpmap", **opts, "t": bump, "scale": 0.3, "bsdf": rough}},
         B.TwoSided(B.BumpMap(B.RoughConductor(alpha_u=0.1, alpha_v=0.5, distribution="ggx"),
                              Bitmap(read_texture(height)), 0.3, flip, shadow))),
    ]


BACK_LIT = (5, 6, 7, 8)  # cases whose wi may come from behind the surface


# Mitsuba's defaults (both options on) for every case, both off for every case, and each alone for a normal map and
# a bump map over diffuse
MAP_CASES = ([(c, True, True) for c in range(9)] + [(c, False, False) for c in range(9)]
             + [(0, True, False), (0, False, True), (2, True, False), (2, False, True), (5, True, False)])


@pytest.mark.parametrize("case,flip,shadow", MAP_CASES)
def test_normal_and_bump_maps_match_mitsuba(map_pngs, case, flip, shadow):
    """normalmap over diffuse and anisotropic roughconductor, bumpmap (scale 1 and 0.3) over diffuse and (0.3) over
    anisotropic roughconductor: eval, pdf and sample at many UVs of a surface with a tilted shading normal and skewed
    dp/du, dp/dv, against Mitsuba's own SurfaceInteraction3f with the same p, n, sh_frame (initialize_sh_frame: dp/du
    made orthogonal to n), uv, dp/du, dp/dv and wi; seen from both sides too: normalmap over twosided diffuse and
    over rough glass, and a twosided around a normalmap (diffuse) and a bumpmap (anisotropic roughconductor); with Mitsuba 3.9's flip_invalid_normals (a map normal on the other side of wi than the shading
    normal mirrored about it; some wi are grazing so that it acts) and
    use_shadowing_function (Conty Estevez et al.'s terminator term on the value and sampled weight) on, off, and
    each alone. durer's side (shading_frame, then the BSDF in that frame, then textures.map_factor: the test that wo
    stays on the same side of both normals and the shadowing term) is composed here as kernels/path/bounce.py
    composes it."""
    from durer.kernels.path.columns import MAP_FLIP
    from durer.kernels.path.textures import map_factor, shading_frame

    mi = _mitsuba()
    mdict, ours = _map_cases(map_pngs, flip, shadow)[case]
    b = mi.load_dict(mdict)
    table = BSDFTable.from_materials([ours])
    P, _, (TI, TD) = table.packed()
    P0 = P.copy()
    P0[:, MAP_FLIP] = 0  # the map's own normal, unflipped
    n = 80
    rng = np.random.default_rng(20 + case)
    uv = rng.uniform(-0.3, 1.3, (n, 2))
    g = np.array([0.0, 0.0, 1.0])
    ns = rng.normal(size=(n, 3)) * 0.25 + g  # shading normals tilted from the geometric one
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    dpdu = np.array([0.8, 0.3, 0.2]) * 1.7  # neither unit, orthogonal to n nor to each other
    dpdv = np.array([-0.1, 1.2, -0.15]) * 0.6
    wi_l, wo_l = _dirs(n, 6 + case), _dirs(n, 9 + case)  # in Mitsuba's sh_frame, as si.wi and eval's wo
    wi_l[::3, 2] = rng.uniform(0.01, 0.15, len(wi_l[::3]))  # grazing: the map's normal may face away
    wi_l /= np.linalg.norm(wi_l, axis=1, keepdims=True)
    if case in BACK_LIT:  # some from behind, where Mitsuba flips a map normal that wi sees from its front
        wi_l[1::2, 2] *= -1
        wo_l[1::2, 2] *= -1  # mostly on wi's side, some not ([::7] above, and these)
        wo_l[2::4, 2] *= -1
    wo_l[::7, 2] *= -1  # some below the shading surface: black in both
    u1, u2 = rng.random(n), rng.random((n, 2))
    ctx = mi.BSDFContext()
    slot = np.zeros(n, np.int64)
    m_val, m_pdf, frames, wi_d, wo_d, wo_w, factor = [], [], [], [], [], [], []
    sis = []
    away = 0  # how often the map's own normal faced away from wi
    for k in range(n):
        si = mi.SurfaceInteraction3f()
        si.p = mi.Point3f(0.0, 0.0, 0.0)
        si.n = mi.Normal3f(g)
        si.uv = mi.Point2f(*uv[k])
        si.dp_du, si.dp_dv = mi.Vector3f(dpdu), mi.Vector3f(dpdv)
        si.sh_frame = mi.Frame3f(mi.Vector3f(ns[k]))
        si.initialize_sh_frame()
        si.wi = mi.Vector3f(wi_l[k])
        sis.append(si)
        m_val.append(list(b.eval(ctx, si, mi.Vector3f(wo_l[k]))))
        m_pdf.append(b.pdf(ctx, si, mi.Vector3f(wo_l[k])))
        sh = si.sh_frame
        to_world = np.array([list(sh.s), list(sh.t), list(sh.n)]).T
        wi_w = to_world @ wi_l[k]
        m, s, t, bent, side_n = shading_frame(P, 0, TI, TD, tuple(ns[k]), tuple(g), (*uv[k], *dpdu, *dpdv),
                                              tuple(wi_w))
        assert bent
        m0, _, _, _, n0 = shading_frame(P0, 0, TI, TD, tuple(ns[k]), tuple(g), (*uv[k], *dpdu, *dpdv), tuple(wi_w))
        away += np.dot(m0, wi_w) * np.dot(n0, wi_w) < 0
        to_ours = np.array([s, t, m])
        frames.append((to_ours, to_world, m, side_n))
        wo_w.append(to_world @ wo_l[k])
        wi_d.append(to_ours @ wi_w)
        wo_d.append(to_ours @ wo_w[-1])
        factor.append(map_factor(P, 0, side_n, m, tuple(wo_w[-1])))
    wi_d, wo_d, wo_w, factor = np.array(wi_d), np.array(wo_d), np.array(wo_w), np.array(factor)
    value, pdf = eval_pdf(table, slot, wi_d, wo_d, uv)
    value, pdf = value * factor[:, None], pdf * (factor > 0)
    assert np.allclose(value, m_val, rtol=2e-3, atol=1e-5)
    assert np.allclose(pdf, m_pdf, rtol=2e-3, atol=1e-5)
    assert (np.array(m_pdf) > 0).sum() >= n // 4 and (factor == 0).sum() >= 3  # both kinds of direction were seen
    assert away >= 3  # map normals on the other side of wi were seen (flipped, or black without the flip)
    if shadow:  # the shadowing term acted, and the options matter
        assert ((factor > 0) & (factor < 0.99)).sum() >= 3
    # sampling: durer's direction (its own warps), brought back to Mitsuba's sh_frame, has Mitsuba's eval / pdf as
    # its weight and Mitsuba's pdf
    d_wo, d_w, d_pdf, _, d_eta = sample(table, slot, wi_d, u1, u2, uv)
    checked = 0
    for k in range(n):
        to_ours, to_world, m, side_n = frames[k]
        world = to_ours.T @ d_wo[k]
        f = map_factor(P, 0, side_n, m, tuple(world))
        if f == 0:  # bounce.py zeroes these; Mitsuba's sample returns weight 0
            continue
        wo_m = mi.Vector3f(to_world.T @ world)
        mp = b.pdf(ctx, sis[k], wo_m)
        if d_pdf[k] <= 0 or mp <= 1e-6:
            assert not np.any(d_w[k] > 1e-6) or mp <= 1e-6
            continue
        assert d_pdf[k] == pytest.approx(mp, rel=2e-3)
        if (d_eta[k] == 1) == (d_wo[k, 2] * wi_d[k, 2] < 0):  # glass's picked lobe left on its wrong side: weight
            assert not np.any(d_w[k] != 0)  # 0, as Mitsuba's sample (its eval there is the other lobe's)
            continue
        assert np.allclose(d_w[k] * f, np.array(list(b.eval(ctx, sis[k], wo_m))) / mp, rtol=2e-3)
        checked += 1
    assert checked >= n // 3
