"""The path tracer's BSDFs as scalar Numba functions: evaluation, importance sampling and pdfs of one direction
pair, read from a packed table (one float64 row per material slot, its columns in kernels/path/columns.py;
rendering/bsdfs.py builds it and documents the models and the course's Phong mapping).

Directions are in the local frame of the (possibly flipped) surface normal, z up, both pointing away from the
surface: wi towards where the path came from, wo the new direction. As in Mitsuba 3, eval returns
f(wi, wo) cos(theta_o), sample returns wo with weight = f cos / pdf, and delta lobes are reached only by sampling.

Parameters that Mitsuba takes as textures name a texture of kernels/path/textures.py in their TEX_* column (-1: the
constant column holds the value); the bounce resolves such a row at the hit's UV into a scratch row first
(textures.resolve_row), so every function here reads plain numbers. The principled BSDFs' functions are in
kernels/path/principled.py and kernels/path/principledthin.py. Two modifiers apply to any row: OPACITY (Mitsuba's
`mask`: the ray passes through with probability 1 - opacity, a delta lobe) and TWOSIDED; a BLEND row mixes the rows
CHILD0 and CHILD1 by WEIGHT (Mitsuba's `blendbsdf`).
"""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT
from .columns import (
    AU,
    AV,
    BECKMANN,
    C1,
    C2,
    C3,
    C4,
    CONDUCTOR,
    DIELECTRIC,
    DIFFUSE,
    ETA,
    EXPONENT,
    FDR_INT,
    KIND,
    NONLINEAR,
    PHONG,
    PLASTIC,
    PR_ANISO,
    PRINCIPLED,
    PRINCIPLEDTHIN,
    ROUGHCONDUCTOR,
    ROUGHDIELECTRIC,
    ROUGHPLASTIC,
    SPEC_WEIGHT,
    THINDIELECTRIC,
    TROW,
    TWOSIDED,
)
from .microfacet import d1, fresnel1, fresnel_conductor1, g11, half_vector, sample_visible1
from .principled import principled_eval, principled_sample
from .principledthin import principledthin_eval, principledthin_sample
from .warps import INV_PI, cosine_hemisphere3, frame3, to_world3


@nb.njit(**JIT, inline="always")
def anisotropic(P, s):
    """Does slot s's BSDF depend on the tangent's direction (alpha_u != alpha_v, or a principled BSDF's anisotropic
    above 0)? Only these are shaded in Mitsuba's dp/du frame (warps.tangent_frame3); the rest keep frame3(n),
    whatever the tangent, so their images stay."""
    k = P[s, KIND]
    return ((k == ROUGHCONDUCTOR or k == ROUGHDIELECTRIC) and P[s, AU] != P[s, AV]) or (
        (k == PRINCIPLED or k == PRINCIPLEDTHIN) and P[s, PR_ANISO] != 0)


@nb.njit(**JIT, inline="always")
def _reflect(wx, wy, wz, mx, my, mz):
    c = 2.0 * (wx * mx + wy * my + wz * mz)
    return c * mx - wx, c * my - wy, c * mz - wz


@nb.njit(**JIT, inline="always")
def _diffuse_base(P, s, c):
    d = P[s, C1 + c]
    fdr = P[s, FDR_INT]
    return d / (1.0 - (d * fdr if P[s, NONLINEAR] != 0 else fdr))


@nb.njit(**JIT)
def _transmittance(T, s, cos):
    """The rough plastic's tabulated transmittance at cos(theta), linearly interpolated."""
    res = T.shape[1]
    x = min(max(cos, 0.0), 1.0) * (res - 1)
    i = min(int(x), res - 2)
    f = x - i
    return (1.0 - f) * T[s, i] + f * T[s, i + 1]


