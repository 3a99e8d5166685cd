"""Mitsuba 3 XML property values: numbers, vectors, transforms and spectra, each read from an element's attributes
with its file:line for errors."""

from __future__ import annotations

import math
import re

import numpy as np

from ..errors import SceneError
from .spectra import spectrum_to_rgb


def numbers(text: str, where, what: str) -> list[float]:
    """A comma- or space-separated list of finite numbers."""
    try:
        out = [float(x) for x in re.split(r"[,\s]+", text.strip()) if x]
    except ValueError:
        raise SceneError(f"{what}: not a list of numbers: {text!r}", *where) from None
    if not all(math.isfinite(x) for x in out):
        raise SceneError(f"{what}: numbers must be finite: {text!r}", *where)
    return out


def number(text, where, what: str) -> float:
    """One finite number."""
    try:
        x = float(text)
    except (TypeError, ValueError):
        raise SceneError(f"{what}: not a number: {text!r}", *where) from None
    if not math.isfinite(x):
        raise SceneError(f"{what}: not a finite number: {text!r}", *where)
    return x


def xyz(tag: str, a: dict, where, what: str, default: float | None = None) -> np.ndarray:
    """Three numbers from value="x, y, z" (one number: all three) or x=, y=, z= (missing ones are `default`)."""
    if "value" in a:
        v = numbers(a["value"], where, what)
        if len(v) == 1:
            v = v * 3
    else:
        if default is None and not all(k in a for k in "xyz"):
            raise SceneError(f"<{tag}> needs x, y and z (or value)", *where)
        v = [number(a.get(k, default), where, what) for k in "xyz"]
    if len(v) != 3:
        raise SceneError(f"{what} needs three numbers, got {len(v)}", *where)
    return np.array(v, dtype=np.float64)


def transform(children: list, where_of, subst) -> np.ndarray:
    """The 4x4 matrix of a <transform>'s steps (translate, scale, rotate, matrix, lookat), each applied after the
    previous ones. `children` are (tag, attrs, line) elements; `where_of(line)` gives (file, line)."""
    m = np.eye(4)
    for c in children:
        where = where_of(c.line)
        a = {k: subst(v, where) for k, v in c.attrs.items()}
        if c.children:
            raise SceneError(f"<{c.tag}> in a transform takes no nested elements", *where)
        if c.tag == "translate":
            op = np.eye(4)
            op[:3, 3] = xyz(c.tag, a, where, "translate", 0.0)
        elif c.tag == "scale":
            op = np.diag(np.append(xyz(c.tag, a, where, "scale", 1.0), 1.0))
        elif c.tag == "rotate":
            axis = xyz(c.tag, a, where, "rotate axis", 0.0)
            if not np.linalg.norm(axis) > 0:
                raise SceneError("rotate needs a non-zero axis", *where)
            op = rotation(axis, number(a.get("angle"), where, "rotate angle"))
        elif c.tag == "matrix":
            v = numbers(a.get("value", ""), where, "matrix")
            if len(v) not in (9, 16):
                raise SceneError(f"matrix needs 16 (or 9) numbers, got {len(v)}", *where)
            op = np.eye(4)
            if len(v) == 16:
                op = np.array(v).reshape(4, 4)
            else:
                op[:3, :3] = np.array(v).reshape(3, 3)
        elif c.tag == "lookat":
            vals = [numbers(a.get(k, ""), where, f"lookat {k}") for k in ("origin", "target", "up")]
            if any(len(v) != 3 for v in vals[:2]) or len(vals[2]) not in (0, 3):
                raise SceneError("lookat needs origin, target (and up) of three numbers each", *where)
            op = look_at(*[np.array(v) for v in vals[:2]], np.array(vals[2] or [0.0, 1.0, 0.0]), where)
        else:
            raise SceneError(f"unsupported transform element <{c.tag}> (use lookat, matrix, translate, rotate, "
                             "scale)", *where)
        with np.errstate(over="ignore", invalid="ignore"):
            m = op @ m
    if not np.isfinite(m).all():
        raise SceneError("transform is not finite", *where_of(None))
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
    d = np.asarray(target, dtype=np.float64) - origin
    left = np.cross(up, d)
    if not (np.linalg.norm(d) > 0 and np.linalg.norm(left) > 0):
        raise SceneError("lookat: target equals origin, or up is parallel to the view direction", *where)
    d /= np.linalg.norm(d)
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, origin
    return m


# parameters whose spectra are not reflectances: Mitsuba does not clip them to [0, 1]
UNBOUNDED = ("eta", "k", "int_ior", "ext_ior")


def spectrum(a: dict, where, name: str, emitter: bool, read_text) -> np.ndarray | float:
    """A <spectrum>: value="v" (a constant), value="l1:v1, l2:v2, ..." (nm:value pairs) or filename= (a .spd file
    of such pairs, one a line), turned into RGB as Mitsuba's RGB variants do (io/spectra.py)."""
    if "type" in a:
        raise SceneError(f"unsupported spectrum plugin '{a['type']}' (durer reads value= and filename= spectra)",
                         *where)
    if ("value" in a) == ("filename" in a):
        raise SceneError(f"<spectrum name=\"{name}\"> needs a value or a filename (one of them)", *where)
    if "value" in a:
        text = a["value"]
        if ":" not in text:
            v = numbers(text, where, name)
            if len(v) != 1:
                raise SceneError(f"{name}: a constant spectrum is one number, got {len(v)}", *where)
            return v[0]
        pairs = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    else:
        lines = read_text(a["filename"], where).splitlines()
        pairs = [":".join(ln.split()) for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    w, v = [], []
    for p in pairs:
        parts = p.split(":")
        if len(parts) != 2:
            raise SceneError(f"{name}: spectrum entries are wavelength:value pairs, got {p!r}", *where)
        w.append(number(parts[0], where, name))
        v.append(number(parts[1], where, name))
    try:
        return spectrum_to_rgb(w, v, emitter=emitter, bounded=not emitter and name not in UNBOUNDED)
    except ValueError as e:
        raise SceneError(f"{name}: {e}", *where) from None
