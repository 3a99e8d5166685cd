"""The course's film debug images (assignment 7): -render_samples and -render_filter.

`samples_image` draws where each pixel's samples fell (Film::renderSamples), `filter_image` the reconstruction
filter's weights around one pixel (Film::renderFilter), laid out as the reference images samples7_* and filter7_*
show them; the write_* functions trace the samples and save the images.
"""

from __future__ import annotations

import numpy as np

from ..io.images import save_image
from ..options import RenderOptions
from .film import filter_weight, sample_points, support_radius
from .renderer import choose_integrator, make_context


def samples_image(points: np.ndarray, colors: np.ndarray, width: int, height: int, zoom: int) -> np.ndarray:
    """Film::renderSamples: a (H*zoom, W*zoom, 3) image; each pixel is a zoom x zoom square, grey 0.2 and black
    alternating (grey where column + row-from-the-bottom is even), with one image pixel per sample, in the
    sample's colour, at floor(film point * zoom)."""
    img = np.zeros((height * zoom, width * zoom, 3))
    col = np.arange(width * zoom) // zoom
    row_up = (height * zoom - 1 - np.arange(height * zoom)) // zoom
    even = ((row_up[:, None] + col[None, :]) % 2) == 0
    img[even] = 0.2
    x = np.clip(np.floor(points[:, 0] * zoom).astype(np.int64), 0, width * zoom - 1)
    y = np.clip(np.floor(points[:, 1] * zoom).astype(np.int64), 0, height * zoom - 1)
    img[height * zoom - 1 - y, x] = colors
    return img


def filter_image(width: int, height: int, options: RenderOptions, zoom: int) -> np.ndarray:
    """Film::renderFilter: the filter's weights around the centre pixel (width // 2, height // 2), drawn on a
    (H*zoom+1, W*zoom+1) image: blue (0,0,1) grid lines every zoom pixels, the weight as grey inside the pixels of
    the filter's support, dark blue (0,0,0.5) elsewhere. Image pixel k of a cell samples the film at k / zoom."""
    W, H = width * zoom + 1, height * zoom + 1
    x = np.arange(W) / zoom                     # film x of each image column
    y = (H - 1 - np.arange(H)) / zoom           # film y (up) of each image row
    cx, cy = width // 2 + 0.5, height // 2 + 0.5
    w = filter_weight(options, x[None, :] - cx, y[:, None] - cy)
    img = np.repeat(w[:, :, None], 3, axis=2)
    radius = support_radius(options)
    px = np.floor(x).astype(np.int64)
    py = np.floor(y).astype(np.int64)
    inside = (np.abs(py - (height // 2))[:, None] <= radius) & (np.abs(px - (width // 2))[None, :] <= radius)
    img[~inside] = (0.0, 0.0, 0.5)
    grid = (np.arange(W) % zoom == 0)[None, :] | ((H - 1 - np.arange(H)) % zoom == 0)[:, None]
    img[grid] = (0.0, 0.0, 1.0)
    return img


def write_samples_image(path: str, scene, width: int, height: int, options: RenderOptions, zoom: int) -> None:
    """Trace the render's samples (same sampler, same seed) and write the course's -render_samples image."""
    options.validate()
    ctx = make_context(scene, options)
    integrate = choose_integrator(options)
    points, _ = sample_points(width, height, options)
    origins, directions, valid = ctx.camera.generate_rays(points, width, height)
    colors = np.zeros((len(points), 3))
    idx = np.flatnonzero(valid)
    if len(idx):
        colors[idx] = integrate(ctx, origins[idx], directions[idx], ctx.camera.t_min).color
    save_image(path, samples_image(points, colors, width, height, zoom), course=True)


def write_filter_image(path: str, width: int, height: int, options: RenderOptions, zoom: int) -> None:
    """Write the course's -render_filter image (the filter's weights around the centre pixel)."""
    options.validate()
    save_image(path, filter_image(width, height, options, zoom), course=True)