@nb.njit(**JIT)
def _plastic_probs(P, T, s, wz):
    """Probabilities of the specular and the diffuse lobe of a (rough) plastic seen from wi."""
    sw = P[s, SPEC_WEIGHT]
    if P[s, KIND] == ROUGHPLASTIC:
        ti = _transmittance(T, int(P[s, TROW]), wz)
        ps, pd = (1.0 - ti) * sw, ti * (1.0 - sw)
    else:
        fi = fresnel1(wz, P[s, ETA])[0]
        ps, pd = fi * sw, (1.0 - fi) * (1.0 - sw)
    total = ps + pd
    ps = ps / total if total > 0 else 0.0
    return ps, 1.0 - ps


@nb.njit(**JIT)
def _microfacet(wi, wo, au, av, beck):
    """Microfacet terms (GGX, or Beckmann where beck) of a rough BSDF's eval: half vector, D, G1(wi), G and the
    clamped cos of wi."""
    hx, hy, hz = wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]
    ln = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-300)
    hx, hy, hz = hx / ln, hy / ln, hz / ln
    d = d1(hx, hy, hz, au, av, beck)
    g1i = g11(wi[0], wi[1], wi[2], hx, hy, hz, au, av, beck)
    g = g1i * g11(wo[0], wo[1], wo[2], hx, hy, hz, au, av, beck)
    return hx, hy, hz, d, g1i, g, max(wi[2], 1e-300)


@nb.njit(**JIT)
def _phong_probs(P, s):
    w0 = (P[s, C1] + P[s, C1 + 1] + P[s, C1 + 2]) / 3.0
    w1 = (P[s, C2] + P[s, C2 + 1] + P[s, C2 + 2]) / 3.0
    w2 = (P[s, C3] + P[s, C3 + 1] + P[s, C3 + 2]) / 3.0
    w3 = (P[s, C4] + P[s, C4 + 1] + P[s, C4 + 2]) / 3.0
    total = w0 + w1 + w2 + w3
    if total > 0:
        return w0 / total, w1 / total, w2 / total, w3 / total
    return 0.0, 0.0, 0.0, 0.0


@nb.njit(**JIT, inline="always")
def _diffuse_eval(P, s, wi, wo):
    c = wo[2] * INV_PI if wi[2] > 0 and wo[2] > 0 else 0.0
    return P[s, C1] * c, P[s, C1 + 1] * c, P[s, C1 + 2] * c, c


@nb.njit(**JIT)
def _roughconductor_eval(P, s, wi, wo):
    ok = wi[2] > 0 and wo[2] > 0
    hx, hy, hz, d, g1i, g, cos_i = _microfacet(wi, wo, P[s, AU], P[s, AV], P[s, BECKMANN] != 0)
    ch = wi[0] * hx + wi[1] * hy + wi[2] * hz
    m = d * g / (4.0 * cos_i) if ok else 0.0
    v0 = P[s, C1] * fresnel_conductor1(ch, P[s, C3], P[s, C4]) * m
    v1 = P[s, C1 + 1] * fresnel_conductor1(ch, P[s, C3 + 1], P[s, C4 + 1]) * m
    v2 = P[s, C1 + 2] * fresnel_conductor1(ch, P[s, C3 + 2], P[s, C4 + 2]) * m
    return v0, v1, v2, (d * g1i / (4.0 * cos_i) if ok else 0.0)


@nb.njit(**JIT)
def _roughconductor_pdf(P, s, wi, wo):
    """_roughconductor_eval's pdf alone, from the same operations (the same bits): its sampling needs no more, and
    the three Fresnel terms and G1(wo) it would discard were a quarter of a sample (130 against 172 ns)."""
    ok = wi[2] > 0 and wo[2] > 0
    au, av, beck = P[s, AU], P[s, AV], P[s, BECKMANN] != 0
    hx, hy, hz = wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]
    ln = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-300)
    hx, hy, hz = hx / ln, hy / ln, hz / ln
    g1i = g11(wi[0], wi[1], wi[2], hx, hy, hz, au, av, beck)
    return d1(hx, hy, hz, au, av, beck) * g1i / (4.0 * max(wi[2], 1e-300)) if ok else 0.0


