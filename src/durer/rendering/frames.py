"""Animation frames: the cameras of a turntable or of a camera path, and one scene rendered through each of them.

A frame is the same Job with another camera (units.Job.camera): the scene is compiled once for all frames, and a
frame's image is durer.render of the scene with that camera, to the bit.

Turntable (`turntable`): the camera orbits its look-at point about its up axis, one full turn in N frames,
frame 0 being the scene's own camera. The look-at point and the axis are
  - for a camera framed on a model (a model file without a camera: cameras.frame_sphere), the centre of the
    model's bounding sphere and the framing's up (world +Y, or +Z for Z-up models);
  - for any other camera (course scenes, Mitsuba, glTF cameras), the point on its viewing axis as far from it as
    the centre of the scene's bounding box: center + direction * |box centre - center|, and the world axis
    (+-X, +-Y or +-Z) nearest the camera's up vector: the up the scene file gave (a camera keeps only its
    orthonormalised up, tilted when it looks down), so the camera keeps its height above the floor as it turns.
Camera path (`camera_path`): a JSON list of keys {"eye": [x,y,z], "look_at": [x,y,z], "up": [x,y,z], "fov": deg}
(up defaults to [0, 1, 0], fov to the scene camera's angle, else 40), interpolated linearly key to key.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from ..accel.compile import compile_scene
from ..scene.cameras import FRAMING_ANGLE, PerspectiveCamera, image_camera
from ..scene.graph import Scene
from .result import RenderResult
from .units import Job, finish, run

__all__ = ["camera_path", "frame_job", "look_at_point", "render_frames", "turntable", "world_up"]


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """The 3 x 3 rotation by `angle` radians about the unit `axis` (right-handed: counter-clockwise seen from
    the axis' tip)."""
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def look_at_point(scene: Scene, camera, bounds: tuple | None = None) -> np.ndarray:
    """The point a non-framed camera orbits: on its viewing axis, as far as the scene's bounding-box centre.
    `bounds`: the compiled scene's (lo, hi) when a render has compiled it (SceneBundle.given), else compiled here."""
    lo, hi = bounds if bounds is not None else compile_scene(scene).bounds()
    centre = (np.asarray(lo) + np.asarray(hi)) / 2.0
    if not np.all(np.isfinite(centre)):
        centre = np.zeros(3)  # only unbounded primitives (planes): orbit at the distance of the origin
    distance = float(np.linalg.norm(centre - camera.center))
    return camera.center + camera.direction * (distance if distance > 0 else 1.0)


def world_up(up) -> np.ndarray:
    """The world axis (+-X, +-Y, +-Z) nearest `up`: the vertical a turntable turns about."""
    up = np.asarray(up, dtype=np.float64)
    k = int(np.argmax(np.abs(up)))
    axis = np.zeros(3)
    axis[k] = np.sign(up[k])
    return axis


def turntable(scene: Scene, frames: int, width: int, height: int, bounds: tuple | None = None) -> list:
    """`frames` cameras orbiting the look-at point of the scene's camera about its vertical (module docstring),
    one full turn; frame 0 is the scene's own camera for this image size. `bounds`: as look_at_point's."""
    if int(frames) != frames or frames < 1:
        raise ValueError(f"frames must be a positive integer, got {frames}")
    camera = image_camera(scene.camera, width, height)
    for name in ("center", "direction", "up"):
        if not hasattr(camera, name):
            raise ValueError(f"a turntable needs a camera with a center, direction and up; got "
                             f"{type(camera).__name__}")
    frame = getattr(scene.camera, "frame", None)
    pivot, axis = (np.asarray(frame[0]), np.asarray(frame[2])) if frame else (look_at_point(scene, camera, bounds),
                                                                               world_up(camera.up))
    cameras = [camera]
    for k in range(1, int(frames)):
        r = _rotation(axis, 2.0 * math.pi * k / frames)
        cameras.append(dataclasses.replace(camera, center=pivot + r @ (camera.center - pivot),
                                           direction=r @ camera.direction, up=r @ camera.up))
    return cameras


def _vector(key: dict, name: str, where: str, default=None) -> np.ndarray:
    value = key.get(name, default)
    if value is None:
        raise ValueError(f"{where}: missing {name!r}")
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{where}: {name!r} must be a list of 3 numbers, got {value!r}")
    return v


def camera_path(path: str | Path, frames: int | None = None, fov: float | None = None) -> list[PerspectiveCamera]:
    """Cameras along the keys of a JSON camera path (module docstring): `frames` of them spread evenly from the
    first key to the last (default: one per key). ValueError naming the file and key on a mistake."""
    try:
        keys = json.loads(Path(path).read_text())
    except OSError as e:
        raise ValueError(f"{path}: cannot read the camera path ({e.strerror or e})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ValueError(f"{path}: not JSON ({e})") from None
    if not isinstance(keys, list) or not keys or not all(isinstance(k, dict) for k in keys):
        raise ValueError(f"{path}: expected a non-empty JSON list of camera keys "
                         '{"eye": [x, y, z], "look_at": [x, y, z], "up": [x, y, z], "fov": degrees}')
    fov = FRAMING_ANGLE if fov is None else fov
    table = []
    for i, key in enumerate(keys):
        where = f"{path}: key {i}"
        unknown = set(key) - {"eye", "look_at", "up", "fov"}
        if unknown:
            raise ValueError(f"{where}: unknown field(s) {', '.join(sorted(unknown))} (eye, look_at, up, fov)")
        angle = key.get("fov", fov)
        if isinstance(angle, bool) or not isinstance(angle, (int, float)) or not 0 < angle < 180:
            raise ValueError(f"{where}: 'fov' must be a number of degrees between 0 and 180, got {angle!r}")
        eye, target = _vector(key, "eye", where), _vector(key, "look_at", where)
        if np.allclose(eye, target):
            raise ValueError(f"{where}: 'eye' and 'look_at' are the same point")
        table.append(np.concatenate([eye, target, _vector(key, "up", where, [0.0, 1.0, 0.0]), [float(angle)]]))
    n = len(keys) if frames is None else int(frames)
    if n < 1:
        raise ValueError(f"frames must be a positive integer, got {frames}")
    table = np.array(table)
    cameras = []
    for i in range(n):
        t = 0.0 if n == 1 else i * (len(keys) - 1) / (n - 1)
        j = min(int(t), len(keys) - 2) if len(keys) > 1 else 0
        f = t - j
        row = table[j] if len(keys) == 1 else (1.0 - f) * table[j] + f * table[j + 1]
        try:
            cameras.append(PerspectiveCamera(row[:3], row[3:6] - row[:3], row[6:9], row[9]))
        except ValueError as e:
            raise ValueError(f"{path}: frame {i}: {e}") from None
    return cameras


def frame_job(job: Job, camera) -> Job:
    """The job of one frame: the same compiled scene through `camera` (framed for the job's image size)."""
    return dataclasses.replace(job, camera=image_camera(camera, job.width, job.height))


def render_frames(job: Job, cameras: list, bar=None) -> list[RenderResult]:
    """Render the job through each camera on this machine, one frame after another (units.run); `bar` hears
    every unit's samples, as durer.render's does."""
    results = []
    for camera in cameras:
        one = frame_job(job, camera)
        results.append(finish(one, run(one, bar=bar)))
    return results
