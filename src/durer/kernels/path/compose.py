"""The path tracer's BSDF entry points over the packed table of kernels/path/bsdf.py: eval, sample and the denoiser's
albedo of any row, with the two ways Mitsuba composes BSDFs that durer keeps out of the per-kind functions: a blend
of two rows (`blendbsdf`) and a mask (`mask`: the ray passes through with probability 1 - opacity). Directions and
conventions as in kernels/path/bsdf.py."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..common import JIT
from .bsdf import leaf_albedo, leaf_eval, leaf_sample
from .columns import BLEND, CHILD0, CHILD1, COLUMNS, KIND, MAP_TWOSIDED, OPACITY, TEXTURED, TWOSIDED, WEIGHT
from .textures import resolve_row

_leaf_eval_call = nb.njit(**JIT)(leaf_eval.py_func)  # a blend's children: called, not inlined (compile time)


@nb.njit(**JIT)
def _blend_eval(P, T, s, wi, wo):
    """Mitsuba's blendbsdf: (1 - weight) CHILD0 + weight CHILD1, values and pdfs alike."""
    w = P[s, WEIGHT]
    a0, a1, a2, pa = _leaf_eval_call(P, T, int(P[s, CHILD0]), wi, wo)
    b0, b1, b2, pb = _leaf_eval_call(P, T, int(P[s, CHILD1]), wi, wo)
    return ((1.0 - w) * a0 + w * b0, (1.0 - w) * a1 + w * b1, (1.0 - w) * a2 + w * b2, (1.0 - w) * pa + w * pb)


@nb.njit(**JIT, inline="always")
def bsdf_eval(P, T, s, wi, wo):
    """f(wi, wo) cos(theta_o) (three channels) and the pdf with which bsdf_sample picks wo (delta lobes
    excluded), for slot s; a masked row's both times its opacity, as Mitsuba's mask."""
    if P[s, KIND] == BLEND:
        if P[s, TWOSIDED] != 0 and wi[2] < 0:
            wi = (wi[0], wi[1], -wi[2])
            wo = (wo[0], wo[1], -wo[2])
        v0, v1, v2, pdf = _blend_eval(P, T, s, wi, wo)
    else:
        v0, v1, v2, pdf = leaf_eval(P, T, s, wi, wo)
    op = P[s, OPACITY]
    if op != 1.0:
        return v0 * op, v1 * op, v2 * op, pdf * op
    return v0, v1, v2, pdf


_leaf_sample_call = nb.njit(**JIT)(leaf_sample.py_func)


@nb.njit(**JIT)
def _blend_sample(P, T, s, wi, u1, u20, u21):
    """Mitsuba's blendbsdf: CHILD1 sampled with probability weight (else CHILD0, u1 rescaled), then the mixture at
    the sampled direction: pdf = w_k pdf_k + w_other pdf_other(wo) and weight = (w_k f_k + w_other f_other(wo)) / pdf,
    where a delta lobe's f_k is its weight times its pick probability (Mitsuba 3.9's sample, measured)."""
    w = P[s, WEIGHT]
    if u1 <= w:
        k, other, wk = int(P[s, CHILD1]), int(P[s, CHILD0]), w
        u1 = u1 / w if w > 0 else 0.0
    else:
        k, other, wk = int(P[s, CHILD0]), int(P[s, CHILD1]), 1.0 - w
        u1 = (u1 - w) / (1.0 - w)
    wo, bw, pdf, delta, eta = _leaf_sample_call(P, T, k, wi, u1, u20, u21)
    o0, o1, o2, po = _leaf_eval_call(P, T, other, wi, wo)
    den = wk * pdf + (1.0 - wk) * po
    if not den > 0:
        return wo, (0.0, 0.0, 0.0), 0.0, delta, eta
    m = 1.0 / den
    return (wo, ((wk * bw[0] * pdf + (1.0 - wk) * o0) * m, (wk * bw[1] * pdf + (1.0 - wk) * o1) * m,
                 (wk * bw[2] * pdf + (1.0 - wk) * o2) * m), den, delta, eta)