@nb.njit(**JIT)
def _roughdielectric_eval(P, s, wi, wo):
    """Walter et al.'s rough glass as Mitsuba's roughdielectric: reflection F D G / (4 |cos_i|), refraction
    (1 - F) |D G eta^2 (wi.m)(wo.m) / (cos_i (wi.m + eta wo.m)^2)| / eta^2 (radiance), from either side; the pdf of
    sampling the visible normal seen from wi's side, then the lobe by F."""
    ci, co = wi[2], wo[2]
    if ci == 0 or co == 0:
        return 0.0, 0.0, 0.0, 0.0
    au, av, beck, eta_rel = P[s, AU], P[s, AV], P[s, BECKMANN] != 0, P[s, ETA]
    reflect = ci * co > 0
    eta = eta_rel if ci > 0 else 1.0 / eta_rel
    k = 1.0 if reflect else eta
    hx, hy, hz, dwi, dwo, ok = half_vector(wi, wo, k)
    if not ok:
        return 0.0, 0.0, 0.0, 0.0
    if dwi * ci <= 0 or dwo * co <= 0:
        return 0.0, 0.0, 0.0, 0.0
    d = d1(hx, hy, hz, au, av, beck)
    g = g11(wi[0], wi[1], wi[2], hx, hy, hz, au, av, beck) * g11(wo[0], wo[1], wo[2], hx, hy, hz, au, av, beck)
    f = fresnel1(dwi, eta_rel)[0]
    sg = 1.0 if ci > 0 else -1.0
    pm = d * g11(wi[0] * sg, wi[1] * sg, wi[2] * sg, hx, hy, hz, au, av, beck) * abs(dwi) / abs(ci)
    if reflect:
        v = f * d * g / (4.0 * abs(ci))
        pdf = pm * f / (4.0 * abs(dwo))
        c = C1
    else:
        denom = dwi + eta * dwo
        v = (1.0 - f) * abs(d * g * dwi * dwo / (ci * denom * denom))
        pdf = pm * (1.0 - f) * abs(eta * eta * dwo / (denom * denom))
        c = C2
    return P[s, c] * v, P[s, c + 1] * v, P[s, c + 2] * v, pdf


@nb.njit(**JIT)
def _plastic_eval(P, T, s, wi, wo):
    c = wo[2] if wi[2] > 0 and wo[2] > 0 else 0.0
    eta = P[s, ETA]
    fi, fo = fresnel1(wi[2], eta)[0], fresnel1(wo[2], eta)[0]
    pd = _plastic_probs(P, T, s, wi[2])[1]
    m = (1.0 - fi) * (1.0 - fo) * c / (math.pi * eta * eta)
    return _diffuse_base(P, s, 0) * m, _diffuse_base(P, s, 1) * m, _diffuse_base(P, s, 2) * m, pd * c * INV_PI


@nb.njit(**JIT)
def _roughplastic_eval(P, T, s, wi, wo):
    if not (wi[2] > 0 and wo[2] > 0):
        return 0.0, 0.0, 0.0, 0.0
    c = wo[2]
    au, eta = P[s, AU], P[s, ETA]
    hx, hy, hz, d, g1i, g, cos_i = _microfacet(wi, wo, au, au, P[s, BECKMANN] != 0)
    spec = fresnel1(wi[0] * hx + wi[1] * hy + wi[2] * hz, eta)[0] * d * g / (4.0 * cos_i)
    tr = int(P[s, TROW])
    m = _transmittance(T, tr, wi[2]) * _transmittance(T, tr, wo[2]) * c / (math.pi * eta * eta)
    ps, pd = _plastic_probs(P, T, s, wi[2])
    return (P[s, C2] * spec + _diffuse_base(P, s, 0) * m, P[s, C2 + 1] * spec + _diffuse_base(P, s, 1) * m,
            P[s, C2 + 2] * spec + _diffuse_base(P, s, 2) * m, ps * d * g1i / (4.0 * cos_i) + pd * c * INV_PI)


