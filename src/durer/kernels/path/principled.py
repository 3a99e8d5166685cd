"""Mitsuba 3's `principled` BSDF (the Disney principled model as Mitsuba's principled.cpp has it) as scalar Numba
functions over one row of the packed table (kernels/path/columns.py): eval with its pdf, and sample. Directions and
conventions as in kernels/path/bsdf.py; a row's base colour is C1, its roughness AU, its relative index ETA, the rest
its PR_* columns.

Lobes, each weighted as Mitsuba weighs it (brdf = (1 - metallic)(1 - spec_trans), bsdf = (1 - metallic) spec_trans):
- main specular reflection, GGX with alpha = max(1e-3, roughness^2) (stretched by sqrt(1 - 0.9 anisotropic)), whose
  Fresnel term mixes the dielectric F, a Schlick term towards the base colour (metallic) and a tinted Schlick term
  (spec_tint); from inside only the dielectric F times bsdf;
- specular transmission (Walter et al.'s rough refraction) times sqrt(base colour) bsdf, from either side;
- clearcoat: GTR1 with alpha = lerp(0.1, 0.001, clearcoat_gloss), Schlick F0 = 0.04, Smith GGX shadowing of alpha
  0.25, weighted clearcoat / 4 (Mitsuba's value carries no 1 / (4 cos_i cos_o));
- diffuse with Burley's retro-reflection, and sheen (tinted by sheen_tint), front side only.
Sampling picks a lobe by Mitsuba's probabilities (the dielectric F at a visible GGX normal sampled first, each
scaled by its sampling rate), then weight = eval / pdf of the mixture, so it is unbiased whatever the rates.
"""

from __future__ import annotations

import math

import numba as nb

from ..common import JIT
from .columns import (
    AU,
    C1,
    ETA,
    PR_ANISO,
    PR_CLEARCOAT,
    PR_CLEARCOAT_GLOSS,
    PR_METALLIC,
    PR_RATE_CLEARCOAT,
    PR_RATE_DIFFUSE,
    PR_RATE_SPEC,
    PR_SHEEN,
    PR_SHEEN_TINT,
    PR_SPEC_TINT,
    PR_SPEC_TRANS,
)
from .microfacet import fresnel1, ggx_d1, ggx_g11, ggx_sample_visible1, half_vector
from .warps import INV_PI, cosine_hemisphere3

LUMA = (0.212671, 0.715160, 0.072169)  # Mitsuba's luminance of linear sRGB


@nb.njit(**JIT, inline="always")
def schlick_weight(c):
    m = min(max(1.0 - c, 0.0), 1.0)
    return m * m * m * m * m


@nb.njit(**JIT)
def schlick(r0, cos_i, eta):
    """Schlick's Fresnel towards r0 at cos_i, seen through an interface of relative index eta: from the denser side
    it follows the refracted angle (1 where totally reflected)."""
    eta_it = eta if cos_i >= 0 else 1.0 / eta
    if eta_it > 1.0:
        w = schlick_weight(abs(cos_i))
    else:
        cos_t2 = 1.0 - (1.0 - cos_i * cos_i) / (eta_it * eta_it)
        w = schlick_weight(math.sqrt(max(cos_t2, 0.0)))
    return w * (1.0 - r0) + r0


@nb.njit(**JIT, inline="always")
def alphas(P, s, roughness):
    """GGX alpha_u, alpha_v from a roughness and the row's anisotropic (Mitsuba's calc_dist_params)."""
    r2 = roughness * roughness
    aspect = math.sqrt(1.0 - 0.9 * P[s, PR_ANISO])
    return max(1e-3, r2 / aspect), max(1e-3, r2 * aspect)


@nb.njit(**JIT)
def _probs(P, s, front, f):
    """Probabilities of sampling diffuse, clearcoat, specular transmission, specular reflection from wi's side, given
    the dielectric F at the sampled (or evaluated) microfacet normal."""
    metallic, spec_trans = P[s, PR_METALLIC], P[s, PR_SPEC_TRANS]
    bsdf = (1.0 - metallic) * spec_trans
    if front:
        rate = P[s, PR_RATE_SPEC]
        ps, pt = rate * (1.0 - bsdf * (1.0 - f)), rate * bsdf * (1.0 - f)
        pc = 0.25 * P[s, PR_CLEARCOAT] * P[s, PR_RATE_CLEARCOAT]
        pd = (1.0 - metallic) * (1.0 - spec_trans) * P[s, PR_RATE_DIFFUSE]
    else:
        ps, pt, pc, pd = f, (1.0 - f if spec_trans > 0 else 0.0), 0.0, 0.0
    total = ps + pt + pc + pd
    if not total > 0:
        return 0.0, 0.0, 0.0, 0.0
    return pd / total, pc / total, pt / total, ps / total


