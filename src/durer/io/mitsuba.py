"""Mitsuba 3 scenes: the XML format (io/mitsuba_xml.py) and `load_dict` (the same structure as a Python dict, like
mi.load_dict), turned into a durer Scene by io/mitsuba_scene.py. What durer does not render is a SceneError
`file:line: ...` naming the element or parameter, never a silent difference. README.md's Mitsuba table lists every
plugin and parameter durer reads and the known differences.
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

from ..errors import SceneError
from ..scene.graph import Scene
from .mitsuba_scene import Builder
from .mitsuba_tree import Node
from .mitsuba_values import look_at, rotation  # noqa: F401  (re-exported: Mitsuba's transform helpers)
from .mitsuba_xml import MAX_DEPTH, Reader


# --- dicts (mi.load_dict's structure) -----------------------------------------------------------------------------
def _dict_nodes(d: dict, tag: str = "scene", name: str | None = None, path: str = "<dict>", depth: int = 0) -> Node:
    if not isinstance(d, dict) or "type" not in d:
        raise SceneError(f"{name or 'scene'}: a plugin must be a dict with a 'type'", path)
    if depth > MAX_DEPTH:
        raise SceneError(f"plugins nested more than {MAX_DEPTH} deep", path)
    where = (path, None)
    t = d["type"]
    if tag == "scene" and t != "scene":
        raise SceneError(f"the root must have type 'scene', got {t!r}", path)
    node = Node(tag, str(t), where, d.get("id"), name)
    for k, v in d.items():
        if k in ("type", "id"):
            continue
        k = str(k)
        kw = (path, None)
        if isinstance(v, dict) and v.get("type") == "ref":
            node.children.append(Node("ref", "ref", kw, v.get("id"), k))
        elif isinstance(v, dict) and v.get("type") in ("rgb", "spectrum"):
            node.props[k] = (_dict_colour(v, k, path), kw)
        elif isinstance(v, dict):
            child_tag = _dict_tag(v["type"] if "type" in v else "", k, tag, path)
            child = _dict_nodes(v, child_tag, k, f"{path}/{k}" if path != "<dict>" else k, depth + 1)
            if child.id is None and tag == "scene":
                child.id = k  # mi.load_dict: top-level keys name objects that refs can use
            node.children.append(child)
        else:
            node.props[k] = (v, kw)
    return node


def _dict_colour(v: dict, key: str, path: str):
    """{'type': 'rgb', 'value': [r, g, b]} or {'type': 'spectrum', 'value': x or [(nm, value), ...]}."""
    value = v.get("value")
    try:
        if v["type"] == "spectrum" and not np.isscalar(value):
            from .spectra import spectrum_to_rgb

            w, x = np.asarray(value, dtype=np.float64).reshape(-1, 2).T
            return spectrum_to_rgb(w, x)
        a = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError) as e:
        raise SceneError(f"{key}: not a colour: {e}", path) from None
    if a.size not in (1, 3) or not np.isfinite(a).all():
        raise SceneError(f"{key}: a colour is one or three finite numbers", path)
    return a


_DICT_TYPES = {
    "integrator": ("path", "direct", "moment", "aov", "volpath", "volpathmis", "prb", "ptracer"),
    "sensor": ("perspective", "thinlens", "orthographic"), "film": ("hdrfilm", "specfilm"),
    "rfilter": ("box", "tent", "gaussian", "mitchell", "catmullrom", "lanczos"),
    "sampler": ("independent", "stratified", "multijitter", "orthogonal", "ldsampler"),
    "shape": ("obj", "ply", "serialized", "rectangle", "cube", "sphere", "disk", "cylinder", "sdfgrid", "shapegroup",
              "instance"),
    "bsdf": ("diffuse", "dielectric", "thindielectric", "roughdielectric", "conductor", "roughconductor", "plastic",
             "roughplastic", "twosided", "blendbsdf", "mask", "bumpmap", "normalmap", "principled",
             "principledthin", "null"),
    "emitter": ("area", "point", "spot", "directional", "constant", "envmap"),
    "texture": ("bitmap", "checkerboard"),
}


def _dict_tag(t: str, key: str, parent: str, path: str) -> str:
    """The plugin category of a dict entry, from its type (Mitsuba's dicts do not name the category)."""
    if parent == "sensor" and t in _DICT_TYPES["film"] + _DICT_TYPES["sampler"]:
        return "film" if t in _DICT_TYPES["film"] else "sampler"
    if parent == "film" and t in _DICT_TYPES["rfilter"]:
        return "rfilter"
    for tag in ("integrator", "sensor", "shape", "bsdf", "emitter", "texture"):
        if t in _DICT_TYPES[tag]:
            return tag
    raise SceneError(f"{key}: unsupported plugin type {t!r} (outside durer's Mitsuba subset)", path)


def load_mitsuba(path: str, mesh_path: list[str] | None = None, params: dict | None = None) -> Scene:
    """Read a Mitsuba 3 XML scene; `params` set its $parameters (as mi.load_file's keyword arguments do),
    overriding the file's <default>s."""
    reader = Reader(params)
    with _one_line():
        root = reader.read(path)
        return Builder(root, mesh_path, os.path.dirname(os.path.abspath(path)), reader.search).build()


def load_dict(d: dict, mesh_path: list[str] | None = None) -> Scene:
    """The same scene from a Python dict of mi.load_dict's structure (transforms as 4x4 arrays or any object with
    a `.matrix`, such as Mitsuba's own), without importing Mitsuba."""
    with _one_line():
        return Builder(_dict_nodes(d), mesh_path, os.getcwd()).build()


@contextlib.contextmanager
def _one_line():
    """Messages quote the user's ids, names and values, which may hold line breaks: escape them, so that every
    error stays one line."""
    try:
        yield
    except SceneError as e:
        if not any(c in e.message for c in "\r\n\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"):
            raise
        text = "".join(c if c.isprintable() else c.encode("unicode_escape").decode() for c in e.message)
        raise SceneError(text, e.path, e.line) from None