@nb.njit(**JIT)
def _phong_eval(P, s, wi, wo):
    """The course's Phong mixture, lit from both sides: the frame follows wi."""
    side = -1.0 if wi[2] < 0 else 1.0
    wiz, woz = wi[2] * side, wo[2] * side
    c = woz if woz > 0 else 0.0
    e = P[s, EXPONENT]
    cr = min(max(-wi[0] * wo[0] - wi[1] * wo[1] + wiz * woz, 0.0), 1.0) ** e
    lobe = (e + 2.0) / (2.0 * math.pi) * cr
    p0, p1, _, _ = _phong_probs(P, s)
    lobe_pdf = (e + 1.0) / (2.0 * math.pi) * cr if woz > 0 else 0.0
    return (P[s, C1] * c * INV_PI + P[s, C2] * lobe * c, P[s, C1 + 1] * c * INV_PI + P[s, C2 + 1] * lobe * c,
            P[s, C1 + 2] * c * INV_PI + P[s, C2 + 2] * lobe * c, p0 * c * INV_PI + p1 * lobe_pdf)


@nb.njit(**JIT, inline="always")
def leaf_eval(P, T, s, wi, wo):
    """f cos and pdf of a row that is not a blend: a switch over per-kind functions (inlined into bsdf_eval, so a call
    costs one small function); a TwoSided row mirrors the frame to wi's side first."""
    if P[s, TWOSIDED] != 0 and wi[2] < 0:
        wi = (wi[0], wi[1], -wi[2])
        wo = (wo[0], wo[1], -wo[2])
    k = P[s, KIND]
    if k == DIFFUSE:
        return _diffuse_eval(P, s, wi, wo)
    if k == ROUGHCONDUCTOR:
        return _roughconductor_eval(P, s, wi, wo)
    if k == PLASTIC:
        return _plastic_eval(P, T, s, wi, wo)
    if k == ROUGHPLASTIC:
        return _roughplastic_eval(P, T, s, wi, wo)
    if k == PHONG:
        return _phong_eval(P, s, wi, wo)
    if k == ROUGHDIELECTRIC:
        return _roughdielectric_eval(P, s, wi, wo)
    if k == PRINCIPLED:
        return principled_eval(P, s, wi, wo)
    if k == PRINCIPLEDTHIN:
        return principledthin_eval(P, s, wi, wo)
    return 0.0, 0.0, 0.0, 0.0  # dielectric, thin dielectric, conductor (delta lobes only), black


@nb.njit(**JIT, inline="always")
def _diffuse_sample(P, s, wi, u20, u21):
    wo = cosine_hemisphere3(u20, u21)
    ok = 1.0 if wi[2] > 0 and wo[2] > 0 else 0.0
    return wo, (P[s, C1] * ok, P[s, C1 + 1] * ok, P[s, C1 + 2] * ok), wo[2] * INV_PI * ok, False, 1.0


@nb.njit(**JIT)
def _dielectric_sample(P, s, wi, u1):
    wx, wy, wz = wi
    f, cos_t, eta_it, eta_ti = fresnel1(wz, P[s, ETA])
    if u1 <= f:
        return (-wx, -wy, wz), (P[s, C1], P[s, C1 + 1], P[s, C1 + 2]), f, True, 1.0
    # radiance is scaled by (eta_t / eta_i)^-2 when refracted (Veach's non-symmetric scattering)
    e2 = eta_ti * eta_ti
    return ((-eta_ti * wx, -eta_ti * wy, cos_t), (P[s, C2] * e2, P[s, C2 + 1] * e2, P[s, C2 + 2] * e2),
            1.0 - f, True, eta_it)


