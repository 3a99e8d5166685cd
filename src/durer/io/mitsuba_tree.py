"""The plugin tree both Mitsuba readers produce (XML in io/mitsuba_xml.py, dicts in io/mitsuba.py) and typed access
to a plugin's parameters: a value of the wrong kind (an <rgb> where an integer belongs, a transform for an index of
refraction) is a SceneError at the parameter's file:line, never a Python exception."""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError


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


def call(node: Node, fn, *args, **kw):
    """Run a description constructor, turning its ValueError (or TypeError) into a SceneError at the node."""
    try:
        return fn(*args, **kw)
    except (ValueError, TypeError) as e:
        raise node.error(f"{node.tag} '{node.type}': {e}") from None


def _is_number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def _array(v) -> np.ndarray | None:
    """v as a float64 array if it is numbers (a list, an array, or an object with .matrix such as Mitsuba's)."""
    if isinstance(v, (str, bytes, dict, bool, np.bool_)) or v is None:
        return None
    try:
        a = np.asarray(getattr(v, "matrix", v), dtype=np.float64)
    except (TypeError, ValueError):
        return None
    return a if np.isfinite(a).all() else None


class Props:
    """A plugin's parameters, taken one by one with the kind each must have; whatever is left at the end is outside
    the subset (`done`)."""

    def __init__(self, node: Node):
        self.node = node
        self.left = dict(node.props)

    def _bad(self, name: str, where, what: str) -> SceneError:
        return self.node.error(f"{name} of {self.node.tag} '{self.node.type}' must be {what}", where)

    def get(self, name: str, default=None, kind=None):
        """The parameter `name` (removed from what is left), checked to be of `kind`: float, int, bool, str,
        "matrix" (4x4), "vec" (three numbers), "colour" (a number or three) or "ior" (a number or a name)."""
        if name not in self.left:
            return default
        value, where = self.left.pop(name)
        if kind is float:
            if not _is_number(value) or not np.isfinite(float(value)):
                raise self._bad(name, where, "a number")
            return float(value)
        if kind is int:
            if not _is_number(value) or not float(value).is_integer() or abs(float(value)) > 2**31 - 1:
                raise self._bad(name, where, "an integer")
            return int(value)
        if kind is bool:
            if not isinstance(value, (bool, np.bool_)):
                raise self._bad(name, where, "true or false")
            return bool(value)
        if kind is str:
            if not isinstance(value, str):
                raise self._bad(name, where, "a string")
            return value
        if kind == "ior":
            if isinstance(value, str):
                return value
            if not _is_number(value):
                raise self._bad(name, where, "a number or a material name")
            return float(value)
        a = None if kind is None else _array(value)
        if kind == "matrix":
            if a is None or a.shape != (4, 4):
                raise self._bad(name, where, "a 4x4 transform")
            return a
        if kind == "vec":
            if a is None or a.size != 3:
                raise self._bad(name, where, "three numbers (a point or vector)")
            return a.reshape(3)
        if kind == "colour":
            if a is None or a.size not in (1, 3) or _is_number(value) is False and a.ndim > 1:
                raise self._bad(name, where, "a colour (one number, rgb or spectrum) or a texture")
            return a.reshape(-1)
        return value

    def where(self, name: str):
        return self.node.props[name][1] if name in self.node.props else self.node.where

    def done(self) -> None:
        for name, (_, where) in self.left.items():
            raise self.node.error(f"unsupported parameter '{name}' of {self.node.tag} '{self.node.type}' "
                                  "(outside durer's Mitsuba subset)", where)
