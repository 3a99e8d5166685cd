"""RenderResult: the arrays of one render (colour, depth, normals and any per-sample outputs filtered like colour),
with the ways to look at them and write them."""

from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from ..accel.stats import RayStats
from ..io.images import depth_visualization, encode_srgb, normal_visualization, save_image


@dataclass
class RenderResult:
    """The arrays of one render, each (H, W, ...), row 0 at the top.

    color: float32 (H,W,3) linear radiance; depth: float32 (H,W) ray parameter t of the closest hit (inf on a miss);
    normals: float32 (H,W,3) unit world-space normals of the closest hit (0 on a miss). With several samples per
    pixel, depth and normals are those of the sample nearest the pixel's centre.
    With options.hit_aovs, that same sample's first hit as Mitsuba's aov integrator's `position` and `uv`:
    position float32 (H,W,3) world-space point and uv float32 (H,W,2) surface UV (rendering/hit_aovs.py), 0 on a
    miss; else None. Unlike Mitsuba's aov, which filters them with the film's filter, they are not filtered.
    With options.aovs or options.denoise, the denoiser's features, filtered like the colour: albedo (H,W,3), the
    reflectance of each sample's first non-specular hit (seen through mirrors and glass, tinted by them; 0 where the
    ray escapes), and shading_normals (H,W,3), that hit's shading normal, a normal or bump map's included (not unit
    after filtering); from the path tracer also emission and environment (H,W,3), the part of the colour that is
    light seen directly or through mirrors and glass, from surface emitters and from the environment (the denoiser's
    split); else None. With options.denoise, color is OIDN's output and denoise_seconds its time (included in
    seconds); the other outputs are then filtered by a one-pixel box, the emission and the colour by the scene's
    filter (rendering/denoise.py).
    """

    color: np.ndarray
    depth: np.ndarray
    normals: np.ndarray
    seconds: float = 0.0
    stats: RayStats | None = None  # -stats counters (None unless options.stats)
    # per-sample outputs of the integrator beyond colour (SampleResult's extra (N,k) fields, e.g. albedo), each
    # filtered with the colour's weights into a float32 (H,W,k) image
    aovs: dict[str, np.ndarray] = field(default_factory=dict)
    denoise_seconds: float = 0.0
    position: np.ndarray | None = None
    uv: np.ndarray | None = None

    @property
    def alpha(self) -> np.ndarray | None:
        """Coverage (H,W), with options.alpha: the filter-weighted share of samples whose camera ray hit something."""
        a = self.aovs.get("alpha")
        return None if a is None else a[..., 0]

    @property
    def rgba(self) -> np.ndarray:
        """Colour and coverage (H,W,4) (alpha 1 without options.alpha), as Mitsuba's rgba films."""
        alpha = self.alpha if self.alpha is not None else np.ones(self.color.shape[:2], np.float32)
        return np.concatenate([self.color, alpha[..., None]], axis=-1)

    @property
    def shading_normals(self) -> np.ndarray | None:
        """The filtered shading normal of the first non-specular hit (H,W,3), with the denoiser's features."""
        return self.aovs.get("shading_normal")

    @property
    def albedo(self) -> np.ndarray | None:
        """The filtered albedo (H,W,3), when the integrator reports one (else None)."""
        return self.aovs.get("albedo")

    @property
    def emission(self) -> np.ndarray | None:
        """The filtered emission of surface emitters seen directly or through mirrors and glass (H,W,3), a part of
        the colour, when the integrator reports it (the path tracer with the features; else None)."""
        return self.aovs.get("emission")

    @property
    def environment(self) -> np.ndarray | None:
        """As emission, the environment's (H,W,3)."""
        return self.aovs.get("environment")

    def __repr__(self) -> str:
        h, w = self.depth.shape
        hit = int(np.isfinite(self.depth).sum())
        return (f"<RenderResult {w}x{h}: {hit} of {w * h} pixels hit, colour up to {float(self.color.max()):.3g} "
                f"(linear), {self.seconds:.2f} s>")

    def to_srgb8(self) -> np.ndarray:
        """The colour as an sRGB-encoded uint8 (H, W, 3) array, as `save` writes it and as image viewers and
        `plt.imshow` expect (`color` itself is linear radiance, which looks too dark shown directly)."""
        return encode_srgb(self.color)

    def _repr_png_(self) -> bytes:
        """PNG bytes of `to_srgb8()`: Jupyter shows a RenderResult as its image."""
        import io

        from PIL import Image

        buffer = io.BytesIO()
        Image.fromarray(self.to_srgb8(), mode="RGB").save(buffer, format="PNG")
        return buffer.getvalue()

    def save(self, path: str | os.PathLike, *, course: bool = False) -> None:
        """Write the colour image (8-bit formats sRGB-encoded, or truncated like the course with course=True)."""
        save_image(os.fspath(path), self.color, course=course)

    def save_depth(self, path: str | os.PathLike, near: float | None = None, far: float | None = None) -> None:
        """Write depth: raw t for .npy/.pfm, else grey with near = white and far = black (default: the hit range)."""
        path = os.fspath(path)
        if path.lower().endswith((".npy", ".pfm")):
            save_image(path, self.depth)
            return
        finite = self.depth[np.isfinite(self.depth)]
        if near is None:
            near = float(finite.min()) if finite.size else 0.0
        if far is None:
            far = float(finite.max()) if finite.size else 1.0
        if far == near:
            far = near + 1.0
        save_image(path, depth_visualization(self.depth, near, far), course=True)

    def save_normals(self, path: str | os.PathLike) -> None:
        """Write normals: raw for .npy/.pfm, else |n| per channel."""
        path = os.fspath(path)
        if path.lower().endswith((".npy", ".pfm")):
            save_image(path, self.normals)
            return
        save_image(path, normal_visualization(self.normals), course=True)
