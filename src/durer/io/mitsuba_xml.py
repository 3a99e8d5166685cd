"""Mitsuba 3's XML scene format -> the plugin tree of io/mitsuba.py (Node), with every element's file:line.

The format in full: <scene version>, plugins (integrator, sensor, film, rfilter, sampler, shape, bsdf, emitter,
texture), properties (float, integer, boolean, string, rgb, spectrum, point, vector, transform), <ref>, <default>
(anywhere; the first declaration of a name wins, so parameters given to the loader override it), $name in every
attribute, <path> (a folder searched for files, relative to the file that names it, newest first, as Mitsuba's file
resolver) and <include> (another scene file whose children take its place). Participating media are out of
durer's scope and say so.
"""

from __future__ import annotations

import os
import re
import xml.parsers.expat
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError
from . import mitsuba_values as V
from .files import read_bytes
from .mitsuba_tree import Node

MAX_DEPTH = 100  # elements nested, includes inside includes, references followed: beyond this a scene is an error
PLUGINS = ("integrator", "sensor", "film", "rfilter", "sampler", "shape", "bsdf", "emitter", "texture")
PROPERTIES = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform")
MEDIA = ("medium", "phase", "volume")


@dataclass
class Elem:
    """One XML element as parsed: tag, attributes, line and children (its file is the Reader's current one)."""

    tag: str
    attrs: dict
    line: int
    children: list = field(default_factory=list)


def parse_file(path: str) -> Elem:
    """The root element of an XML file; malformed XML or nesting beyond MAX_DEPTH is a SceneError."""
    data = read_bytes(path, "scene file")
    parser = xml.parsers.expat.ParserCreate()
    stack: list[Elem] = [Elem("#document", {}, 1)]

    def start(tag, attrs):
        e = Elem(tag, dict(attrs), parser.CurrentLineNumber)
        if len(stack) > MAX_DEPTH:
            raise SceneError(f"elements nested more than {MAX_DEPTH} deep", path, e.line)
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
    if len(root) != 1:
        raise SceneError("an XML file has exactly one root element", path, root[1].line if root else 1)
    return root[0]


