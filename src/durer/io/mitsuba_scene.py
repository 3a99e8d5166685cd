"""Mitsuba 3 plugin trees (io/mitsuba.py's Node, from XML or a dict) -> durer Scene, checking every plugin and
parameter against the subset durer renders (each mistake a SceneError at its file:line)."""

from __future__ import annotations

import math
import os

import numpy as np

from ..scene import bsdfs as B
from ..scene.cameras import PerspectiveCamera
from ..scene.graph import Group, Scene, Transform
from ..scene.lights import ConstantEnvironment, DirectionalLight, EnvironmentMap, PointLight
from ..scene.shapes import Sphere, TriangleMesh
from .images import read_hdr

DISK_SEGMENTS = 256
_ROUGH = ("alpha", "alpha_u", "alpha_v", "distribution", "sample_visible")


# Mitsuba's aov types durer produces, and the output each becomes (io/layers.py)
AOV_TYPES = {"albedo": "albedo", "sh_normal": "normals", "geo_normal": "normals", "depth": "depth"}


class _Props:
    """A plugin's parameters, taken one by one; whatever is left at the end is outside the subset."""

    def __init__(self, node):
        self.node = node
        self.left = dict(node.props)

    def get(self, name: str, default=None, kind=None):
        if name not in self.left:
            return default
        value, where = self.left.pop(name)
        if kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise self.node.error(f"{name} of {self.node.tag} '{self.node.type}' must be a number", where)
            return float(value)
        if kind is int:
            if isinstance(value, bool) or int(value) != value:
                raise self.node.error(f"{name} of {self.node.tag} '{self.node.type}' must be an integer", where)
            return int(value)
        if kind is bool and not isinstance(value, (bool, np.bool_)):
            raise self.node.error(f"{name} of {self.node.tag} '{self.node.type}' must be true or false", where)
        if kind == "matrix":
            m = np.asarray(getattr(value, "matrix", value), dtype=np.float64)
            if m.shape != (4, 4) or not np.isfinite(m).all():
                raise self.node.error(f"{name} must be a 4x4 transform", where)
            return m
        if kind == "vec":
            v = np.asarray(value, dtype=np.float64).reshape(-1)
            if v.size != 3:
                raise self.node.error(f"{name} must be three numbers", where)
            return v
        return value

    def where(self, name: str):
        return self.node.props[name][1] if name in self.node.props else self.node.where

    def done(self) -> None:
        for name, (_, where) in self.left.items():
            raise self.node.error(f"unsupported parameter '{name}' of {self.node.tag} '{self.node.type}' "
                                  "(outside durer's Mitsuba subset)", where)


def _call(node, fn, *args, **kw):
    """Run a description constructor, turning its ValueError into a SceneError at the node."""
    try:
        return fn(*args, **kw)
    except ValueError as e:
        raise node.error(f"{node.tag} '{node.type}': {e}") from None


