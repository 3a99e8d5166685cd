"""Mitsuba 3 plugin trees (io/mitsuba_tree.Node, from XML or a dict) -> durer Scene: the scene, integrator, sensor,
film, sampler and emitters, checking every plugin and parameter against what durer renders (each mistake a
SceneError at its file:line). BSDFs are io/mitsuba_bsdfs.py, shapes io/mitsuba_shapes.py."""

from __future__ import annotations

import math
import os
import re

import numpy as np

from ..scene import bsdfs as B
from ..scene.cameras import OrthographicCamera, PerspectiveCamera
from ..scene.graph import Group, Scene
from ..scene.lights import ConstantEnvironment, DirectionalLight, EnvironmentMap, PointLight, SpotLight
from ..scene.textures import Bitmap, Checker
from .images import read_hdr
from .mitsuba_bsdfs import build_bsdf, build_texture, colour
from .mitsuba_shapes import build_shape
from .mitsuba_tree import Props, call
from .mitsuba_xml import MAX_DEPTH

SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")
OUT_OF_SCOPE = ("volpath", "volpathmis", "prbvolpath")  # participating media: not in durer

# Mitsuba's aov types durer computes, and the output each becomes (`durer render` writes them: io/layers.py)
AOV_TYPES = {"albedo": "albedo", "sh_normal": "normals", "geo_normal": "normals", "depth": "depth",
             "position": "position", "uv": "uv"}
# Mitsuba's other aov types, which durer does not compute (a scene asking for them is refused, naming them)
AOV_NOT_COMPUTED = ("dp_du", "dp_dv", "duv_dx", "duv_dy", "prim_index", "shape_index")


