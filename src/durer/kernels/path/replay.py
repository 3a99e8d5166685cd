"""The light sample's directions at one recorded hit, in the frame the path kernel used (durer explain).

shade_path evaluates the BSDF for next-event estimation in the hit's full shading frame: a textured slot's row
looked up at the hit's UV, a normal or bump map's perturbed frame and its side test and shadowing, an anisotropic
BSDF's tangents along dp/du. rendering/explain_path.py lists the BSDF's value beside the kernel's contribution, so
it replays those steps here for one hit (then evaluates the BSDF through rendering/bsdfs.eval_pdf, whose kernel the
renderer's other callers compile anyway) instead of evaluating in a plain frame around the normal."""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT
from .columns import COLUMNS, FLIP, TEXTURED
from .textures import map_factor, resolve_row, shading_frame
from .warps import to_local3


@nb.njit(**JIT)
def light_sample_frame(P, tex, s, ng, ns, surf, d, ld):
    """(wi, wo) local to slot s's shading frame (3,) each and the map's factor on the BSDF's value (1 without a
    normal or bump map; 0 also zeroes the pdf) at a hit with geometric and shading normals ng, ns (3,),
    surf (8,) = (u, v, dp/du, dp/dv) (surface.uv_at), seen along ray direction d (3,), for the light direction ld
    (3,): shade_path's next-event steps (texture lookup, shading_frame, map_factor) before its bsdf_eval."""
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
    k = map_factor(P, s, side_n, (nx, ny, nz), (ld[0], ld[1], ld[2])) if bent else 1.0
    return np.array([wi[0], wi[1], wi[2]]), np.array([wo[0], wo[1], wo[2]]), k
