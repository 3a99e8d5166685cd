"""Mitsuba 3's `principledthin` BSDF (the Disney model for thin, two-sided surfaces such as leaves and paper) as
scalar Numba functions over one row of the packed table: eval with its pdf, and sample. Conventions as in
kernels/path/bsdf.py; the row's columns as the principled BSDF's (kernels/path/principled.py).

The surface is the same from both sides (both directions are mirrored through the origin to wi's side first), and
light that passes keeps its direction's tangent part (no refraction: the index only sets the Fresnel term). With
st = spec_trans and dt = diff_trans, the lobes as Mitsuba 3.9 weighs them (measured with mi.load_dict):
- specular reflection st F D G / (4 cos_i), GGX alpha from roughness^2, F the dielectric one lerped by spec_tint
  towards a Schlick term of the tinted base colour;
- specular transmission st base (1 - F) D_t G1(wi) G1(wo) / (4 cos_i) about the mirrored direction, roughness
  scaled by 0.65 eta - 0.35;
- diffuse reflection (1 - st)(1 - dt / 2) base / pi (Burley's diffuse with retro-reflection, lerped by flatness
  towards the Hanrahan-Krueger fake subsurface term), sheen weighted the same, and diffuse transmission
  (1 - st) dt / 2 base / pi.
Each lobe is sampled with probability proportional to that weight (st / 2 for each specular one) times its rate.
A transmitted sample where G1(wo) is 0 is dropped (Mitsuba's eval and pdf are 0 there, so its weight would go
to the diffuse transmission's pdf): the pair is then exact and the estimator unbiased.
"""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT
from .columns import (
    AU,
    C1,
    ETA,
    PR_DIFF_TRANS,
    PR_FLATNESS,
    PR_RATE_DIFF_TRANS,
    PR_RATE_DIFFUSE,
    PR_RATE_SPEC,
    PR_RATE_SPEC_TRANS,
    PR_SHEEN,
    PR_SHEEN_TINT,
    PR_SPEC_TINT,
    PR_SPEC_TRANS,
)
from .microfacet import fresnel1, ggx_d1, ggx_g11, ggx_sample_visible1
from .principled import LUMA, alphas, schlick, schlick_weight
from .warps import INV_PI, cosine_hemisphere3


@nb.njit(**JIT)
def _probs(P, s):
    """Probabilities of sampling specular reflection, specular transmission, diffuse reflection, diffuse
    transmission."""
    st, dt = P[s, PR_SPEC_TRANS], P[s, PR_DIFF_TRANS]
    psr, pst = 0.5 * st * P[s, PR_RATE_SPEC], 0.5 * st * P[s, PR_RATE_SPEC_TRANS]
    pdr = (1.0 - st) * (1.0 - 0.5 * dt) * P[s, PR_RATE_DIFFUSE]
    pdt = (1.0 - st) * 0.5 * dt * P[s, PR_RATE_DIFF_TRANS]
    total = psr + pst + pdr + pdt
    if not total > 0:
        return 0.0, 0.0, 0.0, 0.0
    return psr / total, pst / total, pdr / total, pdt / total


@nb.njit(**JIT, inline="always")
def _unit(x, y, z):
    ln = math.sqrt(x * x + y * y + z * z)
    return x / ln, y / ln, z / ln


@nb.njit(**JIT)
def _reflected(P, s, c, wi, wo, hx, hy, hz, lum, spec, diffuse, sheen):
    """Channel c of the reflection lobes, given their colourless factors."""
    base = P[s, C1 + c]
    v = diffuse * base
    if spec > 0:
        eta = P[s, ETA]
        f = fresnel1(wi[0] * hx + wi[1] * hy + wi[2] * hz, eta)[0]
        tint = P[s, PR_SPEC_TINT]
        r0 = ((eta - 1.0) / (eta + 1.0)) ** 2
        ct = base / lum if lum > 0 else 1.0
        v += ((1.0 - tint) * f + tint * schlick(ct * r0, wi[0] * hx + wi[1] * hy + wi[2] * hz, eta)) * spec
    if sheen > 0:
        v += sheen * (1.0 + P[s, PR_SHEEN_TINT] * ((base / lum if lum > 0 else 1.0) - 1.0))
    return v


