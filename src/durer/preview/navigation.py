"""Moving the preview's camera with the mouse: orbit about a target point, pan across the view, zoom.

Every move returns a new camera of the same class (dataclasses.replace reruns its checks and its basis), so
the scene's own camera is never changed and `reset` is a copy of it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..scene.cameras import OrthographicCamera, PerspectiveCamera


@dataclasses.dataclass(frozen=True)
class View:
    """A camera and the point it orbits about (on its view axis)."""

    camera: object
    target: np.ndarray

    def describe(self) -> dict:
        """The camera as JSON-ready numbers (what the page shows and tests compare)."""
        cam = self.camera
        out = {"type": type(cam).__name__, "center": [float(v) for v in cam.center],
               "direction": [float(v) for v in cam.direction], "up": [float(v) for v in cam.up],
               "target": [float(v) for v in self.target]}
        for name in ("angle", "size"):
            if hasattr(cam, name):
                out[name] = float(getattr(cam, name))
        return out


def home_view(camera, bounds: tuple[np.ndarray, np.ndarray]) -> View:
    """The scene's camera, orbiting about the point of its view axis level with the middle of the scene's
    bounded objects (at least a unit ahead, for scenes of planes only or behind the camera)."""
    lo, hi = bounds
    middle = 0.5 * (np.asarray(lo) + np.asarray(hi))
    distance = max(float(np.dot(middle - camera.center, camera.direction)), 1.0)
    return View(camera, camera.center + distance * camera.direction)


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation matrix about a unit axis."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def orbit(view: View, yaw: float, pitch: float, world_up: np.ndarray) -> View:
    """Turn the camera about the target: `yaw` radians about world_up, then `pitch` about its horizontal axis
    (skipped where it would look straight along world_up, which would leave its up vector undefined)."""
    cam = view.camera
    r = _rotation(world_up, -yaw)
    offset, direction = r @ (cam.center - view.target), r @ cam.direction
    horizontal = np.cross(direction, world_up)
    if np.linalg.norm(horizontal) > 1e-9:
        p = _rotation(horizontal, pitch)
        if abs(np.dot(p @ direction, world_up)) < 0.995:
            offset, direction = p @ offset, p @ direction
    new = dataclasses.replace(cam, center=view.target + offset, direction=direction, up=world_up)
    return View(new, view.target)


def pixel_size(view: View, width: int, height: int) -> float:
    """World size of one pixel at the target's distance (what a pan of one pixel moves)."""
    cam = view.camera
    side = max(width, height)
    if isinstance(cam, OrthographicCamera):
        return cam.size / side
    distance = float(np.linalg.norm(view.target - cam.center))
    extent = 2.0 * math.tan(math.radians(cam.angle) / 2.0) if isinstance(cam, PerspectiveCamera) else 2.0
    return distance * extent / side


def pan(view: View, dx: float, dy: float, width: int, height: int) -> View:
    """Slide camera and target so the scene follows a drag of (dx, dy) image pixels (dy down)."""
    cam = view.camera
    shift = pixel_size(view, width, height) * (-dx * cam.horizontal + dy * cam.up)
    return View(dataclasses.replace(cam, center=cam.center + shift), view.target + shift)


def zoom(view: View, factor: float) -> View:
    """factor < 1 comes closer: the distance to the target (or an orthographic camera's size) times factor."""
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"zoom factor must be a positive number, got {factor!r}")
    cam = view.camera
    if isinstance(cam, OrthographicCamera):
        return View(dataclasses.replace(cam, size=cam.size * factor), view.target)
    offset = cam.center - view.target
    if np.linalg.norm(offset) * factor < 1e-6:
        return view
    return View(dataclasses.replace(cam, center=view.target + factor * offset), view.target)
