"""Compile every kernel once, so that later renders and queries load machine code from Numba's on-disk cache.

Numba compiles a kernel for each set of argument types on its first call and caches the result beside the module
(`__pycache__`), keyed by the source file's content, the CPU and the Numba version. A first render would otherwise
spend most of its time compiling (12 s for the ray caster, 30 s more for the path tracer on a 2-core machine).
`pip install .` runs this module while it builds the wheel (setup.py), so the installed package carries the
cache for the machine it was built on; `durer warmup` runs it by hand, e.g. after an editable install or when
building a container image. Each group below drives the public API on tiny inputs chosen to reach every kernel
and every argument type that real work reaches (float32 and float64 rays, flat and image-shaped, one- and
two-level trees, float32 leaves, each integrator and accelerator).

`python -m durer.warmup [GROUP ...]` runs the groups in this process; `warm_up()` runs them in parallel processes
(Numba compiles on one core per process).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np


def _course_scene():
    """A course-style scene touching every shape, texture and light kind, with a mesh placed twice (instances)."""
    import durer
    from durer.scene import transforms as tf

    cube_v = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)], float)
    cube_f = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                       [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    cube = durer.TriangleMesh(cube_v, cube_f, material=1)
    phong = [durer.PhongMaterial(diffuse_color=(0.8, 0.2, 0.1), specular_color=(1, 1, 1), exponent=20,
                                 reflective_color=(0.3, 0.3, 0.3)),
             durer.PhongMaterial(diffuse_color=(0.2, 0.7, 0.2), transparent_color=(0.5, 0.5, 0.5),
                                 index_of_refraction=1.5)]
    textures = [durer.Checkerboard(0, 1), durer.Noise(0, 1, octaves=3), durer.Marble(0, 1, octaves=3),
                durer.Wood(0, 1, octaves=3)]
    group = durer.Group([
        durer.Sphere((0, 0, 0), 1, material=0),
        durer.Plane((0, 1, 0), -1, material=2),
        durer.Triangle((-2, -1, -2), (2, -1, -2), (0, 2, -2), material=3),
        durer.Transform(tf.scale((1, 0.5, 1)) @ tf.translate((2, 0, 0)), durer.Sphere((0, 0, 0), 0.5, material=4)),
        durer.Transform(tf.translate((-2, 0, 0)), cube),
        durer.Transform(tf.translate((-2, 1.5, 0)), cube),
        durer.Transform(tf.translate((0, 0, 2)), durer.Sphere((0, 0, 0), 0.3, material=5)),
    ])
    return durer.Scene(
        camera=durer.PerspectiveCamera(center=(0, 1, 8), direction=(0, -0.1, -1), up=(0, 1, 0), angle=40),
        group=group, materials=phong + textures,
        lights=[durer.PointLight(position=(3, 5, 5), color=(1, 1, 1)),
                durer.DirectionalLight(direction=(-1, -1, -1), color=(0.5, 0.5, 0.5))],
    )


def course() -> None:
    """The ray caster and the Whitted tracer, on the BVH (one- and two-level), brute force and the grid."""
    import durer

    scene = _course_scene()
    durer.render(scene, 16, 16)
    durer.render(scene, 16, 16, shadows=True, bounces=2, samples=4, sampler="jittered", filter="tent")
    durer.render(scene, 8, 8, samples=4, sampler="random", filter="gaussian", filter_radius=0.4, shade_back=True)
    durer.render(scene, 8, 8, accel="brute", shadows=True)
    durer.render(scene, 8, 8, grid=(4, 4, 4), shadows=True, stats=True)
    durer.render(scene, 8, 8, grid=(4, 4, 4), visualize_grid=True)
    durer.render(scene, 8, 8, course_edges=True, course_random=True, samples=4, sampler="jittered")


_CORNELL = {
    "type": "scene",
    "integrator": {"type": "path", "max_depth": 6},
    "sensor": {"type": "perspective", "fov": 40, "to_world": None,
               "film": {"type": "hdrfilm", "width": 8, "height": 8}},
    "white": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}},
    "glass": {"type": "dielectric"},
    "metal": {"type": "roughconductor", "alpha": 0.2, "distribution": "ggx"},
    "mirror": {"type": "conductor"},
    "plastic": {"type": "roughplastic", "distribution": "ggx"},
    "light": {"type": "rectangle", "to_world": None, "emitter": {"type": "area", "radiance": 10}},
    "floor": {"type": "rectangle", "to_world": None, "bsdf": {"type": "ref", "id": "white"}},
    "ball": {"type": "sphere", "center": [0.3, -0.6, 0], "radius": 0.3, "bsdf": {"type": "ref", "id": "glass"}},
    "ball2": {"type": "sphere", "center": [-0.3, -0.6, 0], "radius": 0.3, "bsdf": {"type": "ref", "id": "metal"}},
    "box": {"type": "cube", "to_world": None, "bsdf": {"type": "ref", "id": "plastic"}},
    "box2": {"type": "cube", "to_world": None, "bsdf": {"type": "ref", "id": "mirror"}},
}


def _cornell(**extra):
    """The path tracer's test scene as a Mitsuba dict (transforms filled in here, where durer is importable)."""
    import durer
    from durer.io.mitsuba import look_at
    from durer.scene import transforms as tf

    d = {k: dict(v) if isinstance(v, dict) else v for k, v in _CORNELL.items()}
    d["sensor"] = dict(d["sensor"], to_world=look_at(np.array([0, 0, 3.9]), np.zeros(3), np.array([0.0, 1, 0])))
    d["light"] = dict(d["light"], to_world=tf.translate((0, 0.99, 0)) @ tf.x_rotate(90) @ tf.scale((0.3, 0.3, 1)))
    d["floor"] = dict(d["floor"], to_world=tf.translate((0, -1, 0)) @ tf.x_rotate(-90))
    d["box"] = dict(d["box"], to_world=tf.translate((0.5, 0, -0.5)) @ tf.scale((0.2, 0.2, 0.2)))
    d["box2"] = dict(d["box2"], to_world=tf.translate((-0.5, 0, -0.5)) @ tf.scale((0.2, 0.2, 0.2)))
    d.update(extra)
    return durer.load_dict(d)


