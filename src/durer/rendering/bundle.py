"""The compiled scene bundle: everything the render stages read, made by one compile step.

`compile_bundle(scene, options)` checks the scene, flattens its object tree in one walk (accel/compile.py) and
builds every table the integrators read from that walk's arrays and the scene's flat lists: the course's Phong
table, the path tracer's BSDF and texture tables, its emitters (area lights over the placed triangles, lights,
environment map tables) and the camera-independent settings (background, ambient light, course or radiometric
lights). After it, no integrator, film, explain, preview or dask unit reads the Scene or builds a table: they read
`RenderContext.bundle` (context.py), which pickles with the context. The camera is not in the bundle: a view
(preview, animation frames) is the same bundle through another camera.

It is a rendering step, not accel's: the tables are the integrators' own (shading.py, bsdfs.py, emitters.py), and
accel may not import rendering (tests/test_project_architecture.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..accel.compile import CompiledScene, compile_scene, with_course_edges
from ..options import RenderOptions
from ..scene.graph import Scene
from ..scene.validate import PHYSICAL, check_scene
from .bsdfs import BSDFTable
from .emitters import Emitters
from .shading import MaterialTable
from .texturing import has_image_textures


@dataclass(frozen=True)
class SceneBundle:
    """A compiled scene: geometry, material and emitter tables, and the scene-wide settings, built once."""

    geometry: CompiledScene  # what rays hit (triangles widened by the course's edge tolerance under course_edges)
    given: CompiledScene     # the geometry as given: the course grid's cells and the -stats bounds
    materials: tuple         # the scene's materials by id: solid and image textures are evaluated from them
    phong: MaterialTable     # the course integrators' Phong table (rows of zeros for other materials)
    bsdfs: BSDFTable         # the path tracer's BSDF table, with its TextureTable
    emitters: Emitters       # the path tracer's emitters: area lights, lights, environment (map tables included)
    lights: tuple | None     # the course's lights; None: no Lights block, objects show their flat colour
    background: np.ndarray   # (3,) the colour camera rays see where they escape (course scenes)
    ambient: np.ndarray      # (3,) the course's ambient light
    radiometric: bool        # light colours are radiometric (Mitsuba) rather than the course's
    textured: bool           # some material has an image texture and the meshes have UVs: compute UVs at hits
    physical: bool           # some material is physically based: only the path tracer renders it


def compile_bundle(scene: Scene, options: RenderOptions) -> SceneBundle:
    """Check the scene (ValueError naming a wrong object), compile its geometry in one walk of the tree and build
    every table from it. options.course_edges: the course command's triangles, which accept points just outside
    their edges (accel/compile.with_course_edges)."""
    check_scene(scene)
    given = compile_scene(scene)
    geometry = with_course_edges(given) if options.course_edges else given
    materials = tuple(scene.materials)
    bsdfs = BSDFTable.from_materials(list(materials))
    emitters = Emitters.build(scene, geometry, bsdfs)
    # the kernels' packed arrays, made now so that no render stage builds (or caches into) a table
    bsdfs.packed()
    emitters.pack()
    emitters.env_tables()
    bsdfs.textures.packed()
    lights = None if scene.lights is None else tuple(scene.lights)
    return SceneBundle(
        geometry=geometry, given=given, materials=materials, phong=MaterialTable.from_materials(list(materials)),
        bsdfs=bsdfs, emitters=emitters, lights=lights,
        background=np.asarray(scene.background_color, dtype=np.float64),
        ambient=np.asarray(scene.ambient_light, dtype=np.float64), radiometric=bool(scene.radiometric_lights),
        textured=has_image_textures(list(materials)) and geometry.has_uv,
        physical=any(isinstance(m, PHYSICAL) for m in materials))
