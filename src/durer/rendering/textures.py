"""The path tracer's texture table: every Bitmap and Checker of a scene's BSDFs packed once per render into the two
arrays kernels/path/textures.py looks them up in (TI, one row per texture; TD, all texels in one float32 array), so
that a bounce reads textures inside its Numba loop. BSDF rows name a texture by its index here."""

from __future__ import annotations

import numpy as np

from ..kernels.path.textures import (
    BILINEAR,
    BITMAP,
    CHANNELS,
    CHECKER,
    CLAMP,
    COLOR0,
    COLOR1,
    FILTER,
    HEIGHT,
    MIRROR,
    NEAREST,
    OFFSET,
    REPEAT,
    TCOLS,
    TKIND,
    TO_UV,
    WIDTH,
    WRAP,
    eval3_kernel,
)
from ..scene.textures import Bitmap, Checker

WRAPS = {"repeat": REPEAT, "mirror": MIRROR, "clamp": CLAMP}
FILTERS = {"bilinear": BILINEAR, "nearest": NEAREST}


class TextureTable:
    """Textures by index, each object once however many parameters name it."""

    def __init__(self):
        self.textures: list = []
        self._ids: dict[int, int] = {}
        self._packed: tuple[np.ndarray, np.ndarray] | None = None

    def add(self, texture: Bitmap | Checker) -> int:
        """The index of `texture` (added on first sight)."""
        key = id(texture)
        if key not in self._ids:
            self._ids[key] = len(self.textures)
            self.textures.append(texture)
            self._packed = None
        return self._ids[key]

    def packed(self) -> tuple[np.ndarray, np.ndarray]:
        """(TI (n, TCOLS) float64, TD float32): the kernels' arrays (one empty row's worth when there is none, so
        one compilation serves every scene)."""
        if self._packed is None:
            TI = np.zeros((max(len(self.textures), 1), TCOLS))
            data, offset = [np.zeros(1, np.float32)], 1
            for i, t in enumerate(self.textures):
                m = t.to_uv
                TI[i, TO_UV:TO_UV + 6] = np.concatenate([m[0], m[1]])
                if isinstance(t, Checker):
                    TI[i, TKIND] = CHECKER
                    TI[i, COLOR0:COLOR0 + 3], TI[i, COLOR1:COLOR1 + 3] = t.color0, t.color1
                    continue
                h, w, c = t.image.shape
                TI[i, [TKIND, OFFSET, WIDTH, HEIGHT, CHANNELS, WRAP, FILTER]] = (
                    BITMAP, offset, w, h, c, WRAPS[t.wrap], FILTERS[t.filter])
                data.append(t.image.reshape(-1))
                offset += t.image.size
            self._packed = TI, np.ascontiguousarray(np.concatenate(data), dtype=np.float32)
        return self._packed

    def eval3(self, index: int, uv: np.ndarray) -> np.ndarray:
        """Texture `index` at texture coordinates uv (N, 2) -> (N, 3), by the kernels' lookup."""
        uv = np.ascontiguousarray(uv, dtype=np.float64).reshape(-1, 2)
        out = np.empty((len(uv), 3))
        TI, TD = self.packed()
        eval3_kernel(TI, TD, index, uv, out)
        return out


def mean(value) -> np.ndarray:
    """A parameter's mean as an RGB triple: a constant's own value, a texture's Texture::mean (grey)."""
    if isinstance(value, (Bitmap, Checker)):
        return np.full(3, value.mean)
    return np.asarray(value, dtype=np.float64)