@nb.njit(**JIT, inline="always")
def _gtr1_d(cos_h, alpha):
    a2 = alpha * alpha
    d = (a2 - 1.0) / (math.pi * math.log(a2) * (1.0 + (a2 - 1.0) * cos_h * cos_h))
    return d if d * cos_h > 1e-20 else 0.0


@nb.njit(**JIT, inline="always")
def _smith_ggx1(vx, vy, vz, hx, hy, hz, alpha):
    """The clearcoat's isotropic Smith G1 (Mitsuba's smith_ggx1)."""
    if (vx * hx + vy * hy + vz * hz) * vz <= 0:
        return 0.0
    if vz == 1.0:
        return 1.0
    c2 = vz * vz
    return 2.0 / (1.0 + math.sqrt(1.0 + alpha * alpha * (1.0 - c2) / c2))


@nb.njit(**JIT)
def _fresnel_principled(P, s, c, f, cos_ih, front, lum):
    """Channel c of the main specular lobe's Fresnel term (Mitsuba's principled_fresnel)."""
    metallic, spec_tint, eta = P[s, PR_METALLIC], P[s, PR_SPEC_TINT], P[s, ETA]
    if not front:
        return (1.0 - metallic) * P[s, PR_SPEC_TRANS] * f
    base = P[s, C1 + c]
    out = (1.0 - metallic) * (1.0 - spec_tint) * f + metallic * schlick(base, cos_ih, eta)
    if spec_tint > 0:
        eta_it = eta if cos_ih >= 0 else 1.0 / eta
        r0 = ((eta_it - 1.0) / (eta_it + 1.0)) ** 2
        out += (1.0 - metallic) * spec_tint * schlick((base / lum if lum > 0 else 1.0) * r0, cos_ih, eta)
    return out


@nb.njit(**JIT, inline="always")
def _channel(P, s, c, f, cos_ih, front, lum, spec, trans, cc, diffuse, sheen):
    """Channel c of the sum of the lobes, given each lobe's colourless factor."""
    base = P[s, C1 + c]
    v = cc + diffuse * base
    if spec > 0:
        v += _fresnel_principled(P, s, c, f, cos_ih, front, lum) * spec
    if trans > 0:
        v += math.sqrt(base) * trans
    if sheen > 0:
        v += sheen * (1.0 + P[s, PR_SHEEN_TINT] * ((base / lum if lum > 0 else 1.0) - 1.0))
    return v


@nb.njit(**JIT)
def principled_eval(P, s, wi, wo):
    """f(wi, wo) cos(theta_o) (three channels) and the pdf with which principled_sample picks wo."""
    ci, co = wi[2], wo[2]
    if ci == 0 or co == 0:
        return 0.0, 0.0, 0.0, 0.0
    metallic, spec_trans, eta = P[s, PR_METALLIC], P[s, PR_SPEC_TRANS], P[s, ETA]
    brdf, bsdf = (1.0 - metallic) * (1.0 - spec_trans), (1.0 - metallic) * spec_trans
    reflect, front = ci * co > 0, ci > 0
    eta_path = eta if front else 1.0 / eta
    k = 1.0 if reflect else eta_path
    hx, hy, hz, dih, doh, ok = half_vector(wi, wo, k)
    if not ok:
        return 0.0, 0.0, 0.0, 0.0
    f = fresnel1(dih, eta)[0]
    sg = 1.0 if front else -1.0
    compatible = dih * sg > 0 and (doh * sg > 0) == reflect  # the microfacet seen from both sides as the lobe needs
    ax, ay = alphas(P, s, P[s, AU])
    d = ggx_d1(hx, hy, hz, ax, ay)
    g = ggx_g11(wi[0], wi[1], wi[2], hx, hy, hz, ax, ay) * ggx_g11(wo[0], wo[1], wo[2], hx, hy, hz, ax, ay)
    lum = LUMA[0] * P[s, C1] + LUMA[1] * P[s, C1 + 1] + LUMA[2] * P[s, C1 + 2]
    spec = d * g / (4.0 * abs(ci)) if reflect and compatible and f > 0 else 0.0
    trans = 0.0
    if not reflect and compatible and bsdf > 0 and f < 1:
        den = dih + eta_path * doh
        trans = bsdf * abs((1.0 - f) * d * g * dih * doh / (ci * den * den))  # (1 / eta_path)^2: radiance
    clearcoat, gloss = P[s, PR_CLEARCOAT], P[s, PR_CLEARCOAT_GLOSS]
    alpha_cc = 0.1 + gloss * (0.001 - 0.1)
    cc = 0.0
    if reflect and compatible and front and clearcoat > 0:
        cc = (0.25 * clearcoat * (0.04 + 0.96 * schlick_weight(abs(dih))) * _gtr1_d(hz, alpha_cc)
              * _smith_ggx1(wi[0], wi[1], wi[2], hx, hy, hz, 0.25)
              * _smith_ggx1(wo[0], wo[1], wo[2], hx, hy, hz, 0.25) * abs(co))
    diffuse, sheen = 0.0, 0.0
    if reflect and front and brdf > 0:
        fo, fi = schlick_weight(abs(co)), schlick_weight(abs(ci))
        rr = 2.0 * P[s, AU] * doh * doh
        retro = rr * (fo + fi + fo * fi * (rr - 1.0))
        diffuse = brdf * abs(co) * INV_PI * ((1.0 - 0.5 * fi) * (1.0 - 0.5 * fo) + retro)
        if P[s, PR_SHEEN] > 0 and metallic < 1:
            sheen = P[s, PR_SHEEN] * (1.0 - metallic) * schlick_weight(abs(doh)) * abs(co)
    v0 = _channel(P, s, 0, f, dih, front, lum, spec, trans, cc, diffuse, sheen)
    v1 = _channel(P, s, 1, f, dih, front, lum, spec, trans, cc, diffuse, sheen)
    v2 = _channel(P, s, 2, f, dih, front, lum, spec, trans, cc, diffuse, sheen)
    # the pdf: each lobe's probability times its density in wo
    pd, pc, pt, ps = _probs(P, s, front, f)
    pdf = pd * co * INV_PI if reflect else 0.0
    if compatible:
        dwh = 1.0 / abs(4.0 * doh) if reflect else abs(eta_path * eta_path * doh / ((dih + eta_path * doh) ** 2))
        vis = d * ggx_g11(wi[0] * sg, wi[1] * sg, ci * sg, hx, hy, hz, ax, ay) * abs(dih) / abs(ci) * dwh
        if reflect:
            pdf += ps * vis + (pc * hz * _gtr1_d(hz, alpha_cc) * dwh if hz > 0 else 0.0)
        else:
            pdf += pt * vis
    return v0, v1, v2, pdf


