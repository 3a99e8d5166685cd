"""Mitsuba 3 scenes: the XML format (and `load_dict`, the same structure as a Python dict, like mi.load_dict)
for the subset the path tracer renders. Anything outside it is a SceneError `file:line: ...` naming the element
or parameter, never a silent difference.

Subset: scene; default (name, value) with $name substitution; integrator path (max_depth, rr_depth, hide_emitters),
and aov (albedo, sh_normal, geo_normal, depth) around it;
sensor perspective (fov, fov_axis, near_clip, far_clip, focus_distance, to_world) with film hdrfilm (width, height,
rfilter box/tent/gaussian, pixel_format, component_format) and a sampler (sample_count, seed; every sampler type
maps onto durer's own Owen-scrambled Sobol stream); shapes obj, ply, rectangle, cube, sphere, disk (to_world,
flip_normals, filename, center, radius; nested or referenced bsdf; nested area emitter); bsdfs diffuse,
dielectric, conductor, roughconductor, plastic, roughplastic (ggx only), twosided; emitters area, point,
directional, constant, envmap (filename .exr/.pfm/.npy, scale, to_world); properties float, integer, boolean,
string, rgb, point, vector, transform (lookat, matrix, translate, rotate, scale) and ref.

Known differences, by design: a disk becomes a fan of DISK_SEGMENTS triangles (area 0.01% short of the circle's,
below the noise of any render here); meshes are shaded with face normals (vertex normals of OBJ/PLY files are not
interpolated); the gaussian filter's stddev becomes durer's gaussian sigma (durer cuts it at 2 sigma, Mitsuba at
4); near_clip becomes the camera rays' t_min (Mitsuba measures it along the view axis); far_clip is read but not
applied (geometry beyond it stays visible; Mitsuba's default is 10^4); every sampler type is durer's own sampler.
"""

from __future__ import annotations

import math
import os
import re
import xml.parsers.expat
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from ..scene.graph import Scene
from .files import read_bytes
from .mitsuba_scene import DISK_SEGMENTS, Builder  # noqa: F401  (DISK_SEGMENTS: see the docstring)

PLUGINS = ("scene", "integrator", "sensor", "film", "rfilter", "sampler", "shape", "bsdf", "emitter")
PROPERTIES = ("float", "integer", "boolean", "string", "rgb", "point", "vector", "transform")


@dataclass
class Node:
    """One plugin: its category (`tag`), type, id/name, properties {name: (value, where)} and nested plugins."""

    tag: str
    type: str
    where: tuple
    id: str | None = None
    name: str | None = None
    props: dict = field(default_factory=dict)
    children: list = field(default_factory=list)

    def error(self, message: str, where=None) -> SceneError:
        path, line = where or self.where
        return SceneError(message, path, line)


# --- XML ----------------------------------------------------------------------------------------------------------
@dataclass
class _Elem:
    tag: str
    attrs: dict
    line: int
    children: list = field(default_factory=list)


def _parse_xml(path: str) -> _Elem:
    data = read_bytes(path, "scene file")
    parser = xml.parsers.expat.ParserCreate()
    stack: list[_Elem] = [_Elem("#document", {}, 1)]

    def start(tag, attrs):
        e = _Elem(tag, dict(attrs), parser.CurrentLineNumber)
        stack[-1].children.append(e)
        stack.append(e)

    def end(tag):
        stack.pop()

    parser.StartElementHandler, parser.EndElementHandler = start, end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as e:
        raise SceneError(f"malformed XML: {xml.parsers.expat.ErrorString(e.code)}", path, e.lineno) from None
    root = stack[0].children
    if len(root) != 1 or root[0].tag != "scene":
        raise SceneError("the root element must be <scene>", path, root[0].line if root else 1)
    return root[0]


def _numbers(text: str, where, what: str) -> list[float]:
    try:
        return [float(x) for x in re.split(r"[,\s]+", text.strip()) if x]
    except ValueError:
        raise SceneError(f"{what}: not a list of numbers: {text!r}", *where) from None


def _xyz(e: _Elem, where, what: str, default: float | None = None) -> np.ndarray:
    if "value" in e.attrs:
        v = _numbers(e.attrs["value"], where, what)
        if len(v) == 1:
            v = v * 3
    else:
        if default is None and not all(k in e.attrs for k in "xyz"):
            raise SceneError(f"<{e.tag}> needs x, y and z (or value)", *where)
        v = [float(_num(e.attrs.get(k, default), where, what)) for k in "xyz"]
    if len(v) != 3:
        raise SceneError(f"{what} needs three numbers, got {len(v)}", *where)
    return np.array(v, dtype=np.float64)