@nb.njit(**JIT, inline="always")
def bsdf_sample(P, T, s, wi, u1, u20, u21):
    """Sample wo for slot s from wi: (wo, weight = f cos / pdf (0 where nothing was sampled or not finite), pdf,
    delta (a specular lobe was picked), eta (relative index crossed, 1 for reflection)). A masked row lets the ray
    through (wo = -wi, weight 1, a delta lobe of probability 1 - opacity) or samples its BSDF with pdf times the
    opacity, as Mitsuba's mask. Inlined, as bsdf_eval."""
    op = P[s, OPACITY]
    if op != 1.0:
        if not u1 < op:
            return (-wi[0], -wi[1], -wi[2]), (1.0, 1.0, 1.0), 1.0 - op, True, 1.0
        u1 = u1 / op
    if P[s, KIND] == BLEND:
        flip = P[s, TWOSIDED] != 0 and wi[2] < 0
        if flip:
            wi = (wi[0], wi[1], -wi[2])
        wo, w, pdf, delta, eta = _blend_sample(P, T, s, wi, u1, u20, u21)
        if flip:
            wo = (wo[0], wo[1], -wo[2])
    else:
        wo, w, pdf, delta, eta = leaf_sample(P, T, s, wi, u1, u20, u21)
    if not (math.isfinite(w[0]) and math.isfinite(w[1]) and math.isfinite(w[2])):
        w = (0.0, 0.0, 0.0)
    return wo, w, pdf * op, delta, eta


@nb.njit(**JIT, inline="always")
def _row(P, s, Q, tex, u, v):
    """(table, row) to read slot s from: P's own row, or its textures resolved at (u, v) into Q[0..2]."""
    if P[s, TEXTURED] != 0:
        resolve_row(P, s, Q, 0, tex[0], tex[1], u, v)
        return Q, 0
    return P, s


@nb.njit(**JIT)
def eval_kernel(P, T, tex, slot, uv, wi, wo, value, pdf):
    """bsdf_eval for every row, textures looked up at uv (n, 2) (NumPy arrays in, outputs written in place)."""
    Q = np.empty((3, COLUMNS))
    for i in range(slot.shape[0]):
        R, r = _row(P, slot[i], Q, tex, uv[i, 0], uv[i, 1])
        value[i, 0], value[i, 1], value[i, 2], pdf[i] = bsdf_eval(R, T, r, (wi[i, 0], wi[i, 1], wi[i, 2]),
                                                                 (wo[i, 0], wo[i, 1], wo[i, 2]))


@nb.njit(**JIT)
def sample_kernel(P, T, tex, slot, uv, wi, u1, u2, wo, weight, pdf, delta, eta):
    """bsdf_sample for every row, textures looked up at uv (NumPy arrays in, outputs written in place)."""
    Q = np.empty((3, COLUMNS))
    for i in range(slot.shape[0]):
        R, r = _row(P, slot[i], Q, tex, uv[i, 0], uv[i, 1])
        o, w, pdf[i], delta[i], eta[i] = bsdf_sample(R, T, r, (wi[i, 0], wi[i, 1], wi[i, 2]), u1[i],
                                                     u2[i, 0], u2[i, 1])
        wo[i, 0], wo[i, 1], wo[i, 2] = o
        weight[i, 0], weight[i, 1], weight[i, 2] = w


@nb.njit(**JIT)
def bsdf_albedo(P, s, wiz):
    """The reflectance of slot s seen from a direction of local cos(theta) wiz, as the denoiser's albedo feature
    (rendering/path.py): leaf_albedo's, a blend's mix of its two rows', times the opacity of a masked row."""
    if P[s, MAP_TWOSIDED] != 0:
        wiz = abs(wiz)
    if P[s, KIND] == BLEND:
        if P[s, TWOSIDED] != 0:
            wiz = abs(wiz)
        w = P[s, WEIGHT]
        a0, a1, a2 = leaf_albedo(P, int(P[s, CHILD0]), wiz)
        b0, b1, b2 = leaf_albedo(P, int(P[s, CHILD1]), wiz)
        v0, v1, v2 = (1.0 - w) * a0 + w * b0, (1.0 - w) * a1 + w * b1, (1.0 - w) * a2 + w * b2
    else:
        v0, v1, v2 = leaf_albedo(P, s, wiz)
    op = P[s, OPACITY]
    return v0 * op, v1 * op, v2 * op


