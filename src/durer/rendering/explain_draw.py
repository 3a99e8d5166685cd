"""Draw a pixel's ray tree over the rendered image, as the course's ray-tree view did: every ray's segment
projected through the camera (cameras' `project`), coloured by its kind."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from ..io.images import encode_srgb
from .explain import PixelTree, walk

COLORS = {  # the course's ray-tree colours: camera rays grey-white, shadow green, reflection red, refraction blue
    "camera": (255, 255, 255),
    "shadow": (40, 220, 40),
    "blocked": (20, 90, 20),
    "reflection": (255, 50, 50),
    "refraction": (60, 140, 255),
    "bounce": (255, 160, 40),  # the path tracer's BSDF-sampled rays
}
STEPS = 64  # points per segment: straight in a pinhole or orthographic image, curved in a fisheye or panorama


def segments(tree: PixelTree, camera) -> list[tuple[str, list[list[tuple[float, float]]]]]:
    """(colour key, polylines in image pixels (x right, y down)) for every ray of the tree. Each segment is
    sampled at STEPS points and projected; points the camera cannot see split it into several polylines."""
    width, height = tree.size
    out = []
    for node in walk(tree.rays):
        if node.get("no_ray"):
            continue
        a, b = np.asarray(node["origin"]), np.asarray(node["end"])
        s = np.linspace(0.0, 1.0, STEPS)[:, None]
        film, seen = camera.project(a + s * (b - a), width, height)
        xy = np.stack([film[:, 0], height - film[:, 1]], axis=-1)
        lines, current = [], []
        for p, ok, prev in zip(xy, seen, np.vstack([xy[:1], xy[:-1]]), strict=True):
            jump = np.abs(p - prev).max() > 0.5 * max(width, height)  # a panorama wrapping round
            if not ok or jump:
                if len(current) > 1:
                    lines.append(current)
                current = []
            if ok:
                current.append((float(p[0]), float(p[1])))
        if len(current) > 1:
            lines.append(current)
        key = "blocked" if node["kind"] == "shadow" and node.get("blocked") else node["kind"]
        out.append((key, lines))
    return out


def draw_tree(tree: PixelTree, color: np.ndarray, camera, min_size: int = 512) -> Image.Image:
    """The linear image `color` (H,W,3), sRGB-encoded, enlarged (nearest) to at least min_size on its longer side,
    with the tree's rays drawn over it and the explained pixel outlined."""
    height, width = color.shape[:2]
    scale = max(1, int(np.ceil(min_size / max(width, height))))
    image = Image.fromarray(encode_srgb(color)).resize((width * scale, height * scale), Image.NEAREST)
    draw = ImageDraw.Draw(image)
    limit = 10.0 * max(width, height)  # keep far-off points of a segment within what Pillow draws safely
    for key, lines in segments(tree, camera):
        for line in lines:
            pts = [(float(np.clip(x, -limit, limit)) * scale, float(np.clip(y, -limit, limit)) * scale)
                   for x, y in line]
            draw.line(pts, fill=COLORS[key], width=max(1, scale // 3))
    for node in walk(tree.rays):
        if node["hit"] is not None and node["kind"] != "shadow":
            film, seen = camera.project(np.asarray(node["hit"]["point"])[None], width, height)
            if seen[0]:
                x, y = film[0, 0] * scale, (height - film[0, 1]) * scale
                r = max(2, scale // 2)
                draw.ellipse([x - r, y - r, x + r, y + r], outline=COLORS[node["kind"]])
    px, py = tree.pixel
    draw.rectangle([px * scale, py * scale, (px + 1) * scale - 1, (py + 1) * scale - 1], outline=(255, 255, 0))
    return image
