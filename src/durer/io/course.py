"""Parser of the MIT 6.837 scene format (see shared/scenes/mit6837/FORMAT.md) into a durer Scene.

Every mistake is reported as a SceneError carrying the file and line, so the CLI can print `file:line: message`.
The top-level blocks may come in any order (some course files put Lights before Background); fields inside a block
may too. `MaterialIndex k` sets the current material for every object parsed after it, in nested groups as well,
as the course's parser does.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable

import numpy as np

from ..errors import SceneError
from ..scene import transforms as tf
from ..scene.cameras import FisheyeCamera, OrthographicCamera, PanoramaCamera, PerspectiveCamera
from ..scene.graph import Group, Scene, Transform
from ..scene.lights import DirectionalLight, PointLight
from ..scene.materials import PhongMaterial
from ..scene.shapes import Plane, Sphere, Triangle, TriangleMesh
from ..scene.textures import Checkerboard, Marble, Noise, Wood
from ..scene.validate import MAX_NESTING
from .files import find_mesh, mesh_search_path
from .obj import read_obj

_TOKEN = re.compile(r"[{}]|[^\s{}]+")
_OBJECTS = ("Group", "Transform", "Sphere", "Plane", "Triangle", "TriangleMesh")


class _Tokens:
    """A token stream that knows each token's line, for error messages."""

    def __init__(self, text: str, path: str):
        self.path = path
        self.items: list[tuple[str, int]] = []
        for lineno, line in enumerate(text.splitlines(), 1):
            self.items.extend((m.group(0), lineno) for m in _TOKEN.finditer(line))
        self.pos = 0
        self.last_line = self.items[-1][1] if self.items else 1

    def error(self, message: str, line: int | None = None) -> SceneError:
        if line is None:
            line = self.items[self.pos][1] if self.pos < len(self.items) else self.last_line
        return SceneError(message, self.path, line)

    def at_end(self) -> bool:
        return self.pos >= len(self.items)

    def peek(self) -> str | None:
        return self.items[self.pos][0] if self.pos < len(self.items) else None

    def line(self) -> int:
        return self.items[self.pos][1] if self.pos < len(self.items) else self.last_line

    def next(self, what: str) -> str:
        if self.pos >= len(self.items):
            raise self.error(f"unexpected end of file: expected {what}")
        tok = self.items[self.pos][0]
        self.pos += 1
        return tok

    def expect(self, word: str, context: str) -> None:
        line = self.line()
        tok = self.next(f"'{word}' {context}")
        if tok != word:
            raise self.error(f"expected '{word}' {context}, got '{tok}'", line)

    def number(self, what: str) -> float:
        line = self.line()
        tok = self.next(f"a number for {what}")
        try:
            value = float(tok)
        except ValueError:
            raise self.error(f"expected a number for {what}, got '{tok}'", line) from None
        if not np.isfinite(value):
            raise self.error(f"{what} must be finite, got '{tok}'", line)
        return value

    def integer(self, what: str) -> int:
        line = self.line()
        tok = self.next(f"an integer for {what}")
        try:
            return int(tok)
        except ValueError:
            raise self.error(f"expected an integer for {what}, got '{tok}'", line) from None

    def vec3(self, what: str) -> np.ndarray:
        return np.array([self.number(f"{what} (x)"), self.number(f"{what} (y)"), self.number(f"{what} (z)")])


def _fields(tokens: _Tokens, block: str, spec: dict[str, Callable[[_Tokens, str], object]],
            required: tuple[str, ...], open_line: int) -> tuple[dict[str, object], dict[str, int]]:
    """Parse `key value` pairs up to the closing brace; each key at most once; report unknown and missing ones."""
    values: dict[str, object] = {}
    lines: dict[str, int] = {}
    while True:
        if tokens.at_end():
            raise tokens.error(f"unexpected end of file: '{block} {{' opened at line {open_line} is not closed")
        line = tokens.line()
        key = tokens.next("a field name")
        if key == "}":
            break
        if key not in spec:
            raise tokens.error(f"unknown field '{key}' in {block} (expected one of: {', '.join(spec)})", line)
        if key in values:
            raise tokens.error(f"field '{key}' given twice in {block}", line)
        values[key] = spec[key](tokens, key)
        lines[key] = line
    missing = [k for k in required if k not in values]
    if missing:
        raise tokens.error(f"{block} is missing '{missing[0]}'", open_line)
    return values, lines