def path() -> None:
    """The path tracer: the fused bounce kernel, and the unfused wavefront (taken with a constant environment)."""
    import durer

    durer.render(_cornell(), 8, 8, integrator="path", samples=2)
    durer.render(_cornell(sky={"type": "constant", "radiance": 0.5}), 8, 8, integrator="path", samples=2)


def _rays(n: int, rng: np.random.Generator, dtype) -> np.ndarray:
    o = rng.uniform(-2, 2, (n, 3))
    d = rng.normal(size=(n, 3))
    return np.concatenate([o, d / np.linalg.norm(d, axis=1, keepdims=True)], axis=1).astype(dtype)


def queries() -> None:
    """RaycastingScene's ray queries: float32 and float64 rays, flat and as images, on a small mesh and a sphere
    (float64 leaves), a large float32 mesh (float32 leaves), and a mesh placed twice (the two-level kernels)."""
    import trimesh

    import durer

    rng = np.random.default_rng(0)
    big = trimesh.creation.icosphere(subdivisions=6)  # 81,920 triangles: a tree large enough for float32 leaves
    small = trimesh.creation.box()
    one = durer.RaycastingScene()
    one.add_triangles(small.vertices, small.faces)
    one.add_sphere((0, 2, 0), 0.5)
    large = durer.RaycastingScene()
    large.add_triangles(big.vertices.astype(np.float32), big.faces.astype(np.uint32))
    two = durer.RaycastingScene()
    g = two.add_triangles(small.vertices, small.faces)
    two.add_instance(g, np.eye(4))
    moved = np.eye(4)
    moved[:3, 3] = (3, 0, 0)
    two.add_instance(g, moved)
    for scene in (one, large, two):
        for dtype in (np.float32, np.float64):
            flat = _rays(64, rng, dtype)
            image = durer.RaycastingScene.create_rays_pinhole(60, (0, 0, 0), (0, 0, 5), (0, 1, 0), 8, 8)
            image = image.astype(dtype)
            for rays in (flat, image):
                scene.cast_rays(rays)
                scene.test_occlusions(rays)
                scene.count_intersections(rays)
                scene.list_intersections(rays)