@nb.njit(**JIT)
def principledthin_eval(P, s, wi, wo):
    """f(wi, wo) cos(theta_o) (three channels) and the pdf with which principledthin_sample picks wo."""
    if wi[2] == 0 or wo[2] == 0:
        return 0.0, 0.0, 0.0, 0.0
    if wi[2] < 0:  # the same from both sides
        wi, wo = (-wi[0], -wi[1], -wi[2]), (-wo[0], -wo[1], -wo[2])
    ci, co = wi[2], wo[2]
    st, dt, r, eta = P[s, PR_SPEC_TRANS], P[s, PR_DIFF_TRANS], P[s, AU], P[s, ETA]
    psr, pst, pdr, pdt = _probs(P, s)
    if co > 0:
        hx, hy, hz = _unit(wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2])
        ax, ay = alphas(P, s, r)
        d = ggx_d1(hx, hy, hz, ax, ay)
        g1i = ggx_g11(wi[0], wi[1], wi[2], hx, hy, hz, ax, ay)
        spec = st * d * g1i * ggx_g11(wo[0], wo[1], wo[2], hx, hy, hz, ax, ay) / (4.0 * ci)
        fo, fi = schlick_weight(co), schlick_weight(ci)
        cd = hx * wo[0] + hy * wo[1] + hz * wo[2]
        rr = 2.0 * r * cd * cd
        burley = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo) + rr * (fo + fi + fo * fi * (rr - 1.0))
        fss = (1.0 + (0.5 * rr - 1.0) * fo) * (1.0 + (0.5 * rr - 1.0) * fi)
        subsurface = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5)
        flat = P[s, PR_FLATNESS]
        w = (1.0 - st) * (1.0 - 0.5 * dt)
        diffuse = w * co * INV_PI * ((1.0 - flat) * burley + flat * subsurface)
        sheen = w * P[s, PR_SHEEN] * schlick_weight(abs(cd)) * co
        lum = LUMA[0] * P[s, C1] + LUMA[1] * P[s, C1 + 1] + LUMA[2] * P[s, C1 + 2]
        v0 = _reflected(P, s, 0, wi, wo, hx, hy, hz, lum, spec, diffuse, sheen)
        v1 = _reflected(P, s, 1, wi, wo, hx, hy, hz, lum, spec, diffuse, sheen)
        v2 = _reflected(P, s, 2, wi, wo, hx, hy, hz, lum, spec, diffuse, sheen)
        dih = wi[0] * hx + wi[1] * hy + wi[2] * hz
        pdf = psr * d * g1i * abs(dih) / ci / (4.0 * abs(cd)) + pdr * co * INV_PI
        return v0, v1, v2, pdf
    # through: about the mirrored direction wt, with the transmission's scaled roughness
    hx, hy, hz = _unit(wi[0] + wo[0], wi[1] + wo[1], wi[2] - wo[2])
    ax, ay = alphas(P, s, (0.65 * eta - 0.35) * r)
    dih = wi[0] * hx + wi[1] * hy + wi[2] * hz
    dth = wo[0] * hx + wo[1] * hy - wo[2] * hz
    d = ggx_d1(hx, hy, hz, ax, ay)
    g1i = ggx_g11(wi[0], wi[1], wi[2], hx, hy, hz, ax, ay)
    g1o = ggx_g11(wo[0], wo[1], wo[2], hx, hy, hz, ax, ay)  # of wo itself, as Mitsuba's
    trans = st * (1.0 - fresnel1(dih, eta)[0]) * d * g1i * g1o / (4.0 * ci)
    diffuse = (1.0 - st) * 0.5 * dt * abs(co) * INV_PI
    m = trans + diffuse
    pdf = (pst * d * g1i * abs(dih) / ci / (4.0 * abs(dth)) if g1o > 0 else 0.0) + pdt * abs(co) * INV_PI
    return P[s, C1] * m, P[s, C1 + 1] * m, P[s, C1 + 2] * m, pdf


@nb.njit(**JIT)
def principledthin_sample(P, s, wi, u1, u20, u21):
    """(wo, weight = f cos / pdf, pdf, delta = False, eta = 1): a lobe picked by its probability, its direction from
    wi mirrored to the front side, then mirrored back."""
    zero = ((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), 0.0, False, 1.0)
    if wi[2] == 0:
        return zero
    sg = 1.0 if wi[2] > 0 else -1.0
    wx, wy, wz = wi[0] * sg, wi[1] * sg, wi[2] * sg
    psr, pst, pdr, _ = _probs(P, s)
    if u1 < psr + pst:
        r = P[s, AU] if u1 < psr else (0.65 * P[s, ETA] - 0.35) * P[s, AU]
        ax, ay = alphas(P, s, r)
        mx, my, mz = ggx_sample_visible1(wx, wy, wz, u20, u21, ax, ay)
        c = 2.0 * (wx * mx + wy * my + wz * mz)
        ox, oy, oz = c * mx - wx, c * my - wy, c * mz - wz
        if not oz > 0:
            return zero
        if u1 >= psr:
            oz = -oz
            if not (ox * mx + oy * my + oz * mz) * oz > 0:  # where eval's G1(wo) and the pdf's share are 0
                return zero
    else:
        ox, oy, oz = cosine_hemisphere3(u20, u21)
        if u1 >= psr + pst + pdr:
            oz = -oz
    wo = (ox * sg, oy * sg, oz * sg)
    v0, v1, v2, pdf = principledthin_eval(P, s, wi, wo)
    if not pdf > 0:
        return zero
    return wo, (v0 / pdf, v1 / pdf, v2 / pdf), pdf, False, 1.0