def _vec3(t: _Tokens, key: str) -> np.ndarray:
    return t.vec3(key)


def _num(t: _Tokens, key: str) -> float:
    return t.number(key)


def _int(t: _Tokens, key: str) -> int:
    return t.integer(key)


def _word(t: _Tokens, key: str) -> str:
    tok = t.next(f"a value for {key}")
    if tok in "{}":
        raise t.error(f"expected a value for {key}, got '{tok}'")
    return tok


class _Parser:
    def __init__(self, text: str, path: str, mesh_path: list[str]):
        self.t = _Tokens(text, path)
        self.path = path
        self.mesh_path = mesh_path
        self.num_materials: int | None = None
        self.current_material: int | None = None
        self.depth = 0  # Groups and Transforms open around the object being read (limited to MAX_NESTING)

    # --- top level ---------------------------------------------------------------------------------------
    def scene(self) -> Scene:
        t = self.t
        found: dict[str, int] = {}
        camera = group = None
        lights: list | None = None
        materials: list = []
        background, ambient = np.zeros(3), np.zeros(3)
        handlers = ("OrthographicCamera", "PerspectiveCamera", "FisheyeCamera", "PanoramaCamera",
                    "Background", "Lights", "Materials", "Group")
        while not t.at_end():
            line = t.line()
            kw = t.next("a block")
            if kw not in handlers:
                if kw == "}":
                    raise t.error("unexpected '}' (no block is open)", line)
                raise t.error(f"unknown keyword '{kw}' at top level (expected one of: {', '.join(handlers)})", line)
            kind = "camera" if kw.endswith("Camera") else kw
            if kind in found:
                raise t.error(f"second {kind} block (the first is at line {found[kind]})", line)
            found[kind] = line
            t.expect("{", f"after {kw}")
            if kind == "camera":
                camera = self.camera(kw, line)
            elif kw == "Background":
                background, ambient = self.background(line)
            elif kw == "Lights":
                lights = self.lights(line)
            elif kw == "Materials":
                if "Group" in found:
                    raise t.error("Materials must come before the Group that uses them", line)
                materials = self.materials(line)
            else:
                group = self.group(line)
        if camera is None:
            raise t.error("the scene has no camera (OrthographicCamera or PerspectiveCamera)", 1)
        if group is None:
            raise t.error("the scene has no Group of objects", t.last_line)
        return Scene(camera=camera, group=group, materials=materials or [PhongMaterial()], lights=lights,
                     background_color=background, ambient_light=ambient, source=self.path)

    def camera(self, kind: str, line: int):
        t = self.t
        spec = {"center": _vec3, "direction": _vec3, "up": _vec3}
        extra = {"OrthographicCamera": "size", "PerspectiveCamera": "angle", "FisheyeCamera": "angle"}.get(kind)
        if extra:
            spec[extra] = _num
        v, lines = _fields(t, kind, spec, tuple(spec), line)
        cls = {"OrthographicCamera": OrthographicCamera, "PerspectiveCamera": PerspectiveCamera,
               "FisheyeCamera": FisheyeCamera, "PanoramaCamera": PanoramaCamera}[kind]
        try:
            return cls(**v)
        except ValueError as e:
            msg = str(e)
            key = next((k for k in ("size", "angle", "up", "direction") if k in msg), None)
            raise t.error(msg, lines.get(key, line)) from None

    def background(self, line: int):
        v, _ = _fields(self.t, "Background", {"color": _vec3, "ambientLight": _vec3}, ("color",), line)
        return v["color"], v.get("ambientLight", np.zeros(3))

    def _count_block(self, block: str, count_key: str, line: int, item: Callable[[str, int], object],
                     kinds: tuple[str, ...]) -> list:
        t = self.t
        t.expect(count_key, f"at the start of {block}")
        n = t.integer(count_key)
        if n < 0:
            raise t.error(f"{count_key} must not be negative, got {n}")
        items = []
        while True:
            if t.at_end():
                raise t.error(f"unexpected end of file: '{block} {{' opened at line {line} is not closed")
            iline = t.line()
            kw = t.next("an item")
            if kw == "}":
                break
            if kw not in kinds:
                raise t.error(f"unknown keyword '{kw}' in {block} (expected one of: {', '.join(kinds)})", iline)
            if len(items) == n:
                raise t.error(f"{block} declares {count_key} {n} but has more than {n}", iline)
            t.expect("{", f"after {kw}")
            items.append(item(kw, iline))
        if len(items) != n:
            raise t.error(f"{block} declares {count_key} {n} but has {len(items)}", line)
        return items

    def lights(self, line: int) -> list:
        return self._count_block("Lights", "numLights", line, self.light, ("DirectionalLight", "PointLight"))

    def light(self, kind: str, line: int):
        t = self.t
        if kind == "DirectionalLight":
            v, lines = _fields(t, kind, {"direction": _vec3, "color": _vec3}, ("direction", "color"), line)
            if not v["direction"].any():
                raise t.error("light direction has zero length", lines["direction"])
            return DirectionalLight(**v)

        def attenuation(tt: _Tokens, key: str):
            return (tt.number("attenuation (constant)"), tt.number("attenuation (linear)"),
                    tt.number("attenuation (quadratic)"))

        v, lines = _fields(t, kind, {"position": _vec3, "color": _vec3, "attenuation": attenuation},
                           ("position", "color"), line)
        att = v.get("attenuation", (1.0, 0.0, 0.0))
        if min(att) < 0 or sum(att) <= 0:
            raise t.error("attenuation coefficients must be non-negative and not all zero", lines["attenuation"])
        return PointLight(position=v["position"], color=v["color"], attenuation=att)

    def materials(self, line: int) -> list:
        t = self.t
        t.expect("numMaterials", "at the start of Materials")
        self.num_materials = n = t.integer("numMaterials")
        if n < 0:
            raise t.error(f"numMaterials must not be negative, got {n}")
        self.t.pos -= 2  # let _count_block read the count again
        kinds = ("Material", "PhongMaterial", "Checkerboard", "Noise", "Marble", "Wood")
        mats = self._count_block("Materials", "numMaterials", line, self.material, kinds)
        self._check_texture_cycles(mats, line)
        return mats

    def material(self, kind: str, line: int):
        t = self.t
        if kind in ("Material", "PhongMaterial"):
            spec = {"diffuseColor": _vec3, "specularColor": _vec3, "exponent": _num, "reflectiveColor": _vec3,
                    "transparentColor": _vec3, "indexOfRefraction": _num}
            v, lines = _fields(t, kind, spec, (), line)
            if "indexOfRefraction" in v and not v["indexOfRefraction"] > 0:
                raise t.error("indexOfRefraction must be positive", lines["indexOfRefraction"])
            if v.get("exponent", 0) < 0:
                raise t.error(f"exponent must not be negative, got {v['exponent']:g}", lines["exponent"])
            names = {"diffuseColor": "diffuse_color", "specularColor": "specular_color", "exponent": "exponent",
                     "reflectiveColor": "reflective_color", "transparentColor": "transparent_color",
                     "indexOfRefraction": "index_of_refraction"}
            return PhongMaterial(**{names[k]: val for k, val in v.items()})
        # a solid texture: [Transform { ... }] materialIndex a materialIndex b [octaves] [frequency] [amplitude]
        matrix = np.eye(4)
        if t.peek() == "Transform":
            tline = t.line()
            t.next("Transform")
            t.expect("{", "after Transform")
            matrix = self.transformations(tline, allow_object=False)[0]
        indices = []
        for _ in range(2):
            t.expect("materialIndex", f"in {kind}")
            iline = t.line()
            k = t.integer("materialIndex")
            if not 0 <= k < (self.num_materials or 0):
                raise t.error(f"materialIndex {k} out of range (there are {self.num_materials} materials)", iline)
            indices.append(k)
        spec: dict = {}
        if kind != "Checkerboard":
            spec["octaves"] = _int
        if kind in ("Marble", "Wood"):
            spec.update(frequency=_num, amplitude=_num)
        v, lines = _fields(t, kind, spec, (), line)
        if v.get("octaves", 1) < 0:
            raise t.error("octaves must not be negative", lines["octaves"])
        cls = {"Checkerboard": Checkerboard, "Noise": Noise, "Marble": Marble, "Wood": Wood}[kind]
        tex = cls(material1=indices[0], material2=indices[1], matrix=matrix, **v)
        tex._line = line  # for the cycle check's message
        return tex

    def _check_texture_cycles(self, mats: list, line: int) -> None:
        """A texture blends two materials by index; following those indices must end at Phong materials. Walked
        with an explicit stack (a chain of thousands of textures must not overflow Python's)."""
        done: set[int] = set()  # materials whose every blend ends at Phong materials
        for root in range(len(mats)):
            on_path: set[int] = set()
            stack: list[tuple[int, int]] = [(root, 0)]  # (material, how many of its two blends were followed)
            while stack:
                i, k = stack.pop()
                m = mats[i]
                if isinstance(m, PhongMaterial) or i in done:
                    continue
                if k == 0:
                    if i in on_path:
                        raise self.t.error(f"material {i} blends itself (a cycle of material indices)",
                                           getattr(m, "_line", line))
                    on_path.add(i)
                if k < 2:
                    stack.append((i, k + 1))
                    stack.append(((m.material1, m.material2)[k], 0))
                else:
                    on_path.discard(i)
                    done.add(i)

    # --- objects ---------------------------------------------------------------------------------------------
    def group(self, line: int) -> Group:
        t = self.t
        t.expect("numObjects", "at the start of Group")
        n = t.integer("numObjects")
        if n < 0:
            raise t.error(f"numObjects must not be negative, got {n}")
        objects = []
        while True:
            if t.at_end():
                raise t.error(f"unexpected end of file: 'Group {{' opened at line {line} is not closed")
            iline = t.line()
            kw = t.next("an object")
            if kw == "}":
                break
            if kw == "MaterialIndex":
                k = t.integer("MaterialIndex")
                count = self.num_materials or 0
                if not 0 <= k < count:
                    raise t.error(f"MaterialIndex {k} out of range (there are {count} materials)", iline)
                self.current_material = k
                continue
            if kw not in _OBJECTS:
                raise t.error(f"unknown keyword '{kw}' in Group (expected MaterialIndex or one of: "
                              f"{', '.join(_OBJECTS)})", iline)
            if len(objects) == n:
                raise t.error(f"Group declares numObjects {n} but has more than {n} objects", iline)
            objects.append(self.object(kw, iline))
        if len(objects) != n:
            raise t.error(f"Group declares numObjects {n} but has {len(objects)} objects", line)
        return Group(objects)

    def object(self, kind: str, line: int):
        t = self.t
        t.expect("{", f"after {kind}")
        if kind in ("Group", "Transform"):
            return self.nested(kind, line)
        material = self._material_for(kind, line)
        if kind == "Sphere":
            v, lines = _fields(t, kind, {"center": _vec3, "radius": _num}, ("center", "radius"), line)
            if not v["radius"] > 0:
                raise t.error(f"sphere radius must be positive, got {v['radius']:g}", lines["radius"])
            return Sphere(v["center"], v["radius"], material)
        if kind == "Plane":
            v, lines = _fields(t, kind, {"normal": _vec3, "offset": _num}, ("normal", "offset"), line)
            if not v["normal"].any():
                raise t.error("plane normal has zero length", lines["normal"])
            return Plane(v["normal"], v["offset"], material)
        if kind == "Triangle":
            keys = ("vertex0", "vertex1", "vertex2")
            v, _ = _fields(t, kind, dict.fromkeys(keys, _vec3), keys, line)
            return Triangle(v["vertex0"], v["vertex1"], v["vertex2"], material)
        # TriangleMesh
        v, lines = _fields(t, kind, {"obj_file": _word}, ("obj_file",), line)
        try:
            path = find_mesh(v["obj_file"], self.path, self.mesh_path)
        except SceneError as e:
            raise t.error(e.message, lines["obj_file"]) from None
        if path.lower().endswith(".obj"):
            vertices, faces = read_obj(path)  # the course's OBJ subset, with file:line errors
        else:  # any other model format trimesh reads (PLY, STL, OFF, glTF, ...)
            from .models import read_mesh

            vertices, faces = read_mesh(path)
        return TriangleMesh(vertices, faces, material, source=path)

    def nested(self, kind: str, line: int) -> Group | Transform:
        """A Group or Transform inside another: the parser recurses, so nesting deeper than MAX_NESTING levels
        is a SceneError at the level that passes it (no scene needs it; Python's stack would overflow)."""
        t = self.t
        if self.depth >= MAX_NESTING:
            raise t.error(f"Groups and Transforms nested more than {MAX_NESTING} levels deep", line)
        self.depth += 1
        try:
            if kind == "Group":
                return self.group(line)
            matrix, obj = self.transformations(line, allow_object=True)
            try:
                return Transform(matrix, obj)
            except ValueError as e:
                raise t.error(str(e), line) from None
        finally:
            self.depth -= 1

    def _material_for(self, kind: str, line: int) -> int:
        if self.current_material is not None:
            return self.current_material
        if not self.num_materials:
            raise self.t.error(f"{kind} has no material: the scene defines no Materials", line)
        return 0

    def transformations(self, line: int, allow_object: bool):
        """Transformations composed in file order (M = M @ T), then (if allowed) exactly one object and '}'."""
        t = self.t
        m = np.eye(4)
        obj = None
        while True:
            if t.at_end():
                raise t.error(f"unexpected end of file: 'Transform {{' opened at line {line} is not closed")
            iline = t.line()
            kw = t.next("a transformation")
            if kw == "}":
                break
            if obj is not None:
                raise t.error(f"a Transform holds one object; found '{kw}' after it", iline)
            if kw == "Scale":
                s = t.vec3("Scale")
                if np.any(s == 0):
                    raise t.error("Scale by zero makes the transform singular", iline)
                m = m @ tf.scale(s)
            elif kw == "UniformScale":
                s = t.number("UniformScale")
                if s == 0:
                    raise t.error("UniformScale by zero makes the transform singular", iline)
                m = m @ tf.scale(s)
            elif kw == "Translate":
                m = m @ tf.translate(t.vec3("Translate"))
            elif kw in ("XRotate", "YRotate", "ZRotate"):
                axis = {"X": (1, 0, 0), "Y": (0, 1, 0), "Z": (0, 0, 1)}[kw[0]]
                m = m @ tf.rotate(axis, t.number(kw))
            elif kw == "Rotate":
                t.expect("{", "after Rotate")
                axis = t.vec3("Rotate axis")
                angle = t.number("Rotate angle")
                t.expect("}", "to close Rotate")
                if not axis.any():
                    raise t.error("rotation axis has zero length", iline)
                m = m @ tf.rotate(axis, angle)
            elif kw == "Matrix":
                t.expect("{", "after Matrix")
                values = [t.number(f"Matrix entry {i + 1}") for i in range(16)]
                t.expect("}", "to close Matrix (it takes 16 numbers, row by row)")
                mat = np.array(values).reshape(4, 4)
                if abs(np.linalg.det(mat[:3, :3])) < 1e-12:
                    raise t.error("Matrix is singular", iline)
                m = m @ mat
            elif allow_object and kw in _OBJECTS:
                obj = self.object(kw, iline)
            else:
                expected = "Scale, UniformScale, Translate, XRotate, YRotate, ZRotate, Rotate, Matrix"
                if allow_object:
                    expected += " or an object"
                raise t.error(f"unknown keyword '{kw}' in Transform (expected {expected})", iline)
        if allow_object and obj is None:
            raise t.error("Transform has no object", line)
        return m, obj


def load_course_scene(path: str | os.PathLike, mesh_path: list[str] | None = None) -> Scene:
    """Parse a course scene file; raises SceneError(`file:line: message`) on any mistake.

    Mesh files are looked up next to the scene, then in the working directory, then in `mesh_search_path`.
    """
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError as e:
        raise SceneError(f"cannot read scene file: {e.strerror}", path) from None
    return _Parser(text, path, mesh_search_path(mesh_path)).scene()