def _num(text, where, what: str) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        raise SceneError(f"{what}: not a number: {text!r}", *where) from None


def _transform(e: _Elem, path: str, subst) -> np.ndarray:
    m = np.eye(4)
    for c in e.children:
        where = (path, c.line)
        a = {k: subst(v, where) for k, v in c.attrs.items()}
        c = _Elem(c.tag, a, c.line, c.children)
        if c.tag == "translate":
            t = np.eye(4)
            t[:3, 3] = _xyz(c, where, "translate", 0.0)
            op = t
        elif c.tag == "scale":
            op = np.diag(np.append(_xyz(c, where, "scale", 1.0), 1.0))
        elif c.tag == "rotate":
            axis = _xyz(c, where, "rotate axis", 0.0)
            op = rotation(axis, _num(a.get("angle"), where, "rotate angle"))
            if not np.linalg.norm(axis) > 0:
                raise SceneError("rotate needs a non-zero axis", *where)
        elif c.tag == "matrix":
            v = _numbers(a.get("value", ""), where, "matrix")
            if len(v) not in (9, 16):
                raise SceneError(f"matrix needs 16 (or 9) numbers, got {len(v)}", *where)
            op = np.eye(4)
            if len(v) == 16:
                op = np.array(v).reshape(4, 4)
            else:
                op[:3, :3] = np.array(v).reshape(3, 3)
        elif c.tag == "lookat":
            vals = [_numbers(a.get(k, ""), where, f"lookat {k}") for k in ("origin", "target", "up")]
            if any(len(v) != 3 for v in vals[:2]) or len(vals[2]) not in (0, 3):
                raise SceneError("lookat needs origin, target (and up) of three numbers each", *where)
            op = look_at(*[np.array(v) for v in vals[:2]], np.array(vals[2] or [0.0, 1.0, 0.0]), where)
        else:
            raise SceneError(f"unsupported transform element <{c.tag}> (use lookat, matrix, translate, rotate, "
                             "scale)", *where)
        m = op @ m
    return m


