"""The light sample's BSDF value at one recorded hit, in the frame the path kernel used (durer explain).

shade_path evaluates the BSDF for next-event estimation in the hit's full shading frame: a textured slot's row
looked up at the hit's UV, a normal or bump map's perturbed frame and its side test and shadowing, an anisotropic
BSDF's tangents along dp/du. rendering/explain_path.py lists those values beside the kernel's contribution, so it
replays exactly those steps here for one hit instead of re-evaluating in a plain frame around the normal."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from .columns import COLUMNS, FLIP, TEXTURED
from .compose import bsdf_eval
from .textures import map_factor, resolve_row, shading_frame
from .warps import to_local3


@nb.njit(**JIT)
def light_sample_bsdf(P, T, tex, s, ng, ns, surf, d, ld):
    """f(wi, wo) cos(theta_o) (3,) and the BSDF's pdf of wo for slot s at a hit with geometric and shading normals
    ng, ns (3,), surf (8,) = (u, v, dp/du, dp/dv) (surface.uv_at), seen along ray direction d (3,), towards the
    light direction ld (3,): shade_path's next-event steps (texture lookup, shading_frame, bsdf_eval, map_factor)."""
    TI, TD = tex
    Q = np.empty((3, COLUMNS))
    if P[s, TEXTURED] != 0:
        resolve_row(P, s, Q, 0, TI, TD, surf[0], surf[1])
        P, s = Q, 0
    sgn = -1.0 if P[s, FLIP] != 0 else 1.0
    n0 = (ns[0] * sgn, ns[1] * sgn, ns[2] * sgn)
    (nx, ny, nz), ts, tt, bent, side_n = shading_frame(
        P, s, TI, TD, n0, (ng[0] * sgn, ng[1] * sgn, ng[2] * sgn),
        (surf[0], surf[1], surf[2], surf[3], surf[4], surf[5], surf[6], surf[7]), (-d[0], -d[1], -d[2]))
    wi = to_local3(-d[0], -d[1], -d[2], ts, tt, nx, ny, nz)
    wo = to_local3(ld[0], ld[1], ld[2], ts, tt, nx, ny, nz)
    f0, f1, f2, pdf = bsdf_eval(P, T, s, wi, wo)
    if bent:
        k = map_factor(P, s, side_n, (nx, ny, nz), (ld[0], ld[1], ld[2]))
        f0, f1, f2, pdf = f0 * k, f1 * k, f2 * k, pdf if k > 0 else 0.0
    return np.array([f0, f1, f2]), pdf