class Builder:
    """Walks the plugin tree once, collecting materials, shapes, lights and render defaults."""

    def __init__(self, root, mesh_path: list[str] | None = None, base_dir: str = "."):
        self.root, self.mesh_path, self.base_dir = root, mesh_path or [], base_dir
        self.ids: dict = {}
        self.materials: list = []
        self.objects: list = []
        self.lights: list = []
        self.environment = None
        self.defaults: dict = {"integrator": "path", "max_depth": -1, "rr_depth": 5}
        self.camera = None

    def resolve(self, node):
        if node.tag != "ref":
            return node
        if node.id not in self.ids:
            raise node.error(f"reference to unknown id '{node.id}'")
        return self.ids[node.id]

    def build(self) -> Scene:
        root = self.root
        _Props(root).done()
        for child in root.children:
            if child.id is not None:
                self.ids[child.id] = child
        for child in root.children:
            child = self.resolve(child)
            handler = {"integrator": self.integrator, "sensor": self.sensor, "shape": self.shape,
                       "emitter": self.emitter, "bsdf": lambda n: self.bsdf(n)}.get(child.tag)
            if handler is None:
                raise child.error(f"<{child.tag}> cannot appear at the top of a scene")
            handler(child)
        if self.camera is None:
            raise root.error("the scene has no sensor")
        return Scene(camera=self.camera, group=Group(self.objects), materials=self.materials or [B.Diffuse()],
                     lights=self.lights, environment=self.environment, radiometric_lights=True,
                     render_defaults=self.defaults, source=root.where[0])

    def integrator(self, node) -> None:
        if node.type == "aov":
            return self.aov_integrator(node)
        if node.type != "path":
            raise node.error(f"unsupported integrator '{node.type}' (durer renders Mitsuba's 'path')")
        p = _Props(node)
        self.defaults["max_depth"] = p.get("max_depth", -1, int)
        self.defaults["rr_depth"] = p.get("rr_depth", 5, int)
        self.defaults["hide_emitters"] = p.get("hide_emitters", False, bool)
        if self.defaults["max_depth"] < -1 or self.defaults["rr_depth"] < 1:
            raise node.error("max_depth must be >= -1 and rr_depth >= 1")
        p.done()

    def aov_integrator(self, node) -> None:
        """Mitsuba's `aov` integrator (issue 24): its outputs `name:type` map onto durer's (AOV_TYPES), which the
        CLI writes beside the image under durer's names; its nested integrator renders the colour."""
        p = _Props(node)
        outputs = []
        for item in str(p.get("aovs", "")).split(","):
            name, _, kind = item.strip().partition(":")
            if kind not in AOV_TYPES:
                raise node.error(f"unsupported aov '{item.strip()}' (durer writes "
                                 f"{', '.join(f'name:{t}' for t in AOV_TYPES)})", p.where("aovs"))
            outputs.append(AOV_TYPES[kind])
        p.done()
        inner = [c for c in node.children if c.tag == "integrator"]
        if len(inner) > 1:
            raise inner[1].error("durer renders one integrator inside 'aov'")
        if inner:
            self.integrator(self.resolve(inner[0]))
        self.defaults["aov_outputs"] = tuple(dict.fromkeys(outputs))
        self.defaults["aovs"] = "albedo" in outputs

    def sensor(self, node) -> None:
        if node.type != "perspective":
            raise node.error(f"unsupported sensor '{node.type}' (durer reads 'perspective')")
        p = _Props(node)
        fov = p.get("fov", None, float)
        axis = p.get("fov_axis", "x")
        near = p.get("near_clip", 0.01, float)
        p.get("far_clip", None, float)
        p.get("focus_distance", None, float)  # a pinhole: focus does not matter
        m = p.get("to_world", np.eye(4), "matrix")
        if fov is None:
            raise node.error("the perspective sensor needs fov (durer does not read focal_length)")
        if axis not in ("x", "y", "diagonal", "smaller", "larger"):
            raise node.error(f"unknown fov_axis '{axis}'", p.where("fov_axis"))
        p.done()
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
        aspect = width / height
        t = math.tan(math.radians(fov) / 2)
        tan_x = {"x": t, "y": t * aspect, "diagonal": t * width / math.hypot(width, height),
                 "smaller": t if width <= height else t * aspect, "larger": t if width >= height else t * aspect}[axis]
        tan_long = tan_x if width >= height else tan_x / aspect
        origin, left, up, direction = m[:3, 3], m[:3, 0], m[:3, 1], m[:3, 2]
        if np.dot(np.cross(direction, up), -left) <= 0:
            raise node.error("the sensor's to_world mirrors the image (durer's cameras are right-handed)")
        cam = _call(node, PerspectiveCamera, origin, direction, up, math.degrees(2 * math.atan(tan_long)))
        cam.t_min = near
        self.camera = cam

    def film(self, node) -> tuple[int, int]:
        if node.type != "hdrfilm":
            raise node.error(f"unsupported film '{node.type}' (durer reads 'hdrfilm')")
        p = _Props(node)
        width, height = p.get("width", 768, int), p.get("height", 576, int)
        if width < 1 or height < 1:
            raise node.error("film width and height must be positive")
        for name in ("pixel_format", "component_format", "file_format", "banner"):
            p.get(name)
        p.done()
        self.defaults["filter"], self.defaults["filter_radius"] = "gaussian", 0.5  # Mitsuba's default rfilter
        for child in node.children:
            child = self.resolve(child)
            if child.tag != "rfilter":
                raise child.error(f"<{child.tag}> cannot appear in a film")
            f = _Props(child)
            if child.type not in ("box", "tent", "gaussian"):
                raise child.error(f"unsupported rfilter '{child.type}' (use box, tent or gaussian)")
            radius = f.get("stddev", 0.5, float) if child.type == "gaussian" else \
                f.get("radius", 0.5 if child.type == "box" else 1.0, float)
            f.done()
            if not radius > 0:
                raise child.error("filter radius must be positive")
            self.defaults["filter"], self.defaults["filter_radius"] = child.type, radius
        return width, height

    def sampler(self, node) -> None:
        if node.type not in ("independent", "stratified", "multijitter", "orthogonal", "ldsampler"):
            raise node.error(f"unsupported sampler '{node.type}'")
        p = _Props(node)
        spp = p.get("sample_count", 4, int)
        if spp < 1:
            raise node.error("sample_count must be positive")
        self.defaults["samples"] = spp
        seed = p.get("seed", None, int)
        if seed is not None:
            self.defaults["seed"] = seed
        p.get("jitter", None, bool)
        p.done()

    def bsdf(self, node):
        """A BSDF description (a ref resolved); each node is built once so shared refs share it."""
        node = self.resolve(node)
        if node.tag != "bsdf":
            raise node.error(f"expected a bsdf, found <{node.tag}>")
        cached = getattr(node, "_built", None)
        if cached is not None:
            return cached
        p = _Props(node)
        t = node.type
        rough = t in ("roughconductor", "roughplastic")
        if rough:
            dist = p.get("distribution", "beckmann")
            if dist != "ggx":
                raise node.error(f"{t}: only distribution 'ggx' is supported (Mitsuba's default is beckmann; "
                                 "set it explicitly)", p.where("distribution"))
            if not p.get("sample_visible", True, bool):
                raise node.error(f"{t}: sample_visible must be true")
            alpha = p.get("alpha", 0.1, float)
        if t == "diffuse":
            out = _call(node, B.Diffuse, p.get("reflectance", 0.5))
        elif t == "dielectric":
            out = _call(node, B.Dielectric, p.get("int_ior", 1.5046), p.get("ext_ior", 1.000277),
                        p.get("specular_reflectance", 1.0), p.get("specular_transmittance", 1.0))
        elif t in ("conductor", "roughconductor"):
            material = p.get("material", None)
            eta, k = p.get("eta", None), p.get("k", None)
            kw = dict(specular_reflectance=p.get("specular_reflectance", 1.0))
            if t == "roughconductor":
                kw.update(alpha_u=p.get("alpha_u", alpha, float), alpha_v=p.get("alpha_v", alpha, float))
            cls = B.RoughConductor if t == "roughconductor" else B.Conductor
            if material is not None and (eta is not None or k is not None):
                raise node.error(f"{t}: give either material or eta and k")
            if eta is None and k is None:
                out = _call(node, cls.named, material or "none", **kw)
            else:
                out = _call(node, cls, 0.0 if eta is None else eta, 1.0 if k is None else k, **kw)
        elif t in ("plastic", "roughplastic"):
            args = (p.get("diffuse_reflectance", 0.5), p.get("specular_reflectance", 1.0),
                    p.get("int_ior", 1.49), p.get("ext_ior", 1.000277), p.get("nonlinear", False, bool))
            out = _call(node, B.RoughPlastic, *args, alpha) if rough else _call(node, B.Plastic, *args)
        elif t == "twosided":
            if len(node.children) != 1:
                raise node.error("twosided needs exactly one nested bsdf (durer has no different back side)")
            out = _call(node, B.TwoSided, self.bsdf(node.children[0]))
        else:
            raise node.error(f"unsupported bsdf '{t}' (use diffuse, dielectric, conductor, roughconductor, "
                             "plastic, roughplastic or twosided)")
        if t != "twosided" and node.children:
            raise node.children[0].error(f"<{node.children[0].tag}> cannot appear in bsdf '{t}' (textures are "
                                         "outside durer's Mitsuba subset)")
        p.done()
        node._built = out
        return out

    def emitter(self, node, shape=None):
        p = _Props(node)
        t = node.type
        if (t == "area") != (shape is not None):
            raise node.error("an area emitter belongs inside a shape" if t == "area" else
                             f"emitter '{t}' cannot be attached to a shape")
        if t == "area":
            out = p.get("radiance", 1.0)
        elif t == "point":
            m = p.get("to_world", None, "matrix")
            pos = p.get("position", None, "vec")
            pos = pos if pos is not None else (m[:3, 3] if m is not None else np.zeros(3))
            out = _call(node, PointLight, pos, B.rgb(p.get("intensity", 1.0)), (0.0, 0.0, 1.0))
            self.lights.append(out)
        elif t == "directional":
            m = p.get("to_world", None, "matrix")
            d = p.get("direction", None, "vec")
            d = d if d is not None else (m[:3, 2] if m is not None else np.array([0.0, 0.0, 1.0]))
            out = _call(node, DirectionalLight, d, B.rgb(p.get("irradiance", 1.0)))
            self.lights.append(out)
        elif t in ("constant", "envmap"):
            if self.environment is not None:
                raise node.error("a scene can have only one constant or envmap emitter")
            if t == "constant":
                out = _call(node, ConstantEnvironment, p.get("radiance", 1.0))
            else:
                out = self._envmap(node, p)
            self.environment = out
        else:
            raise node.error(f"unsupported emitter '{t}' (use area, point, directional, constant or envmap)")
        if node.children:
            raise node.children[0].error(f"<{node.children[0].tag}> cannot appear in an emitter")
        p.done()
        return out

    def _envmap(self, node, p) -> EnvironmentMap:
        filename = p.get("filename", None)
        scale = p.get("scale", 1.0, float)
        m = p.get("to_world", np.eye(4), "matrix")
        if not filename:
            raise node.error("envmap needs a filename (.exr, .pfm or .npy)")
        r = m[:3, :3]
        if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
            raise node.error("envmap to_world must be a rotation")
        path = filename if os.path.isabs(filename) else os.path.join(self.base_dir, filename)
        if not os.path.isfile(path):
            raise node.error(f"environment map not found: {filename}", p.where("filename"))
        try:
            image = read_hdr(path)
        except ValueError as e:
            raise node.error(str(e), p.where("filename")) from None
        return _call(node, EnvironmentMap, image, scale, m, path)

    def shape(self, node) -> None:
        p = _Props(node)
        t = node.type
        m = p.get("to_world", np.eye(4), "matrix")
        flip = p.get("flip_normals", False, bool)
        if t in ("obj", "ply"):
            geometry = self._mesh_file(node, p.get("filename", None), p)
        elif t == "rectangle":
            geometry = TriangleMesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]])
        elif t == "cube":
            geometry = _cube()
        elif t == "disk":
            a = np.linspace(0.0, 2.0 * np.pi, DISK_SEGMENTS, endpoint=False)
            v = np.vstack([[0.0, 0.0, 0.0], np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])])
            i = np.arange(DISK_SEGMENTS)
            geometry = TriangleMesh(v, np.column_stack([np.zeros_like(i), 1 + i, 1 + (i + 1) % DISK_SEGMENTS]))
        elif t == "sphere":
            geometry = _call(node, Sphere, p.get("center", np.zeros(3), "vec"), p.get("radius", 1.0, float))
        else:
            raise node.error(f"unsupported shape '{t}' (use obj, ply, rectangle, cube, sphere or disk)")
        p.done()
        bsdf, radiance = None, None
        for child in node.children:
            child = self.resolve(child)
            if child.tag == "bsdf":
                if bsdf is not None:
                    raise child.error("a shape has one bsdf")
                bsdf = self.bsdf(child)
            elif child.tag == "emitter":
                if radiance is not None:
                    raise child.error("a shape has one emitter")
                radiance = self.emitter(child, shape=node)
            else:
                raise child.error(f"<{child.tag}> cannot appear in a shape")
        if abs(np.linalg.det(m[:3, :3])) < 1e-300:
            raise node.error("to_world is singular")
        surface = _call(node, B.Surface, bsdf if bsdf is not None else B.Diffuse(), radiance, flip)
        self.materials.append(surface)
        geometry.material = len(self.materials) - 1
        self.objects.append(Transform(m, geometry))

    def _mesh_file(self, node, filename, p):
        for name in ("face_normals",):
            p.get(name)
        if not filename:
            raise node.error(f"shape '{node.type}' needs a filename")
        candidates = [filename if os.path.isabs(filename) else os.path.join(self.base_dir, filename)]
        candidates += [os.path.join(d, filename) for d in self.mesh_path]
        path = next((c for c in candidates if os.path.isfile(c)), None)
        if path is None:
            raise node.error(f"mesh file not found: {filename}", p.where("filename"))
        import trimesh

        try:
            mesh = trimesh.load(path, file_type=node.type, force="mesh", process=False)
        except Exception as e:  # trimesh raises many types on malformed files
            raise node.error(f"cannot read mesh {filename}: {e}") from None
        if not len(getattr(mesh, "faces", ())):
            raise node.error(f"mesh {filename} has no triangles")
        return _call(node, TriangleMesh, np.asarray(mesh.vertices), np.asarray(mesh.faces))


def _cube() -> TriangleMesh:
    """[-1, 1]^3 with outward-facing triangles."""
    v = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
    faces = []
    for axis in range(3):
        for sign in (-1, 1):
            quad = [i for i in range(8) if v[i, axis] == sign]
            c = v[quad].mean(0)
            normal = np.zeros(3)
            normal[axis] = sign
            e1, e2 = np.eye(3)[(axis + 1) % 3], np.eye(3)[(axis + 2) % 3]
            quad.sort(key=lambda i: math.atan2((v[i] - c) @ e2, (v[i] - c) @ e1))
            a, b, c2, d = quad
            for tri in ((a, b, c2), (a, c2, d)):
                n = np.cross(v[tri[1]] - v[tri[0]], v[tri[2]] - v[tri[0]])
                faces.append(tri if n @ normal > 0 else (tri[0], tri[2], tri[1]))
    return TriangleMesh(v, np.array(faces))
