"""Cameras: each turns points on the film into rays P(t) = origin + t * direction.

Film points are given in pixel units, x to the right and y *up* from the bottom-left corner of the image,
so the centre of pixel column i, row j (counted from the bottom) is (i + 0.5, j + 0.5). The size (orthographic)
or field of view (perspective, fisheye) spans the *longer* image side and the shorter one is cropped, as the course
does ("for non-square image ratios, just crop the screen coordinates"); pixels stay square.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels.camera import orthographic_rays, perspective_rays
from .values import tame, unit


def orthonormal_basis(direction, up) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(direction, up, horizontal) as a right-handed orthonormal frame; horizontal = direction x up.

    `direction` need not be unit length and `up` need not be perpendicular to it, as the course allows.
    """
    d = np.asarray(direction, dtype=np.float64).reshape(3)
    u = np.asarray(up, dtype=np.float64).reshape(3)
    if not (np.isfinite(d).all() and np.isfinite(u).all()):
        raise ValueError("camera direction and up must be finite")
    if not d.any():
        raise ValueError("camera direction has zero length")
    if not u.any():
        raise ValueError("camera up vector is parallel to its direction (or zero)")
    d, u = unit(d), tame(u)  # lengths do not matter; 1e308 components must not overflow (values.tame)
    u0 = np.linalg.norm(u)
    u = u - np.dot(u, d) * d
    un = np.linalg.norm(u)
    if not un > 1e-12 * max(1.0, u0):
        raise ValueError("camera up vector is parallel to its direction (or zero)")
    u = u / un
    h = np.cross(d, u)
    return d, u, h


def concentric_disk(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (..., 2) of [0, 1)^2 mapped onto the unit disk by Shirley and Chiu's concentric map (Mitsuba's
    square_to_uniform_disk_concentric): uniform by area, (x, y)."""
    a, b = 2.0 * u[..., 0] - 1.0, 2.0 * u[..., 1] - 1.0
    first = np.abs(a) > np.abs(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(first, a, b)
        phi = np.where(first, np.pi / 4 * b / a, np.pi / 2 - np.pi / 4 * a / b)
    phi = np.where((a == 0) & (b == 0), 0.0, phi)
    return r * np.cos(phi), r * np.sin(phi)


def _finite_point(p) -> np.ndarray:
    a = np.asarray(p, dtype=np.float64).reshape(3)
    if not np.isfinite(a).all():
        raise ValueError(f"camera center must be finite, got {a.tolist()}")
    return a


def _film_offsets(points: np.ndarray, width: int, height: int, longer: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Film points in pixels -> offsets from the image centre in units of the longer (or shorter) side."""
    p = np.asarray(points, dtype=np.float64)
    side = float(max(width, height) if longer else min(width, height))
    return (p[..., 0] - 0.5 * width) / side, (p[..., 1] - 0.5 * height) / side


def _kernel_rays(kernel, camera, points: np.ndarray, width: int, height: int, scale: float):
    """origins, directions (..., 3) of a camera's ray kernel (kernels/camera.py) through film points (..., 2): the
    camera's frame as float64 arrays (a user may have assigned sequences to its fields) and `scale` its screen's
    extent per unit of the longer side."""
    p = np.asarray(points, dtype=np.float64)
    flat = np.ascontiguousarray(p.reshape(-1, 2))
    origins, directions = np.empty((len(flat), 3)), np.empty((len(flat), 3))
    frame = (np.asarray(v, dtype=np.float64) for v in (camera.center, camera.direction, camera.horizontal, camera.up))
    kernel(flat, int(width), int(height), *frame, float(scale), origins, directions)
    return origins.reshape(p.shape[:-1] + (3,)), directions.reshape(p.shape[:-1] + (3,))


def _film_points(sx: np.ndarray, sy: np.ndarray, width: int, height: int, longer: bool = True) -> np.ndarray:
    """The inverse of _film_offsets: offsets in units of the longer (or shorter) side -> film points (..., 2)."""
    side = float(max(width, height) if longer else min(width, height))
    return np.stack([sx * side + 0.5 * width, sy * side + 0.5 * height], axis=-1)