class Reader:
    """Reads one scene file and what it includes: parameters, the file resolver's folders, the plugin tree."""

    def __init__(self, params: dict | None = None):
        self.params = {str(k): str(v) for k, v in (params or {}).items()}
        self.search: list[str] = []    # <path> folders, newest first, then the scene's folder
        self.including: list[str] = []

    def read(self, path: str):
        path = os.path.abspath(path)
        self.search = [os.path.dirname(path)]
        self.including = [path]
        root = parse_file(path)
        if root.tag != "scene":
            raise SceneError("the root element must be <scene>", path, root.line)
        node = Node("scene", "scene", (path, root.line))
        self._version(root, path)
        self._children(root, node, path, 1, False)
        return node

    def resolve(self, filename: str) -> str:
        """Mitsuba's file resolver: an absolute path, else the first of the search folders that has it."""
        if os.path.isabs(filename):
            return filename
        for d in self.search:
            if os.path.exists(os.path.join(d, filename)):
                return os.path.join(d, filename)
        return os.path.join(self.search[-1], filename)

    def subst(self, text: str, where) -> str:
        def one(m):
            if m.group(1) not in self.params:
                raise SceneError(f"undefined parameter ${m.group(1)} (declare it with <default>)", *where)
            return self.params[m.group(1)]
        return re.sub(r"\$([A-Za-z_][A-Za-z0-9_]*)", one, text)

    def _version(self, e: Elem, path: str) -> None:
        v = self.subst(e.attrs.get("version", "3.0.0"), (path, e.line))
        m = re.fullmatch(r"(\d+)\.(\d+)\.(\d+)", v.strip())
        if m is None:
            raise SceneError(f"version must be major.minor.patch, got {v!r}", path, e.line)
        if int(m.group(1)) < 2:
            raise SceneError(f"version {v}: Mitsuba 0.x scenes (camelCase parameters) are not read; durer reads "
                             "Mitsuba 2 and 3 scenes (version 2.0.0 or later)", path, e.line)

    def _plugin(self, e: Elem, path: str, depth: int, emitter: bool):
        where = (path, e.line)
        a = {k: self.subst(v, where) for k, v in e.attrs.items()}
        if "type" not in a:
            raise SceneError(f"<{e.tag}> needs a type", *where)
        node = Node(e.tag, a["type"], where, a.get("id"), a.get("name"))
        self._children(e, node, path, depth, emitter or e.tag == "emitter")
        return node

    def _children(self, e: Elem, node, path: str, depth: int, emitter: bool) -> None:
        for c in e.children:
            cw = (path, c.line)
            ca = {k: self.subst(v, cw) for k, v in c.attrs.items()}
            if c.tag == "default":
                if "name" not in ca or "value" not in ca:
                    raise SceneError("<default> needs name and value", *cw)
                self.params.setdefault(ca["name"], ca["value"])
            elif c.tag == "path":
                if "value" not in ca:
                    raise SceneError("<path> needs a value (a folder)", *cw)
                folder = ca["value"] if os.path.isabs(ca["value"]) else \
                    os.path.join(os.path.dirname(path), ca["value"])
                self.search.insert(0, os.path.normpath(folder))
            elif c.tag == "include":
                self._include(c, ca, node, cw, depth, emitter)
            elif c.tag in PLUGINS:
                node.children.append(self._plugin(c, path, depth + 1, emitter))
            elif c.tag == "ref":
                if "id" not in ca:
                    raise SceneError("<ref> needs an id", *cw)
                node.children.append(Node("ref", "ref", cw, ca["id"], ca.get("name")))
            elif c.tag in PROPERTIES:
                if "name" not in ca:
                    raise SceneError(f"<{c.tag}> needs a name", *cw)
                if ca["name"] in node.props:
                    raise SceneError(f"parameter '{ca['name']}' given twice (first at line "
                                     f"{node.props[ca['name']][1][1]})", *cw)
                node.props[ca["name"]] = (self._value(c, ca, path, emitter), cw)
            elif c.tag in MEDIA or c.tag == "scene":
                what = "participating media" if c.tag in MEDIA else "a nested <scene>"
                raise SceneError(f"unsupported element <{c.tag}>: {what} outside durer's scope", *cw)
            else:
                raise SceneError(f"unknown element <{c.tag}> in <{e.tag}>", *cw)

    def _include(self, c: Elem, ca: dict, node, where, depth: int, emitter: bool) -> None:
        if "filename" not in ca:
            raise SceneError("<include> needs a filename", *where)
        target = os.path.abspath(self.resolve(ca["filename"]))
        if not os.path.isfile(target):
            raise SceneError(f"included file not found: {ca['filename']}", *where)
        if target in self.including:
            raise SceneError(f"{ca['filename']} includes itself", *where)
        if len(self.including) > MAX_DEPTH:
            raise SceneError(f"includes nested more than {MAX_DEPTH} deep", *where)
        root = parse_file(target)
        self.including.append(target)
        if root.tag == "scene":
            self._version(root, target)
            self._children(root, node, target, depth, emitter)
        else:
            wrapper = Elem("#include", {}, root.line, [root])
            self._children(wrapper, node, target, depth, emitter)
        self.including.pop()

    def _value(self, c: Elem, a: dict, path: str, emitter: bool):
        where = (path, c.line)
        name = a["name"]
        if c.tag == "transform":
            return V.transform(c.children, lambda line: (path, c.line if line is None else line), self.subst)
        if c.children:
            raise SceneError(f"<{c.tag} name=\"{name}\"> takes no nested elements", *where)
        if c.tag in ("point", "vector"):
            return V.xyz(c.tag, a, where, f"{c.tag} {name}")
        if c.tag == "spectrum":
            return V.spectrum(a, where, name, emitter, self._text)
        if "value" not in a:
            raise SceneError(f"<{c.tag} name=\"{name}\"> needs a value", *where)
        v = a["value"]
        if c.tag == "float":
            return V.number(v, where, name)
        if c.tag == "integer":
            try:
                return int(v)
            except ValueError:
                raise SceneError(f"{name}: not an integer: {v!r}", *where) from None
        if c.tag == "boolean":
            if v.strip().lower() not in ("true", "false"):
                raise SceneError(f"{name}: not a boolean (true/false): {v!r}", *where)
            return v.strip().lower() == "true"
        if c.tag == "rgb":
            n = V.numbers(v, where, name)
            if len(n) not in (1, 3):
                raise SceneError(f"{name}: rgb needs one or three numbers, got {len(n)}", *where)
            return np.array(n * 3 if len(n) == 1 else n)
        return v  # string

    def _text(self, filename: str, where) -> str:
        path = self.resolve(filename)
        if not os.path.isfile(path):
            raise SceneError(f"spectrum file not found: {filename}", *where)
        try:
            return read_bytes(path, "spectrum file").decode("utf-8")
        except UnicodeDecodeError:
            raise SceneError(f"{filename}: not a text file of wavelength value pairs", *where) from None