@nb.njit(**JIT)
def principled_sample(P, s, wi, u1, u20, u21):
    """(wo, weight = f cos / pdf, pdf, delta = False, eta crossed): a lobe picked by Mitsuba's probabilities, as in
    its sample; zero where the picked lobe leaves on the wrong side."""
    ci = wi[2]
    zero = ((0.0, 0.0, 1.0), (0.0, 0.0, 0.0), 0.0, False, 1.0)
    front = ci > 0
    if ci == 0 or not (front or (1.0 - P[s, PR_METALLIC]) * P[s, PR_SPEC_TRANS] > 0):
        return zero
    sg = 1.0 if front else -1.0
    ax, ay = alphas(P, s, P[s, AU])
    mx, my, mz = ggx_sample_visible1(wi[0] * sg, wi[1] * sg, ci * sg, u20, u21, ax, ay)
    dim = wi[0] * mx + wi[1] * my + wi[2] * mz
    f, cos_t, eta_it, eta_ti = fresnel1(dim, P[s, ETA])
    pd, pc, pt, _ = _probs(P, s, front, f)
    eta = 1.0
    if u1 < pd:
        wo = cosine_hemisphere3(u20, u21)
        ok = wo[2] * ci > 0
    else:
        if u1 < pd + pc:  # clearcoat: a GTR1 normal
            a2 = (0.1 + P[s, PR_CLEARCOAT_GLOSS] * (0.001 - 0.1)) ** 2
            c2 = (1.0 - a2 ** (1.0 - u21)) / (1.0 - a2)
            st, ct = math.sqrt(max(0.0, 1.0 - c2)), math.sqrt(max(0.0, c2))
            phi = 2.0 * math.pi * u20
            mx, my, mz = math.cos(phi) * st, math.sin(phi) * st, ct
            dim = wi[0] * mx + wi[1] * my + wi[2] * mz
        if u1 < pd + pc or u1 >= pd + pc + pt:  # a reflection about m
            wo = (2.0 * dim * mx - wi[0], 2.0 * dim * my - wi[1], 2.0 * dim * mz - wi[2])
            ok = wo[2] * ci > 0 and dim * sg > 0 and (wo[0] * mx + wo[1] * my + wo[2] * mz) * sg > 0
        else:  # refraction through m
            k = dim * eta_ti + cos_t
            wo = (k * mx - eta_ti * wi[0], k * my - eta_ti * wi[1], k * mz - eta_ti * wi[2])
            ok = wo[2] * ci < 0 and dim * sg > 0 and (wo[0] * mx + wo[1] * my + wo[2] * mz) * sg < 0
            eta = eta_it
    if not ok:
        return zero
    v0, v1, v2, pdf = principled_eval(P, s, wi, wo)
    if not pdf > 0:
        return zero
    return wo, (v0 / pdf, v1 / pdf, v2 / pdf), pdf, False, eta