def points() -> None:
    """Point queries: closest points, distance, winding numbers, signed distance and occupancy by both rules, on
    float64 leaves and on a large float32 mesh's float32 leaves."""
    import trimesh

    import durer

    rng = np.random.default_rng(1)
    mesh = trimesh.creation.icosphere(subdivisions=2)
    scene = durer.RaycastingScene()
    scene.add_triangles(mesh.vertices, mesh.faces)
    scene.add_sphere((0, 3, 0), 0.5)
    big = trimesh.creation.icosphere(subdivisions=6)  # float32 leaves, as a scan read from PLY, STL or glTF
    scan = durer.RaycastingScene()
    scan.add_triangles(big.vertices.astype(np.float32), big.faces.astype(np.uint32))
    for target in (scene, scan):
        for dtype, n in ((np.float32, 256), (np.float64, 256), (np.float32, 5000), (np.float64, 5000)):
            p = rng.uniform(-2, 2, (n, 3)).astype(dtype)  # 5000: large batches are walked in Morton order
            target.compute_closest_points(p)
            target.compute_distance(p)
            target.compute_signed_distance(p)
            target.compute_occupancy(p)
            target.compute_signed_distance(p, method="parity", nsamples=3)
            target.compute_occupancy(p, method="parity")


GROUPS: dict[str, Callable[[], None]] = {"course": course, "path": path, "queries": queries, "points": points}


def run_groups(names: list[str]) -> None:
    """Run the named groups here, one after another."""
    for name in names:
        GROUPS[name]()


def warm_up(groups: list[str] | None = None, processes: int | None = None, quiet: bool = False,
            env: dict[str, str] | None = None) -> float:
    """Run the groups (all by default) in parallel child processes, at most `processes` at once (the CPU count);
    return the wall time in seconds. A group that fails raises RuntimeError with its output."""
    names = list(groups or GROUPS)
    unknown = sorted(set(names) - set(GROUPS))
    if unknown:
        raise ValueError(f"unknown warm-up group(s): {', '.join(unknown)} (use {', '.join(GROUPS)})")
    processes = max(1, processes or os.cpu_count() or 1)
    start = time.perf_counter()
    pending = list(names)
    running: list[tuple[str, subprocess.Popen]] = []
    while pending or running:
        while pending and len(running) < processes:
            name = pending.pop(0)
            if not quiet:
                print(f"durer warmup: compiling the {name} kernels ...", file=sys.stderr, flush=True)
            proc = subprocess.Popen([sys.executable, "-m", "durer.warmup", name], env=env,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
            running.append((name, proc))
        name, proc = running.pop(0)
        out, _ = proc.communicate()
        if proc.returncode:
            for _, other in running:
                other.kill()
            raise RuntimeError(f"durer warmup: the {name} group failed:\n{out}")
    return time.perf_counter() - start


def parser() -> argparse.ArgumentParser:
    """The arguments of `durer warmup`."""
    p = argparse.ArgumentParser(prog="durer warmup", description="Compile every kernel now (Numba caches them on "
                                "disk), so that first renders and queries take seconds. `pip install .` already "
                                "does this; use it after an editable install or when building an image.")
    p.add_argument("groups", nargs="*", metavar="GROUP", help=f"what to compile: {', '.join(GROUPS)} (default: all)")
    p.add_argument("--processes", type=int, default=None, help="compile in N processes at once (default: the CPUs)")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    return p


def command(argv: list[str]) -> int:
    """`durer warmup`: UsageError on a bad count, ValueError naming an unknown group (the CLI's one line)."""
    from .errors import UsageError

    args = parser().parse_args(argv)
    if args.processes is not None and args.processes < 1:
        raise UsageError(f"--processes must be at least 1, got {args.processes}")
    seconds = warm_up(args.groups or None, processes=args.processes, quiet=args.quiet)
    if not args.quiet:
        print(f"durer: kernels compiled and cached in {seconds:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    run_groups(sys.argv[1:] or list(GROUPS))