@nb.njit(**JIT)
def _thindielectric_sample(P, s, wi, u1):
    """Mitsuba's thindielectric, from either side: a slab's reflectance summed over its internal bounces,
    R' = R + T^2 R / (1 - R^2) = 2 R / (1 + R) with R the Fresnel reflectance at |cos(theta_i)|; reflect with
    probability R', else pass straight through (no refraction, no radiance scaling)."""
    wx, wy, wz = wi
    r = fresnel1(abs(wz), P[s, ETA])[0]
    if r < 1.0:
        r *= 2.0 / (1.0 + r)
    if u1 <= r:
        return (-wx, -wy, wz), (P[s, C1], P[s, C1 + 1], P[s, C1 + 2]), r, True, 1.0
    return (-wx, -wy, -wz), (P[s, C2], P[s, C2 + 1], P[s, C2 + 2]), 1.0 - r, True, 1.0


@nb.njit(**JIT)
def _conductor_sample(P, s, wi):
    wx, wy, wz = wi
    ok = 1.0 if wz > 0 else 0.0
    return ((-wx, -wy, wz), (P[s, C1] * fresnel_conductor1(wz, P[s, C3], P[s, C4]) * ok,
                             P[s, C1 + 1] * fresnel_conductor1(wz, P[s, C3 + 1], P[s, C4 + 1]) * ok,
                             P[s, C1 + 2] * fresnel_conductor1(wz, P[s, C3 + 2], P[s, C4 + 2]) * ok),
            ok, True, 1.0)


@nb.njit(**JIT)
def _roughconductor_sample(P, s, wi, u20, u21):
    wx, wy, wz = wi
    au, av, beck = P[s, AU], P[s, AV], P[s, BECKMANN] != 0
    mx, my, mz = sample_visible1(wx, wy, wz, u20, u21, au, av, beck)
    wo = _reflect(wx, wy, wz, mx, my, mz)
    ok = 1.0 if wz > 0 and wo[2] > 0 else 0.0
    g = g11(wo[0], wo[1], wo[2], mx, my, mz, au, av, beck) * ok
    cm = wx * mx + wy * my + wz * mz
    pdf = _roughconductor_pdf(P, s, wi, wo)
    return (wo, (P[s, C1] * fresnel_conductor1(cm, P[s, C3], P[s, C4]) * g,
                 P[s, C1 + 1] * fresnel_conductor1(cm, P[s, C3 + 1], P[s, C4 + 1]) * g,
                 P[s, C1 + 2] * fresnel_conductor1(cm, P[s, C3 + 2], P[s, C4 + 2]) * g), pdf, False, 1.0)


@nb.njit(**JIT)
def _roughdielectric_sample(P, s, wi, u1, u20, u21):
    """A visible normal seen from wi's side, then reflection with probability F, else refraction; weight = f cos /
    pdf (zero where the picked lobe would leave on the wrong side, as in Mitsuba)."""
    wx, wy, wz = wi
    sg = 1.0 if wz >= 0 else -1.0
    mx, my, mz = sample_visible1(wx * sg, wy * sg, wz * sg, u20, u21, P[s, AU], P[s, AV], P[s, BECKMANN] != 0)
    dwi = wx * mx + wy * my + wz * mz
    f, cos_t, eta_it, eta_ti = fresnel1(dwi, P[s, ETA])
    if u1 <= f:
        wo = _reflect(wx, wy, wz, mx, my, mz)
        ok, eta = wo[2] * wz > 0, 1.0
    else:
        k = dwi * eta_ti + cos_t
        wo = (k * mx - eta_ti * wx, k * my - eta_ti * wy, k * mz - eta_ti * wz)
        ok, eta = wo[2] * wz < 0, eta_it
    v0, v1, v2, pdf = _roughdielectric_eval(P, s, wi, wo)
    m = 1.0 / pdf if ok and pdf > 0 else 0.0
    return wo, (v0 * m, v1 * m, v2 * m), pdf, False, eta