class Builder:
    """Walks the plugin tree once, collecting materials, shapes, lights and render defaults. `search` is the file
    resolver's folder list (XML <path>s, then the scene's folder)."""

    def __init__(self, root, mesh_path: list[str] | None = None, base_dir: str = ".",
                 search: list[str] | None = None):
        self.root, self.mesh_path, self.base_dir = root, mesh_path or [], base_dir
        self.search = list(search or [base_dir])
        self.ids: dict = {}
        self.materials: list = []
        self.objects: list = []
        self.lights: list = []
        self.environment = None
        self.defaults: dict = {"integrator": "path", "max_depth": -1, "rr_depth": 5}
        self.camera = None
        self._active: set = set()  # ids being built: a ref back to one of them is a cycle

    def file(self, node, filename: str, where, what: str) -> str:
        """An existing file: absolute, or under one of the resolver's folders, or on the mesh path."""
        candidates = [filename] if os.path.isabs(filename) else \
            [os.path.join(d, filename) for d in self.search + self.mesh_path]
        path = next((c for c in candidates if os.path.isfile(c)), None)
        if path is None:
            raise node.error(f"{what} not found: {filename}", where)
        return path

    def resolve(self, node, depth: int = 0):
        """The plugin a <ref> names (or the node itself), refusing references to what is being built."""
        if node.tag != "ref":
            return node
        if node.id not in self.ids:
            raise node.error(f"reference to unknown id '{node.id}'")
        if node.id in self._active:
            raise node.error(f"reference cycle: '{node.id}' refers to itself through its own contents")
        return self.ids[node.id]

    def enter(self, node, depth: int) -> None:
        if depth > MAX_DEPTH:
            raise node.error(f"plugins nested (or referenced) more than {MAX_DEPTH} deep")
        if node.id is not None:
            self._active.add(node.id)

    def leave(self, node) -> None:
        self._active.discard(node.id)

    def _collect_ids(self, node, depth: int = 0) -> None:
        for child in node.children:
            if child.tag == "ref":
                continue
            if child.id is not None:
                if child.id in self.ids:
                    first = self.ids[child.id].where
                    raise child.error(f"id '{child.id}' declared twice (first at {first[0]}:{first[1]})")
                self.ids[child.id] = child
            self._collect_ids(child, depth + 1)

    def build(self) -> Scene:
        root = self.root
        Props(root).done()
        self._collect_ids(root)
        for child in root.children:
            if child.tag == "ref":
                raise child.error("a <ref> at the top of a scene refers to nothing")
            if child.id is not None and (child.tag == "texture" or (child.tag, child.type) in (
                    ("emitter", "area"), ("shape", "shapegroup"))):
                continue  # declarations: they take effect where a <ref> uses them
            handler = {"integrator": self.integrator, "sensor": self.sensor, "shape": self.shape,
                       "emitter": self.emitter, "bsdf": self.bsdf, "texture": self.texture}.get(child.tag)
            if handler is None:
                raise child.error(f"<{child.tag}> cannot appear at the top of a scene")
            handler(child)
        if self.camera is None:
            raise root.error("the scene has no sensor")
        return Scene(camera=self.camera, group=Group(self.objects), materials=self.materials or [B.Diffuse()],
                     lights=self.lights, environment=self.environment, radiometric_lights=True,
                     render_defaults=self.defaults, source=root.where[0])

    def bsdf(self, node, depth: int = 0):
        return build_bsdf(self, node, depth)

    def texture(self, node):
        build_texture(self, node)  # checked; without an id nothing can use it (Mitsuba ignores it too)

    def shape(self, node) -> None:
        build_shape(self, node)

    def integrator(self, node, depth: int = 0) -> None:
        p = Props(node)
        t = node.type
        if t in ("moment", "aov"):  # wrappers: the RGB image is the nested integrator's
            aovs = p.get("aovs", None, str)
            p.done()
            if t == "aov" and aovs:  # the extra outputs durer computes (AOV_TYPES)
                outputs = tuple(dict.fromkeys(AOV_TYPES[k] for k in _aov_types(node, aovs)))
                self.defaults["aov_outputs"] = outputs
                self.defaults["aovs"] = "albedo" in outputs
                self.defaults["hit_aovs"] = "position" in outputs or "uv" in outputs
            nested = [c for c in node.children if c.tag in ("integrator", "ref")]
            if len(nested) != 1 or len(node.children) != 1:
                raise node.error(f"integrator '{t}': durer renders the RGB image of exactly one nested "
                                 "integrator (its extra channels are not computed)")
            self.enter(node, depth)
            self.integrator(self.resolve(nested[0]), depth + 1)
            self.leave(node)
            return
        if t in OUT_OF_SCOPE:
            raise node.error(f"unsupported integrator '{t}': participating media are outside durer's scope")
        if t == "direct":
            emitter_samples = p.get("emitter_samples", 1, int)
            bsdf_samples = p.get("bsdf_samples", 1, int)
            p.get("shading_samples", None, int)
            if emitter_samples < 1 or bsdf_samples < 1:
                raise node.error("direct: durer needs emitter_samples >= 1 and bsdf_samples >= 1 (it renders "
                                 "'direct' as 'path' with max_depth 2: the same expected image)")
            max_depth, rr_depth = 2, 5
        elif t == "path":
            max_depth, rr_depth = p.get("max_depth", -1, int), p.get("rr_depth", 5, int)
        else:
            raise node.error(f"unsupported integrator '{t}' (durer renders path and direct, and reads moment and "
                             "aov as their nested integrator)")
        self.defaults["hide_emitters"] = p.get("hide_emitters", False, bool)
        if max_depth < -1 or rr_depth < 1:
            raise node.error("max_depth must be >= -1 and rr_depth >= 1")
        self.defaults["max_depth"], self.defaults["rr_depth"] = max_depth, rr_depth
        p.done()
        if node.children:
            raise node.children[0].error(f"<{node.children[0].tag}> cannot appear in integrator '{t}'")

    def sensor(self, node) -> None:
        if node.type not in ("perspective", "thinlens", "orthographic"):
            raise node.error(f"unsupported sensor '{node.type}' (durer reads perspective, thinlens and orthographic)")
        if self.camera is not None:
            raise node.error("durer renders one sensor per scene")
        if node.type == "orthographic":
            return self._orthographic(node)
        p = Props(node)
        fov = p.get("fov", None, float)
        axis = p.get("fov_axis", "x", str).lower()
        focal = p.get("focal_length", None)
        near = p.get("near_clip", 0.01, float)
        far = p.get("far_clip", 10000.0, float)
        aperture = p.get("aperture_radius", None if node.type == "thinlens" else 0.0, float)
        if aperture is None:
            raise node.error("thinlens needs an aperture_radius")
        focus = p.get("focus_distance", far, float)  # a pinhole's does not matter
        if not aperture >= 0 or (aperture > 0 and not focus > 0):
            raise node.error(f"thinlens needs aperture_radius >= 0 and focus_distance > 0, got {aperture:g} and "
                             f"{focus:g}")
        if node.type == "perspective":
            aperture = 0.0
        m = p.get("to_world", np.eye(4), "matrix")
        if fov is not None and focal is not None:
            raise node.error("give either fov or focal_length, not both")
        if fov is None:  # Mitsuba: a 35 mm film's diagonal (43.27 mm) seen through focal_length (50mm by default)
            text = str("50mm" if focal is None else focal).strip()
            mm = _number_or_none(text[:-2] if text.endswith("mm") else text)
            if mm is None or not mm > 0:
                raise node.error(f"focal_length must be a positive length like 50mm, got {text!r}",
                                 p.where("focal_length"))
            fov, axis = math.degrees(2 * math.atan(math.hypot(36.0, 24.0) / (2 * mm))), "diagonal"
        if not 0 < fov < 180:
            raise node.error(f"fov must be between 0 and 180 degrees, got {fov}", p.where("fov"))
        if axis not in ("x", "y", "diagonal", "smaller", "larger"):
            raise node.error(f"unknown fov_axis '{axis}'", p.where("fov_axis"))
        p.done()
        width, height = self._sensor_children(node)
        aspect = width / height
        t = math.tan(math.radians(fov) / 2)
        tan_x = {"x": t, "y": t * aspect, "diagonal": t * width / math.hypot(width, height),
                 "smaller": t if width <= height else t * aspect, "larger": t if width >= height else t * aspect}[axis]
        tan_long = tan_x if width >= height else tan_x / aspect
        origin, left, up, direction = m[:3, 3], m[:3, 0], m[:3, 1], m[:3, 2]
        if np.dot(np.cross(direction, up), -left) <= 0:
            raise node.error("the sensor's to_world mirrors the image (durer's cameras are right-handed)")
        # the lens's sizes are in camera space: to_world's scale moves them into the world
        aperture, focus = aperture * np.linalg.norm(left), focus * np.linalg.norm(direction)
        cam = call(node, PerspectiveCamera, origin, direction, up, math.degrees(2 * math.atan(tan_long)), aperture,
                   focus if aperture > 0 else 1.0)
        cam.t_min = near
        self.camera = cam

    def _sensor_children(self, node) -> tuple[int, int]:
        """The sensor's film and sampler; the film's size."""
        width, height = 768, 576
        for child in node.children:
            child = self.resolve(child)
            if child.tag == "film":
                width, height = self.film(child)
            elif child.tag == "sampler":
                self.sampler(child)
            else:
                raise child.error(f"<{child.tag}> cannot appear in a sensor")
        self.defaults["width"], self.defaults["height"] = width, height
        return width, height

    def _orthographic(self, node) -> None:
        """Mitsuba's orthographic sensor: camera-space x in [-1, 1] across the film (y in +-1/aspect), scaled and
        placed by to_world; rays start near_clip in front of the camera plane."""
        p = Props(node)
        near = p.get("near_clip", 0.01, float)
        p.get("far_clip", None, float)
        m = p.get("to_world", np.eye(4), "matrix")
        p.done()
        width, height = self._sensor_children(node)
        left, up, direction = m[:3, 0], m[:3, 1], m[:3, 2]
        sx, sy = np.linalg.norm(left), np.linalg.norm(up)
        if not (sx > 0 and sy > 0 and abs(sx - sy) <= 1e-9 * max(sx, sy)):
            raise node.error("orthographic to_world must scale x and y alike (durer's pixels are square)")
        if np.dot(np.cross(direction, up), -left) <= 0:
            raise node.error("the sensor's to_world mirrors the image (durer's cameras are right-handed)")
        size = 2 * sx if width >= height else 2 * sx * height / width
        cam = call(node, OrthographicCamera, m[:3, 3], direction, up, size)
        cam.t_min = near / float(np.linalg.norm(direction))
        self.camera = cam

    def film(self, node) -> tuple[int, int]:
        if node.type != "hdrfilm":
            raise node.error(f"unsupported film '{node.type}' (durer reads 'hdrfilm')")
        p = Props(node)
        width, height = p.get("width", 768, int), p.get("height", 576, int)
        if not (1 <= width <= 65536 and 1 <= height <= 65536):
            raise node.error("film width and height must be between 1 and 65536")
        pixel_format = p.get("pixel_format", "rgb", str).lower()
        if pixel_format not in ("rgb", "rgba"):
            raise node.error(f"durer's films are rgb or rgba, not pixel_format '{pixel_format}'",
                             p.where("pixel_format"))
        if pixel_format == "rgba":
            self.defaults["alpha"] = True
        for name in ("component_format", "file_format"):
            p.get(name, None, str)
        p.get("banner", None, bool)
        x, y = p.get("crop_offset_x", 0, int), p.get("crop_offset_y", 0, int)
        w, h = p.get("crop_width", width - x, int), p.get("crop_height", height - y, int)
        if min(x, y) < 0 or min(w, h) < 1 or x + w > width or y + h > height:
            raise node.error(f"the crop window {w} x {h} at ({x}, {y}) must lie inside the {width} x {height} film")
        if (x, y, w, h) != (0, 0, width, height):
            self.defaults["crop"] = (x, y, w, h)
        p.done()
        # Mitsuba's default rfilter: its gaussian (rendering/film.py's mitsuba_gaussian, 4 sigma wide)
        self.defaults["filter"], self.defaults["filter_radius"] = "mitsuba_gaussian", 0.5
        for child in node.children:
            child = self.resolve(child)
            if child.tag != "rfilter":
                raise child.error(f"<{child.tag}> cannot appear in a film")
            self.defaults.update(self._rfilter(child))
        return width, height

    def _rfilter(self, node) -> dict:
        """A Mitsuba rfilter as durer's render defaults: filter name and radius, and mitchell's B and C
        (rendering/film.py)."""
        f = Props(node)
        t = node.type
        out = {}
        if t not in ("box", "tent", "gaussian", "mitchell", "catmullrom", "lanczos"):
            raise node.error(f"unsupported rfilter '{t}' (use box, tent, gaussian, mitchell, catmullrom or lanczos)")
        if t == "mitchell":
            out = {"filter_b": f.get("B", 1.0 / 3.0, float), "filter_c": f.get("C", 1.0 / 3.0, float)}
            radius = 2.0
        elif t == "catmullrom":
            radius = 2.0
        elif t == "lanczos":
            radius = float(f.get("lobes", 3, int))
        elif t == "gaussian":
            radius = f.get("stddev", 0.5, float)
        else:
            radius = f.get("radius", 0.5 if t == "box" else 1.0, float)
        f.done()
        if not radius > 0:
            raise node.error("filter radius must be positive")
        return {"filter": {"gaussian": "mitsuba_gaussian"}.get(t, t), "filter_radius": radius, **out}


    def sampler(self, node) -> None:
        if node.type not in SAMPLERS:
            raise node.error(f"unsupported sampler '{node.type}'")
        p = Props(node)
        spp = p.get("sample_count", 4, int)
        if spp < 1:
            raise node.error("sample_count must be positive")
        self.defaults["samples"] = spp
        seed = p.get("seed", None, int)
        if seed is not None:
            self.defaults["seed"] = seed
        p.get("jitter", None, bool)
        p.done()

    def emitter(self, node, shape=None):
        p = Props(node)
        t = node.type
        if (t == "area") != (shape is not None):
            raise node.error("an area emitter belongs inside a shape (or is declared with an id and referenced "
                             "from one)" if t == "area" else f"emitter '{t}' cannot be attached to a shape")
        if t == "area":
            out = colour(self, node, p, "radiance", 1.0)  # a colour or a texture (looked up at the UV)
        elif t == "point":
            m = p.get("to_world", None, "matrix")
            pos = p.get("position", None, "vec")
            pos = pos if pos is not None else (m[:3, 3] if m is not None else np.zeros(3))
            out = call(node, PointLight, pos, B.rgb(colour(self, node, p, "intensity", 1.0)), (0.0, 0.0, 1.0))
            self.lights.append(out)
        elif t == "spot":
            out = self._spot(node, p)
            self.lights.append(out)
        elif t == "directional":
            m = p.get("to_world", None, "matrix")
            d = p.get("direction", None, "vec")
            d = d if d is not None else (m[:3, 2] if m is not None else np.array([0.0, 0.0, 1.0]))
            out = call(node, DirectionalLight, d, B.rgb(colour(self, node, p, "irradiance", 1.0)))
            self.lights.append(out)
        elif t in ("constant", "envmap"):
            if self.environment is not None:
                raise node.error("a scene can have only one constant or envmap emitter")
            if t == "constant":
                out = call(node, ConstantEnvironment, colour(self, node, p, "radiance", 1.0))
            else:
                out = self._envmap(node, p)
            self.environment = out
        else:
            raise node.error(f"unsupported emitter '{t}' (use area, point, spot, directional, constant or envmap)")
        p.done()
        for child in node.children:
            # the spot's projected texture, an area light's textured radiance
            if not (t == "spot" and child.name == "texture" or t == "area" and child.name == "radiance"):
                raise child.error(f"<{child.tag}> cannot appear in emitter '{t}'")
        return out

    def _spot(self, node, p) -> SpotLight:
        """Mitsuba's spot: at to_world's origin along its +z, intensity / d^2, full inside beam_width (default 3/4
        of cutoff_angle, 20 degrees), falling off linearly in the angle to 0 at cutoff_angle; a `texture` projected
        through the cone multiplies the intensity."""
        texture = colour(self, node, p, "texture", None)
        m = p.get("to_world", np.eye(4), "matrix")
        cutoff = p.get("cutoff_angle", 20.0, float)
        beam = p.get("beam_width", 0.75 * cutoff, float)
        intensity = B.rgb(colour(self, node, p, "intensity", 1.0))
        if not 0 < cutoff <= 90 or not 0 <= beam < cutoff:
            raise node.error(f"spot: durer needs 0 <= beam_width < cutoff_angle <= 90 degrees, got {beam:g} and "
                             f"{cutoff:g}")
        frame = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
        if texture is not None and not isinstance(texture, (Bitmap, Checker)):  # a constant: one more factor
            intensity, texture = intensity * B.rgb(texture), None
        return call(node, SpotLight, m[:3, 3], m[:3, 2], intensity, beam, cutoff, (0.0, 0.0, 1.0), "angle",
                    frame[:, 0], frame[:, 1], texture)

    def _envmap(self, node, p) -> EnvironmentMap:
        filename = p.get("filename", None, str)
        scale = p.get("scale", 1.0, float)
        m = p.get("to_world", np.eye(4), "matrix")
        if not filename:
            raise node.error("envmap needs a filename (.exr, .hdr, .pfm or .npy)")
        r = m[:3, :3]
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise node.error("envmap to_world must be a rotation")
        path = self.file(node, filename, p.where("filename"), "environment map")
        try:
            image = read_hdr(path)
        except ValueError as e:
            raise node.error(str(e), p.where("filename")) from None
        return call(node, EnvironmentMap, image, scale, m, path)


def _number_or_none(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _aov_types(node, aovs: str) -> list[str]:
    """The types of an aov integrator's `aovs` list ("name:type, ..." split at commas and spaces, empty items
    skipped, as Mitsuba's): a SceneError at the integrator's line for an entry that is not name:type (Mitsuba
    warns), a type Mitsuba does not know, or one durer does not compute."""
    kinds = []
    for item in (i for i in re.split(r"[,\s]+", aovs) if i):
        name, colon, kind = item.partition(":")
        if not colon or not name or not kind:
            raise node.error(f"aov: {item.strip()!r} is not a name:type pair (aovs=\"{aovs}\")")
        if kind in AOV_NOT_COMPUTED:
            raise node.error(f"aov: durer does not compute the '{kind}' output (it computes "
                             f"{', '.join(AOV_TYPES)})")
        if kind not in AOV_TYPES:
            raise node.error(f"aov: unknown AOV type '{kind}' (Mitsuba's are {', '.join(AOV_TYPES)}, "
                             f"{', '.join(AOV_NOT_COMPUTED)})")
        kinds.append(kind)
    return kinds