def rotation(axis: np.ndarray, degrees: float) -> np.ndarray:
    """4x4 rotation by `degrees` about `axis` (right-handed, as Mitsuba's Transform4f.rotate)."""
    x, y, z = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    r = np.eye(4)
    r[:3, :3] = [[c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
                 [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
                 [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)]]
    return r


def look_at(origin, target, up, where=("<dict>", None)) -> np.ndarray:
    """Mitsuba's look_at: columns left, up, direction and origin."""
    d = target - origin
    left = np.cross(up, d)
    if not (np.linalg.norm(d) > 0 and np.linalg.norm(left) > 0):
        raise SceneError("lookat: target equals origin, or up is parallel to the view direction", *where)
    d /= np.linalg.norm(d)
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, origin
    return m


def _xml_nodes(path: str) -> Node:
    root = _parse_xml(path)
    params: dict[str, str] = {}

    def subst(text: str, where) -> str:
        def one(m):
            if m.group(1) not in params:
                raise SceneError(f"undefined parameter ${m.group(1)} (declare it with <default>)", *where)
            return params[m.group(1)]
        return re.sub(r"\$([A-Za-z_][A-Za-z0-9_]*)", one, text)

    def plugin(e: _Elem) -> Node:
        where = (path, e.line)
        a = {k: subst(v, where) for k, v in e.attrs.items()}
        if e.tag != "scene" and "type" not in a:
            raise SceneError(f"<{e.tag}> needs a type", *where)
        node = Node(e.tag, a.get("type", "scene"), where, a.get("id"), a.get("name"))
        for c in e.children:
            cw = (path, c.line)
            ca = {k: subst(v, cw) for k, v in c.attrs.items()}
            if c.tag == "default" and e.tag == "scene":
                if "name" not in ca or "value" not in ca:
                    raise SceneError("<default> needs name and value", *cw)
                params.setdefault(ca["name"], ca["value"])
            elif c.tag in PLUGINS[1:]:
                node.children.append(plugin(c))
            elif c.tag == "ref":
                if "id" not in ca:
                    raise SceneError("<ref> needs an id", *cw)
                node.children.append(Node("ref", "ref", cw, ca["id"], ca.get("name")))
            elif c.tag in PROPERTIES:
                if "name" not in ca:
                    raise SceneError(f"<{c.tag}> needs a name", *cw)
                node.props[ca["name"]] = (_xml_value(c, ca, path, subst), cw)
            else:
                raise SceneError(f"unsupported element <{c.tag}> in <{e.tag}> (outside durer's Mitsuba subset)", *cw)
        return node

    return plugin(root)


def _xml_value(c: _Elem, a: dict, path: str, subst):
    where = (path, c.line)
    if c.tag == "transform":
        return _transform(c, path, subst)
    if c.tag in ("point", "vector"):
        return _xyz(_Elem(c.tag, a, c.line), where, f"{c.tag} {a['name']}")
    if "value" not in a:
        raise SceneError(f"<{c.tag} name=\"{a['name']}\"> needs a value", *where)
    v = a["value"]
    if c.tag == "float":
        return _num(v, where, a["name"])
    if c.tag == "integer":
        try:
            return int(v)
        except ValueError:
            raise SceneError(f"{a['name']}: not an integer: {v!r}", *where) from None
    if c.tag == "boolean":
        if v.lower() not in ("true", "false"):
            raise SceneError(f"{a['name']}: not a boolean (true/false): {v!r}", *where)
        return v.lower() == "true"
    if c.tag == "rgb":
        n = _numbers(v, where, a["name"])
        if len(n) not in (1, 3):
            raise SceneError(f"{a['name']}: rgb needs one or three numbers, got {len(n)}", *where)
        return np.array(n * 3 if len(n) == 1 else n)
    return v  # string


# --- dicts (mi.load_dict's structure) -----------------------------------------------------------------------------
def _dict_nodes(d: dict, tag: str = "scene", name: str | None = None, path: str = "<dict>") -> Node:
    if not isinstance(d, dict) or "type" not in d:
        raise SceneError(f"{name or 'scene'}: a plugin must be a dict with a 'type'", path)
    where = (path, None)
    t = d["type"]
    if tag == "scene" and t != "scene":
        raise SceneError(f"the root must have type 'scene', got {t!r}", path)
    node = Node(tag, t, where, d.get("id"), name)
    for k, v in d.items():
        if k in ("type", "id"):
            continue
        kw = (path, None)
        if isinstance(v, dict) and v.get("type") == "ref":
            node.children.append(Node("ref", "ref", kw, v.get("id"), k))
        elif isinstance(v, dict) and v.get("type") == "rgb":
            node.props[k] = (np.asarray(v.get("value"), dtype=np.float64).reshape(-1), kw)
        elif isinstance(v, dict):
            child_tag = _dict_tag(v["type"] if "type" in v else "", k, tag, path)
            child = _dict_nodes(v, child_tag, k, f"{path}/{k}" if path != "<dict>" else k)
            if child.id is None and tag == "scene":
                child.id = k  # mi.load_dict: top-level keys name objects that refs can use
            node.children.append(child)
        else:
            node.props[k] = (v, kw)
    return node


_DICT_TYPES = {
    "integrator": ("path", "aov"), "sensor": ("perspective",), "film": ("hdrfilm",),
    "rfilter": ("box", "tent", "gaussian"),
    "sampler": ("independent", "stratified", "multijitter", "orthogonal", "ldsampler"),
    "shape": ("obj", "ply", "rectangle", "cube", "sphere", "disk"),
    "bsdf": ("diffuse", "dielectric", "conductor", "roughconductor", "plastic", "roughplastic", "twosided"),
    "emitter": ("area", "point", "directional", "constant", "envmap"),
}


def _dict_tag(t: str, key: str, parent: str, path: str) -> str:
    """The plugin category of a dict entry, from its type (Mitsuba's dicts do not name the category)."""
    if parent == "sensor" and t in _DICT_TYPES["film"] + _DICT_TYPES["sampler"]:
        return "film" if t in _DICT_TYPES["film"] else "sampler"
    if parent == "film" and t in _DICT_TYPES["rfilter"]:
        return "rfilter"
    for tag in ("integrator", "sensor", "shape", "bsdf", "emitter"):
        if t in _DICT_TYPES[tag]:
            return tag
    raise SceneError(f"{key}: unsupported plugin type {t!r} (outside durer's Mitsuba subset)", path)


def load_mitsuba(path: str, mesh_path: list[str] | None = None) -> Scene:
    """Read a Mitsuba 3 XML scene (the subset in this module's docstring)."""
    root = _xml_nodes(path)
    return Builder(root, mesh_path, os.path.dirname(os.path.abspath(path))).build()


def load_dict(d: dict, mesh_path: list[str] | None = None) -> Scene:
    """The same scene from a Python dict of mi.load_dict's structure (transforms as 4x4 arrays or any object with
    a `.matrix`, such as Mitsuba's own), without importing Mitsuba."""
    return Builder(_dict_nodes(d), mesh_path, os.getcwd()).build()
