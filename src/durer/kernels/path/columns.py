"""The layout of the path tracer's packed BSDF table (rendering/bsdfs.py builds it, kernels/path/bsdf.py,
kernels/path/principled.py and kernels/path/textures.py read it): one float64 row per material slot, the kinds of
BSDF and the column of each parameter. Its own module so that every kernel module can read the layout without
importing another's functions."""

from __future__ import annotations

DIFFUSE, DIELECTRIC, CONDUCTOR, ROUGHCONDUCTOR, PLASTIC, ROUGHPLASTIC, PHONG, BLACK, ROUGHDIELECTRIC = range(9)
BLEND = 9  # Mitsuba's blendbsdf: (1 - weight) CHILD0 + weight CHILD1
THINDIELECTRIC = 10
PRINCIPLED = 11  # Mitsuba's principled (Disney): base colour C1, roughness AU, eta ETA, the rest in PR_* below
PRINCIPLEDTHIN = 12  # Mitsuba's principledthin: the same columns, with flatness, diff_trans and their rates
# columns of the packed table: kind, flags, four colours (3 each), scalars, emission
KIND, TWOSIDED, C1, C2, C3, C4, ETA, AU, AV, EXPONENT, SPEC_WEIGHT, FDR_INT, NONLINEAR, FLIP, EMISSION, SMOOTH = (
    0, 1, 2, 5, 8, 11, 14, 15, 16, 17, 18, 19, 20, 21, 22, 25)
BECKMANN = 26  # rough BSDFs: 1 for Beckmann microfacets, 0 for GGX
# TROW: the row of the rough plastic's transmittance table (the slot's own; a resolved scratch row keeps it); OPACITY
# (1: opaque), a blend's WEIGHT and two child rows; TEXTURED: the row (or a blend's child) names a texture or a
# normal or bump map; TEX_*: texture ids (-1 none) of C1, C2, AU, AV, OPACITY, WEIGHT, EMISSION, the normal map and
# the bump map (scaled by BUMP_SCALE); a normal or bump map's two options (1: on): MAP_FLIP (Mitsuba's
# flip_invalid_normals) and MAP_SHADOW (use_shadowing_function); MAP_TWOSIDED: a `twosided` around the map (seen from
# behind, the map's frame is mirrored, textures.shading_frame; TWOSIDED is the flag of a `twosided` inside it)
TROW, OPACITY, WEIGHT, CHILD0, CHILD1, TEXTURED = 27, 28, 29, 30, 31, 32
TEX_C1, TEX_C2, TEX_AU, TEX_AV, TEX_OPACITY, TEX_WEIGHT, TEX_EMISSION, TEX_NORMAL, TEX_BUMP, BUMP_SCALE = range(33, 43)
MAP_FLIP, MAP_SHADOW, MAP_TWOSIDED = 43, 44, 45
# the principled BSDFs' constant parameters (Mitsuba's names; principledthin's specular reflection rate is named
# specular_reflectance_sampling_rate) and their lobe sampling rates
PRINCIPLED_PARAMS = ("anisotropic", "metallic", "spec_trans", "spec_tint", "sheen", "sheen_tint", "clearcoat",
                     "clearcoat_gloss", "main_specular_sampling_rate", "clearcoat_sampling_rate",
                     "diffuse_reflectance_sampling_rate", "flatness", "diff_trans",
                     "specular_transmittance_sampling_rate", "diffuse_transmittance_sampling_rate")
(PR_ANISO, PR_METALLIC, PR_SPEC_TRANS, PR_SPEC_TINT, PR_SHEEN, PR_SHEEN_TINT, PR_CLEARCOAT, PR_CLEARCOAT_GLOSS,
 PR_RATE_SPEC, PR_RATE_CLEARCOAT, PR_RATE_DIFFUSE, PR_FLATNESS, PR_DIFF_TRANS, PR_RATE_SPEC_TRANS,
 PR_RATE_DIFF_TRANS) = range(46, 61)
# numbers read from textures (Mitsuba's eval_1) into any column, for parameters without a TEX_* column of their own (the
# principled BSDFs' PR_* and principledthin's ETA): NUMBER_PAIRS pairs (column, texture id) from TEX_NUMBERS, the used
# ones first, the rest (-1, -1)
TEX_NUMBERS, NUMBER_PAIRS = 61, 8
COLUMNS = 77
