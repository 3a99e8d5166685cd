"""Render outputs beside the image (`durer render --aov albedo,normals,depth,position,uv`, issue 24): one
multi-layer OpenEXR file when the image is `.exr`, else one file per output named after the image (`out.png` ->
`out.albedo.png`).

Layers in the EXR: the colour as R, G, B; albedo as albedo.R/G/B; normals as normals.X/Y/Z; depth as depth.Z
(inf where the ray escaped); position as position.X/Y/Z (world space) and uv as uv.U/V (0 where the ray escaped),
all float32. Separate 8-bit files show albedo as a colour (sRGB-encoded), normals as |n| per channel and depth as
grey over the hit range (near white), as `--normals` and `--depth` write them, position with each axis scaled
over the image's range (its minimum black, its maximum full), and uv as red = u and green = v (clamped to
[0, 1], linear); `.npy`, `.pfm`, `.hdr` and `.exr` files keep the raw values (uv as (u, v, 0) except in .npy).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import UsageError
from .images import RAW, check_extension, depth_visualization, normal_visualization, save_image, write_exr_channels

AOVS = ("albedo", "normals", "depth", "position", "uv")
CHANNELS = {"albedo": "RGB", "normals": "XYZ", "depth": "Z", "position": "XYZ", "uv": "UV"}


def parse_aovs(text: str) -> tuple[str, ...]:
    """'albedo,normals' -> ('albedo', 'normals'); a UsageError names an unknown output."""
    names = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
    unknown = [n for n in names if n not in AOVS]
    if unknown or not names:
        raise UsageError(f"--aov: unknown output {', '.join(unknown) or repr(text)} (use a comma-separated list of "
                         f"{', '.join(AOVS)})")
    return names


def aov_path(image: str, name: str) -> str:
    """The file an output goes to when the image is not .exr: beside it, named after it."""
    stem, ext = os.path.splitext(image)
    return f"{stem}.{name}{ext}"


def aov_files(image: str, names: tuple[str, ...]) -> list[str]:
    """Every file the outputs will write besides the image (none for .exr: they are layers of the image)."""
    return [] if check_extension(image) == ".exr" else [aov_path(image, n) for n in names]


def save_with_aovs(image: str, color: np.ndarray, layers: dict[str, np.ndarray], *, course: bool = False) -> None:
    """Write the colour image and its outputs (name -> (H,W,3) or (H,W) array, names from AOVS): as layers of one
    EXR, or as the image plus one file each."""
    if check_extension(image) == ".exr":
        _write_layers_exr(image, color, layers)
        return
    save_image(image, color, course=course)
    for name, values in layers.items():
        save_aov(aov_path(image, name), name, values)


def save_aov(path: str, name: str, values: np.ndarray) -> None:
    """One output in its own file: raw for .npy/.pfm/.hdr/.exr, else visualised (module docstring)."""
    ext = check_extension(path)
    if name == "uv" and ext != ".npy":  # image formats hold one or three channels
        values = np.concatenate([values, np.zeros(values.shape[:2] + (1,), values.dtype)], axis=-1)
    if ext in RAW:
        save_image(path, values)
    elif name == "uv":
        save_image(path, np.clip(values, 0.0, 1.0), course=True)
    elif name == "position":
        lo, hi = values.min(axis=(0, 1)), values.max(axis=(0, 1))
        save_image(path, (values - lo) / np.where(hi > lo, hi - lo, 1.0), course=True)
    elif name == "albedo":
        save_image(path, values)
    elif name == "normals":
        save_image(path, normal_visualization(values), course=True)
    else:
        finite = values[np.isfinite(values)]
        near, far = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        save_image(path, depth_visualization(values, near, far if far > near else near + 1.0), course=True)


def _write_layers_exr(path: str, color: np.ndarray, layers: dict[str, np.ndarray]) -> None:
    """Float32 multi-layer OpenEXR (ZIP): R, G, B and each layer's `name.channel`, written beside and renamed."""
    channels = {c: np.ascontiguousarray(color[..., i], dtype=np.float32) for i, c in enumerate("RGB")}
    for name, values in layers.items():
        values = np.asarray(values, dtype=np.float32)
        for i, c in enumerate(CHANNELS[name]):
            channels[f"{name}.{c}"] = np.ascontiguousarray(values if values.ndim == 2 else values[..., i])
    write_exr_channels(path, channels)