@nb.njit(**JIT)
def _plastic_sample(P, T, s, wi, u1, u20, u21):
    wx, wy, wz = wi
    ok = 1.0 if wz > 0 else 0.0
    fi = fresnel1(wz, P[s, ETA])[0]
    ps = _plastic_probs(P, T, s, wz)[0]
    if u1 < ps:
        m = fi / ps * ok
        return (-wx, -wy, wz), (P[s, C2] * m, P[s, C2 + 1] * m, P[s, C2 + 2] * m), ps, True, 1.0
    wo = cosine_hemisphere3(u20, u21)
    v0, v1, v2, pdf = _plastic_eval(P, T, s, wi, wo)
    m = ok / pdf if pdf > 0 else 0.0
    return wo, (v0 * m, v1 * m, v2 * m), pdf, False, 1.0


@nb.njit(**JIT)
def _roughplastic_sample(P, T, s, wi, u1, u20, u21):
    wx, wy, wz = wi
    ps = _plastic_probs(P, T, s, wz)[0]
    if u1 < ps:
        au, beck = P[s, AU], P[s, BECKMANN] != 0
        mx, my, mz = (sample_visible1(wx, wy, wz, u20, u21, au, au, beck) if wz > 0 else
                      sample_visible1(0.0, 0.0, 1.0, u20, u21, au, au, beck))
        wo = _reflect(wx, wy, wz, mx, my, mz)
    else:
        wo = cosine_hemisphere3(u20, u21)
    v0, v1, v2, pdf = _roughplastic_eval(P, T, s, wi, wo)
    m = 1.0 / pdf if pdf > 0 else 0.0
    return wo, (v0 * m, v1 * m, v2 * m), pdf, False, 1.0


@nb.njit(**JIT)
def _phong_sample(P, s, wi, u1, u20, u21):
    """The course's Phong mixture: a lobe picked by its mean colour, lit from both sides."""
    side = -1.0 if wi[2] < 0 else 1.0
    wf = (wi[0], wi[1], wi[2] * side)
    p0, p1, p2, p3 = _phong_probs(P, s)
    lobe = (u1 >= p0) + (u1 >= p0 + p1) + (u1 >= p0 + p1 + p2)
    r = (-wf[0], -wf[1], wf[2])
    if lobe == 0:
        wo = cosine_hemisphere3(u20, u21)
    elif lobe == 1:  # glossy: cos(alpha) = u^(1 / (e + 1)) about the mirror direction
        ca = u20 ** (1.0 / (P[s, EXPONENT] + 1.0))
        sa = math.sqrt(max(0.0, 1.0 - ca * ca))
        phi = 2.0 * math.pi * u21
        ts, tt = frame3(r[0], r[1], r[2])
        wo = to_world3(sa * math.cos(phi), sa * math.sin(phi), ca, ts, tt, r[0], r[1], r[2])
    elif lobe == 2:
        wo = r
    else:
        eta = P[s, ETA] if side > 0 else 1.0 / max(P[s, ETA], 1e-12)
        cos_t2 = 1.0 - (1.0 - wf[2] * wf[2]) / (eta * eta)
        wo = (-wf[0] / eta, -wf[1] / eta, -math.sqrt(cos_t2)) if cos_t2 > 0 else r  # TIR reflects
    on = 1.0 if p0 + p1 + p2 + p3 > 0 else 0.0
    wo_out = (wo[0], wo[1], wo[2] * side)
    if lobe >= 2:
        pl = p2 if lobe == 2 else p3
        c = C3 if lobe == 2 else C4
        m = on / max(pl, 1e-300)
        return wo_out, (P[s, c] * m, P[s, c + 1] * m, P[s, c + 2] * m), pl, True, 1.0
    v0, v1, v2, pdf = _phong_eval(P, s, wf, wo)
    m = on / pdf if pdf > 0 else 0.0
    return wo_out, (v0 * m, v1 * m, v2 * m), pdf, False, 1.0


