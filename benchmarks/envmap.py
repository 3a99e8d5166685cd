"""Time per sample of a path-traced scene lit by an environment map, and of the same scene under a constant
environment of the map's mean radiance (the reference cost of escaping rays and of light sampling).

The scene (written to a temporary folder as Mitsuba XML, read by durer.load): a diffuse floor, a diffuse, a rough
copper and a glass sphere, under `--map` (default: mitsuba-data's museum.exr from ../shared/scenes, else a
generated 256 x 128 sky with a small sun), max_depth 8. Each variant renders once untimed (compiles, builds the
tables), then `--repeat` times; prints the median wall and process CPU seconds per sample per pixel and the image
mean (a checksum: two versions of durer give the same figure when their estimators agree). To compare versions of
durer, run it alternately under each one's PYTHONPATH on a busy machine.

    PYTHONPATH=src python benchmarks/envmap.py [--res 128] [--spp 8] [--repeat 3] [--map sky.exr] [--only envmap]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import durer

ROOT = Path(__file__).resolve().parents[1]
MUSEUM = ROOT.parent.parent / "shared" / "scenes" / "mitsuba" / "mitsuba-data" / "common" / "textures" / "museum.exr"

SCENE = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="8"/></integrator>
  <sensor type="perspective"><float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="0, 2, 6" target="0, 0.6, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="128"/><integer name="height" value="128"/>
      <rfilter type="box"/></film></sensor>
  {light}
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="4"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="-1.6" y="0.7" z="0"/><float name="radius" value="0.7"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.3"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0" y="0.7" z="0"/><float name="radius" value="0.7"/>
    <bsdf type="roughconductor"><string name="material" value="Cu"/><string name="distribution" value="ggx"/>
      <float name="alpha" value="0.2"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="1.6" y="0.7" z="0"/><float name="radius" value="0.7"/>
    <bsdf type="dielectric"/></shape>
</scene>
"""


def sky(path: Path) -> None:
    """A 256 x 128 sky with a small bright sun, as .npy (durer reads it as an envmap file)."""
    h, w = 128, 256
    v, u = (np.arange(h)[:, None] + 0.5) / h, (np.arange(w)[None, :] + 0.5) / w
    img = np.zeros((h, w, 3), np.float32)
    img[..., 0], img[..., 1], img[..., 2] = 0.3 + 0.5 * u, 0.4 * (1 - v), 0.8 * (1 - v) + 0.1
    img[20:24, 160:164] = [400, 350, 300]
    np.save(path, img)


def scenes(folder: Path, env_map: Path) -> dict[str, durer.Scene]:
    """The scene under the map and under a constant emitter of the map's mean radiance."""
    envmap = f'<emitter type="envmap"><string name="filename" value="{env_map}"/></emitter>'
    (folder / "envmap.xml").write_text(SCENE.format(light=envmap))
    lit = durer.load(folder / "envmap.xml")
    img = lit.environment.image
    theta = (np.arange(img.shape[0]) + 0.5) / img.shape[0] * np.pi
    mean = (img * np.sin(theta)[:, None, None]).sum(axis=(0, 1)) / (np.sin(theta).sum() * img.shape[1])
    rgb = ", ".join(f"{c:.6g}" for c in mean)
    constant = f'<emitter type="constant"><rgb name="radiance" value="{rgb}"/></emitter>'
    (folder / "constant.xml").write_text(SCENE.format(light=constant))
    return {"envmap": lit, "constant": durer.load(folder / "constant.xml")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--map", type=Path, default=None, help="an .exr, .pfm or .npy latitude-longitude map")
    ap.add_argument("--only", choices=("envmap", "constant"), default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        env_map = args.map or (MUSEUM if MUSEUM.is_file() else None)
        if env_map is None:
            env_map = folder / "sky.npy"
            sky(env_map)
        print(f"durer {durer.__file__}, map {env_map}, {args.res}x{args.res}, {args.spp} spp, "
              f"load {os.getloadavg()[0]:.2f}")
        for name, scene in scenes(folder, Path(env_map).resolve()).items():
            if args.only and name != args.only:
                continue
            durer.render(scene, args.res, args.res, samples=1)
            wall, cpu = [], []
            for _ in range(args.repeat):
                t, c = time.perf_counter(), time.process_time()
                img = durer.render(scene, args.res, args.res, samples=args.spp).color
                wall.append((time.perf_counter() - t) / args.spp)
                cpu.append((time.process_time() - c) / args.spp)
            print(f"{name:8s} s/spp wall {np.median(wall):.4f} cpu {np.median(cpu):.4f}  "
                  f"mean {img.mean(axis=(0, 1)).round(5)}")


if __name__ == "__main__":
    main()