def _local(camera, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """World points (..., 3) in the camera's frame: (along horizontal, along up, along direction) from its center."""
    v = np.asarray(points, dtype=np.float64) - camera.center
    return v @ camera.horizontal, v @ camera.up, v @ camera.direction


def pixel_centers(width: int, height: int) -> np.ndarray:
    """Film points (H, W, 2) of the pixel centres, in image order: row 0 is the *top* row."""
    xs = np.arange(width) + 0.5
    ys = height - (np.arange(height) + 0.5)
    return np.stack(np.meshgrid(xs, ys), axis=-1)


@dataclass
class OrthographicCamera:
    """Parallel rays along `direction`; the film is a `size` x `size` square (longer side) around `center`.

    Its rays start "at infinity" (t_min = -inf), so objects behind the center are seen, as the course specifies.
    """

    center: np.ndarray
    direction: np.ndarray
    up: np.ndarray
    size: float

    t_min = -np.inf

    def __post_init__(self):
        self.center = _finite_point(self.center)
        self.size = float(self.size)
        if not self.size > 0:
            raise ValueError(f"camera size must be positive, got {self.size}")
        self.direction, self.up, self.horizontal = orthonormal_basis(self.direction, self.up)

    def generate_rays(self, points: np.ndarray, width: int, height: int):
        """Rays through film points (..., 2): returns origins, directions (..., 3) and a validity mask (all True),
        from one Numba pass (kernels/camera.orthographic_rays)."""
        origins, directions = _kernel_rays(orthographic_rays, self, points, width, height, self.size)
        return origins, directions, np.ones(origins.shape[:-1], dtype=bool)

    def project(self, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """World points (..., 3) -> film points (..., 2) in pixels (x right, y up) and a mask of the points the
        camera sees (all of them: its rays come from infinity). The inverse of generate_rays."""
        x, y, _ = _local(self, points)
        return _film_points(x / self.size, y / self.size, width, height), np.ones(x.shape, dtype=bool)


@dataclass
class PerspectiveCamera:
    """A pinhole at `center`; `angle` is the full field of view in degrees across the longer image side.

    Rays go through a flat virtual screen (not interpolated angles), directions are unit length, t_min = 0.
    With `aperture_radius` > 0 it is Mitsuba's thin lens: rays leave a disk of that radius around the centre
    (perpendicular to the view direction) towards the point the pinhole ray meets on the plane `focus_distance`
    ahead (depth of field); `lens` samples in [0, 1)^2 pick the point of the disk (Shirley's concentric map, as
    Mitsuba), and without them every ray leaves the centre.
    """

    center: np.ndarray
    direction: np.ndarray
    up: np.ndarray
    angle: float
    aperture_radius: float = 0.0
    focus_distance: float = 1.0

    t_min = 0.0

    def __post_init__(self):
        self.center = _finite_point(self.center)
        self.angle = float(self.angle)
        if not 0 < self.angle < 180:
            raise ValueError(f"camera angle must be between 0 and 180 degrees, got {self.angle}")
        self.aperture_radius, self.focus_distance = float(self.aperture_radius), float(self.focus_distance)
        if not (self.aperture_radius >= 0 and np.isfinite(self.aperture_radius)):
            raise ValueError(f"aperture radius must be finite and not negative, got {self.aperture_radius}")
        if not (self.focus_distance > 0 and np.isfinite(self.focus_distance)):
            raise ValueError(f"focus distance must be positive, got {self.focus_distance}")
        self.direction, self.up, self.horizontal = orthonormal_basis(self.direction, self.up)

    def generate_rays(self, points: np.ndarray, width: int, height: int, lens: np.ndarray | None = None):
        """Rays through film points (..., 2): origins, unit directions (..., 3) and a validity mask (all True).
        The pinhole's rays come from one Numba pass (kernels/camera.perspective_rays: no temporary arrays; the
        image's rays are a large share of a small render's time), then the thin lens moves their origins."""
        extent = 2.0 * np.tan(np.radians(self.angle) / 2.0)
        origins, d = _kernel_rays(perspective_rays, self, points, width, height, extent)
        if self.aperture_radius > 0 and lens is not None:
            ax, ay = concentric_disk(np.asarray(lens, dtype=np.float64).reshape(d.shape[:-1] + (2,)))
            focus = origins + d * (self.focus_distance / (d @ self.direction))[..., None]
            origins += (self.aperture_radius * ax)[..., None] * self.horizontal
            origins += (self.aperture_radius * ay)[..., None] * self.up
            d = focus - origins
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return origins, d, np.ones(origins.shape[:-1], dtype=bool)

    def project(self, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """World points (..., 3) -> film points (..., 2) in pixels through the pinhole, and a mask of the points
        in front of it (the others get meaningless film points)."""
        x, y, z = _local(self, points)
        extent = 2.0 * np.tan(np.radians(self.angle) / 2.0)
        front = z > 1e-12
        zs = np.where(front, z, 1.0) * extent
        return _film_points(x / zs, y / zs, width, height), front


@dataclass
class FisheyeCamera:
    """Equidistant fisheye: the angle from the view direction grows linearly with the distance from the
    image centre, reaching `angle`/2 at the middle of the shorter side's edge (angle may exceed 180), so the
    whole image circle is in the picture. Film points outside that circle get no ray (their `valid` mask is False)
    and the renderer paints them in the scene's background colour."""

    center: np.ndarray
    direction: np.ndarray
    up: np.ndarray
    angle: float = 180.0

    t_min = 0.0

    def __post_init__(self):
        self.center = _finite_point(self.center)
        self.angle = float(self.angle)
        if not 0 < self.angle <= 360:
            raise ValueError(f"fisheye angle must be in (0, 360] degrees, got {self.angle}")
        self.direction, self.up, self.horizontal = orthonormal_basis(self.direction, self.up)

    def generate_rays(self, points: np.ndarray, width: int, height: int):
        sx, sy = _film_offsets(points, width, height, longer=False)
        r = np.hypot(sx, sy)
        theta = r * np.radians(self.angle)  # r = 0.5 at the edge -> angle / 2
        phi = np.arctan2(sy, sx)
        s = np.sin(theta)
        d = (np.cos(theta)[..., None] * self.direction + (s * np.cos(phi))[..., None] * self.horizontal
             + (s * np.sin(phi))[..., None] * self.up)
        origins = np.broadcast_to(self.center, d.shape).copy()
        return origins, d, r <= 0.5

    def project(self, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """World points (..., 3) -> film points (..., 2) in pixels, and a mask of the points inside the image
        circle (the inverse of generate_rays: radius proportional to the angle from the view direction)."""
        x, y, z = _local(self, points)
        theta = np.arctan2(np.hypot(x, y), z)
        r = theta / np.radians(self.angle)
        phi = np.arctan2(y, x)
        return _film_points(r * np.cos(phi), r * np.sin(phi), width, height, longer=False), r <= 0.5


@dataclass
class PanoramaCamera:
    """Equirectangular (latitude-longitude) panorama: the image width spans 360 degrees of longitude around
    `up`, centred on `direction`, and the height spans 180 degrees of latitude (use a 2:1 image)."""

    center: np.ndarray
    direction: np.ndarray
    up: np.ndarray

    t_min = 0.0

    def __post_init__(self):
        self.center = _finite_point(self.center)
        self.direction, self.up, self.horizontal = orthonormal_basis(self.direction, self.up)

    def generate_rays(self, points: np.ndarray, width: int, height: int):
        p = np.asarray(points, dtype=np.float64)
        lon = (p[..., 0] / width - 0.5) * 2.0 * np.pi
        lat = (p[..., 1] / height - 0.5) * np.pi
        c = np.cos(lat)
        d = ((c * np.cos(lon))[..., None] * self.direction + (c * np.sin(lon))[..., None] * self.horizontal
             + np.sin(lat)[..., None] * self.up)
        origins = np.broadcast_to(self.center, d.shape).copy()
        return origins, d, np.ones(lon.shape, dtype=bool)

    def project(self, points: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
        """World points (..., 3) -> film points (..., 2) in pixels (longitude, latitude), and a mask of the points
        not at the center itself."""
        x, y, z = _local(self, points)
        lon = np.arctan2(x, z)
        lat = np.arctan2(y, np.hypot(x, z))
        film = np.stack([(lon / (2.0 * np.pi) + 0.5) * width, (lat / np.pi + 0.5) * height], axis=-1)
        return film, (np.abs(x) + np.abs(y) + np.abs(z)) > 0


Camera = OrthographicCamera | PerspectiveCamera | FisheyeCamera | PanoramaCamera


FRAMING_ANGLE = 40.0      # field of view (degrees, across the longer side) of a camera framed on a model
FRAMING_AZIMUTH = 35.0    # degrees to the right of the model's front (+Z for +Y up)
FRAMING_ELEVATION = 25.0  # degrees above its horizon
FRAMING_MARGIN = 1.08     # the bounding sphere's silhouette ends this far inside the shorter image side


def frame_sphere(center, radius: float, width: int = 1, height: int = 1, up=(0.0, 1.0, 0.0)) -> PerspectiveCamera:
    """A perspective camera that sees the whole sphere (center, radius) from a three-quarter view, the sphere's
    outline just inside the shorter side of a width x height image. The camera remembers the sphere as `frame`,
    so the renderer can frame it again for the image it actually renders (rendering/renderer.py)."""
    center = _finite_point(center)
    radius = float(radius) if radius > 0 else 1.0
    u = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    front = np.array([0.0, 0.0, 1.0]) if abs(u[2]) < 0.9 else np.array([0.0, -1.0, 0.0])
    front = front - (front @ u) * u
    front /= np.linalg.norm(front)
    right = np.cross(u, front)
    az, el = np.radians(FRAMING_AZIMUTH), np.radians(FRAMING_ELEVATION)
    offset = np.cos(el) * (np.cos(az) * front + np.sin(az) * right) + np.sin(el) * u
    half_short = np.arctan(np.tan(np.radians(FRAMING_ANGLE) / 2) * min(width, height) / max(width, height))
    distance = FRAMING_MARGIN * radius / np.sin(half_short)
    camera = PerspectiveCamera(center + distance * offset, -offset, u, FRAMING_ANGLE)
    camera.frame = (center, radius, u)
    return camera


def image_camera(camera, width: int, height: int):
    """The camera to trace a width x height image through: a camera framed on a model (frame_sphere's, for a model
    without a camera of its own) is framed again for this image's shape; any other camera is used as it is."""
    frame = getattr(camera, "frame", None)
    if frame is None:
        return camera
    return frame_sphere(*frame[:2], width, height, up=frame[2])