@nb.njit(**JIT, inline="always")
def leaf_sample(P, T, s, wi, u1, u20, u21):
    """bsdf_sample of a row that is not a blend (inlined into bsdf_sample, as leaf_eval)."""
    flip = P[s, TWOSIDED] != 0 and wi[2] < 0
    if flip:
        wi = (wi[0], wi[1], -wi[2])
    k = P[s, KIND]
    if k == DIFFUSE:
        wo, w, pdf, delta, eta = _diffuse_sample(P, s, wi, u20, u21)
    elif k == DIELECTRIC:
        wo, w, pdf, delta, eta = _dielectric_sample(P, s, wi, u1)
    elif k == CONDUCTOR:
        wo, w, pdf, delta, eta = _conductor_sample(P, s, wi)
    elif k == ROUGHCONDUCTOR:
        wo, w, pdf, delta, eta = _roughconductor_sample(P, s, wi, u20, u21)
    elif k == PLASTIC:
        wo, w, pdf, delta, eta = _plastic_sample(P, T, s, wi, u1, u20, u21)
    elif k == ROUGHPLASTIC:
        wo, w, pdf, delta, eta = _roughplastic_sample(P, T, s, wi, u1, u20, u21)
    elif k == PHONG:
        wo, w, pdf, delta, eta = _phong_sample(P, s, wi, u1, u20, u21)
    elif k == ROUGHDIELECTRIC:
        wo, w, pdf, delta, eta = _roughdielectric_sample(P, s, wi, u1, u20, u21)
    elif k == THINDIELECTRIC:
        wo, w, pdf, delta, eta = _thindielectric_sample(P, s, wi, u1)
    elif k == PRINCIPLED:
        wo, w, pdf, delta, eta = principled_sample(P, s, wi, u1, u20, u21)
    elif k == PRINCIPLEDTHIN:
        wo, w, pdf, delta, eta = principledthin_sample(P, s, wi, u1, u20, u21)
    else:
        wo, w, pdf, delta, eta = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, False, 1.0
    if flip:
        wo = (wo[0], wo[1], -wo[2])
    return wo, w, pdf, delta, eta


@nb.njit(**JIT)
def leaf_albedo(P, s, wiz):
    """A diffuse BSDF's reflectance, a plastic's diffuse reflectance, a principled BSDF's base colour, a rough
    conductor's specular reflectance times its Fresnel reflectance at normal incidence, the sum of a course Phong
    material's lobes (scaled to at most 1, as the table holds them). Zero for one-sided BSDFs seen from behind, and for
    smooth dielectrics and conductors (the path goes on through them: their albedo is what they show)."""
    k = P[s, KIND]
    if P[s, TWOSIDED] != 0:
        wiz = abs(wiz)
    if k == PHONG:
        return (P[s, C1] + P[s, C2] + P[s, C3] + P[s, C4], P[s, C1 + 1] + P[s, C2 + 1] + P[s, C3 + 1] + P[s, C4 + 1],
                P[s, C1 + 2] + P[s, C2 + 2] + P[s, C3 + 2] + P[s, C4 + 2])
    if not wiz > 0:
        return 0.0, 0.0, 0.0
    if k == PRINCIPLEDTHIN:  # the same from both sides
        return P[s, C1], P[s, C1 + 1], P[s, C1 + 2]
    if k == DIFFUSE or k == PLASTIC or k == ROUGHPLASTIC or k == PRINCIPLED:
        return P[s, C1], P[s, C1 + 1], P[s, C1 + 2]
    if k == ROUGHCONDUCTOR:
        return (P[s, C1] * fresnel_conductor1(1.0, P[s, C3], P[s, C4]),
                P[s, C1 + 1] * fresnel_conductor1(1.0, P[s, C3 + 1], P[s, C4 + 1]),
                P[s, C1 + 2] * fresnel_conductor1(1.0, P[s, C3 + 2], P[s, C4 + 2]))
    return 0.0, 0.0, 0.0
