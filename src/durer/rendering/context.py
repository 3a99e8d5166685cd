"""RenderContext, what every integrator reads (the compiled scene bundle, the camera, an accelerator, the options),
how it is built from a scene, and SampleResult, what every integrator returns per camera ray."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..accel.brute import BruteForce
from ..accel.bvh import BVHAccelerator
from ..accel.compile import CompiledScene
from ..accel.grid import GridAccelerator
from ..accel.hits import Accelerator
from ..accel.stats import CountingAccelerator, RayStats
from ..options import RenderOptions
from ..scene.graph import Scene
from ..scene.validate import check_scene
from .builds import kept_build
from .bundle import SceneBundle, compile_bundle
from .shading import MaterialTable


@dataclass
class RenderContext:
    """What every integrator needs: the compiled scene bundle (geometry, tables, settings: bundle.py), the camera
    it is seen through, an accelerator and the options. It holds no Scene: nothing after compile reads one."""

    bundle: SceneBundle
    camera: object
    accel: Accelerator
    options: RenderOptions = field(default_factory=RenderOptions)
    # what an integrator builds once per render at prepare time from the bundle and the accelerator
    # (Integrator.prepare: the path tracer's surface arrays and tree), so no unit builds it again; it pickles
    prepared: dict = field(default_factory=dict, repr=False, compare=False)
    # what an integrator derives from the bundle and the accelerator alone (the path tracer's surface arrays):
    # shared by every context of one build, so it is kept with the build between renders (builds.py)
    derived: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def compiled(self) -> CompiledScene:
        """The geometry rays hit (bundle.geometry)."""
        return self.bundle.geometry

    @property
    def materials(self) -> MaterialTable:
        """The course integrators' Phong table (bundle.phong)."""
        return self.bundle.phong

    @property
    def textured(self) -> bool:
        """Some material has an image texture: integrators compute UVs at the hits (bundle.textured)."""
        return self.bundle.textured


@dataclass
class SampleResult:
    """Per-ray results: linear colour (N,3), t of the closest hit (inf on a miss), world normal (N,3); and the
    denoiser's features, None when the integrator does not produce them (options.aovs off): the first
    non-specular hit's albedo (N,3), seen through mirrors and glass, and its shading normal (N,3); the path
    tracer's share of the colour that is emission seen directly or through mirrors and glass (N,3), from surface
    emitters (emission) and from the environment (environment), which the denoiser keeps out of its input
    (rendering/denoise.py). The film filters every feature that is not None like the colour (units.py)."""

    color: np.ndarray
    t: np.ndarray
    normal: np.ndarray
    albedo: np.ndarray | None = None
    shading_normal: np.ndarray | None = None
    emission: np.ndarray | None = None
    environment: np.ndarray | None = None


def make_context(scene: Scene, options: RenderOptions) -> RenderContext:
    """Compile the scene into its bundle (bundle.compile_bundle: ValueError naming a wrong object) and build its
    accelerator, or take those kept from the last render of the unchanged scene (builds.py); the scene's own camera
    is the context's."""
    check_scene(scene)  # every render: the camera is checked, and the fingerprint walks a valid (acyclic) tree
    if options.stats or options.grid is not None:  # counters of this render's rays; the course's grid is cheap
        bundle, accel, derived = *_build(scene, options), {}
    else:
        bundle, accel, derived = kept_build(scene, build_key(options), lambda: (*_build(scene, options), {}))
    return RenderContext(bundle=bundle, camera=scene.camera, accel=accel, options=options, derived=derived)


# The options _build reads (itself and through compile_bundle): a kept build is reused only for the same values, so
# an option read there must be added here, or renders with another value get a stale build
# (tests/test_rendering_context.py checks that _build reads no other option).
BUILD_OPTIONS = ("course_edges", "integrator", "accel", "stats", "grid")


def build_key(options: RenderOptions) -> tuple:
    """What a kept build must agree on with the render that wants it (stats and grid renders are never kept)."""
    return options.course_edges, options.integrator == "path", options.accel


def _build(scene: Scene, options: RenderOptions) -> tuple[SceneBundle, Accelerator]:
    """The scene's bundle and accelerator: what make_context builds, or keeps between renders."""
    bundle = compile_bundle(scene, options)
    cs, hit_cs = bundle.given, bundle.geometry
    # the lecture's loop over every object (--accel brute), or the bounding volume hierarchy (the default)
    # The path tracer walks one tree inside its fused bounce (rendering/path.py), which a two-level BVH is not, and
    # it reads the flattened triangles anyway: it gets instanced meshes flattened into one tree (same virtual ids,
    # same images to the bit). Through the unfused wavefront of two-level queries the instanced real Mitsuba scenes
    # took 1.3-1.4x the CPU time (benchmarks/README.md, "The path tracer on every real Mitsuba scene").
    tree_cs = hit_cs.flat if options.integrator == "path" else hit_cs
    accel: Accelerator = BruteForce(hit_cs) if options.accel == "brute" else BVHAccelerator(tree_cs)
    # -grid / -stats (issue 4, item 5; grid.py, stats.py): the course's uniform grid instead of the default
    # accelerator, and counters of rays, ray-primitive tests and grid cells, read back as RenderResult.stats
    stats = RayStats(bounds=cs.bounds()) if options.stats else None
    if options.grid is not None:
        accel = GridAccelerator(cs, options.grid, stats=stats)  # spheres under a Transform go in as boxes
        accel.cs = hit_cs  # cells hold the triangles' boxes as given (the course's insertion); tests use hit_cs
    elif stats is not None:
        # the course's -stats without a grid counts its loop over every object; measure that same loop, so the
        # counts are real and compare with the course's (the image is the same as the BVH's, as tests check)
        accel = CountingAccelerator(BruteForce(hit_cs), stats, sum(cs.counts))
    return bundle, accel
