"""Draw a slice of the Stanford bunny's signed distance for the README: durer's winding-number sign beside
Open3D-style single-ray parity, through the holes in the bunny's base.

    python tools/sdf_slice.py      # writes docs/images/bunny_sdf_slice.png (needs ../shared/meshes)

The bunny (Stanford Computer Graphics Laboratory) is not part of this repository: it is read from
../shared/meshes. Colours: blue inside, orange outside, lighter with distance, a dark line every 5 mm of
distance and black on the surface.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from durer.query import RaycastingScene

ROOT = Path(__file__).resolve().parents[1]
MESH = ROOT.parent / "shared" / "meshes" / "bun_zipper.ply"
OUT = ROOT / "docs" / "images" / "bunny_sdf_slice.png"
SIZE = 256


def colour(sd: np.ndarray, scale: float) -> np.ndarray:
    """RGB (H, W, 3) uint8 of a signed-distance image: blue inside, orange outside, iso-lines every `scale`/4."""
    t = np.clip(np.abs(sd) / scale, 0, 1)[..., None]
    inside = np.array([40, 90, 200]) * (1 - t) + np.array([200, 220, 255]) * t
    outside = np.array([220, 110, 30]) * (1 - t) + np.array([255, 240, 215]) * t
    rgb = np.where(sd[..., None] < 0, inside, outside)
    band = np.abs(((sd / (scale / 4)) + 0.5) % 1.0 - 0.5) < 0.06
    rgb[band] *= 0.75
    rgb[np.abs(sd) < scale / 150] = 0
    return rgb.astype(np.uint8)


def main() -> int:
    if not MESH.exists():
        print(f"{MESH}: not found (the Stanford meshes live in ../shared/meshes)", file=sys.stderr)
        return 2
    scene = RaycastingScene()
    scene.add_mesh(MESH)
    lo, hi = scene._shapes[0].lo, scene._shapes[0].hi
    centre = (lo + hi) / 2
    half = 0.6 * (hi - lo)[:2].max()
    xs = np.linspace(centre[0] - half, centre[0] + half, SIZE)
    ys = np.linspace(centre[1] + half, centre[1] - half, SIZE)  # row 0 at the top
    gx, gy = np.meshgrid(xs, ys)
    z = centre[2] + 0.1 * (hi[2] - lo[2])
    pts = np.stack([gx, gy, np.full_like(gx, z)], axis=-1)
    winding = scene.compute_signed_distance(pts)
    # Open3D's rule: the parity of one ray's crossings, the ray along a fixed direction (here +x, slightly tilted)
    d = np.array([1.0, 0.05, 0.02])
    counts = scene.count_intersections(pts, np.broadcast_to(d / np.linalg.norm(d), pts.shape))
    parity = np.where(counts % 2 == 1, -np.abs(winding), np.abs(winding))
    img = Image.fromarray(np.concatenate([colour(winding, 0.02), np.full((SIZE, 4, 3), 255, np.uint8),
                                          colour(parity, 0.02)], axis=1))
    draw = ImageDraw.Draw(img)
    draw.text((6, 4), "winding number (durer default)", fill=(0, 0, 0))
    draw.text((SIZE + 10, 4), "one ray's parity (Open3D's rule)", fill=(0, 0, 0))
    OUT.parent.mkdir(parents=True, exist_ok=True)
    img.quantize(64).save(OUT, optimize=True)  # a palette keeps the README image small
    print(f"wrote {OUT} ({OUT.stat().st_size // 1024} KB), slice z = {z:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
