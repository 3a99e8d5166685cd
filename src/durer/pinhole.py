"""RaycastingScene.create_rays_pinhole: Open3D's camera rays, both of its forms, the same rays to float32 rounding.

Open3D's convention (open3d/t/geometry/RaycastingScene.cpp): a pixel (x, y) of a width_px x height_px image has
the ray direction R^T K^-1 (x + 0.5, y + 0.5, 1) from the camera centre -R^T t, where K is the intrinsic matrix
and [R | t] the world-to-camera extrinsic matrix, in float64, stored as float32 (h, w, 6). The directions are not
unit length: their camera-space z is 1, so a hit's t_hit is its depth along the optical axis. The look-at form
builds K from a horizontal field of view (focal length 0.5 w / tan(fov / 2), principal point at the image centre)
and R with camera y along -up and z towards `center`: row 0 of the image looks along +up and column 0 to the
camera's left, as a photograph.
"""

from __future__ import annotations

import numpy as np

from .kernels.pinhole import pinhole_rays
from .query_args import array


def _vector(name: str, v) -> np.ndarray:
    a = array(v).astype(np.float64).reshape(-1)
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be 3 finite numbers, got {array(v).tolist()}")
    return a


RAY_BYTES = 24  # one float32 ray (origin and direction) in the (height, width, 6) result


def _size(width_px, height_px) -> tuple[int, int]:
    """The image size as whole positive pixels whose rays fit in memory; ValueError naming what is wrong."""
    for name, value in (("width_px", width_px), ("height_px", height_px)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer, float, np.floating)) \
                or value != int(value) or value < 1:
            raise ValueError(f"{name} must be a positive whole number of pixels, got {value!r}")
    w, h = int(width_px), int(height_px)
    from .rendering.memory import physical_memory

    need, have = w * h * RAY_BYTES, physical_memory()
    if have and need > have // 2:
        raise ValueError(f"{w} x {h} rays would take {need / 1e9:.1f} GB; this machine has {have / 1e9:.1f} GB")
    return w, h


def rays_from_matrices(intrinsic_matrix, extrinsic_matrix, width_px: int, height_px: int) -> np.ndarray:
    """Open3D's create_rays_pinhole(intrinsic_matrix (3, 3), extrinsic_matrix (4, 4) world to camera, width_px,
    height_px): float32 rays (height_px, width_px, 6), computed in float64 in Open3D's order of operations."""
    k = array(intrinsic_matrix).astype(np.float64)
    e = array(extrinsic_matrix).astype(np.float64)
    if k.shape != (3, 3) or e.shape != (4, 4):
        raise ValueError(f"intrinsic_matrix must be 3x3 and extrinsic_matrix 4x4, got {k.shape} and {e.shape}")
    if not (np.isfinite(k).all() and np.isfinite(e).all()):
        raise ValueError("the camera matrices contain NaN or infinity")
    if abs(np.linalg.det(k)) == 0.0:
        raise ValueError("intrinsic_matrix is singular")
    w, h = _size(width_px, height_px)
    rt = e[:3, :3].T
    m = rt @ np.linalg.inv(k)  # Eigen evaluates R^T K^-1 first, then its product with the pixel
    out = np.empty((h, w, 6), np.float32)
    pinhole_rays(m, -rt @ e[:3, 3], out)
    return out


def rays_look_at(fov_deg: float, center, eye, up, width_px: int, height_px: int) -> np.ndarray:
    """Open3D's create_rays_pinhole(fov_deg, center, eye, up, width_px, height_px): fov_deg is the horizontal
    field of view; the camera at eye looks at center with image up along up."""
    fov = float(fov_deg)
    if not 0.0 < fov < 180.0:
        raise ValueError(f"fov_deg must be between 0 and 180 degrees, got {fov_deg}")
    c, o, u = _vector("center", center), _vector("eye", eye), _vector("up", up)
    w, h = _size(width_px, height_px)
    focal = 0.5 * w / np.tan(0.5 * np.radians(fov))
    k = np.array([[focal, 0.0, 0.5 * w], [0.0, focal, 0.5 * h], [0.0, 0.0, 1.0]])
    forward = c - o
    if not np.linalg.norm(forward) > 0.0:
        raise ValueError("eye and center are the same point")
    r = np.empty((3, 3))
    r[2] = forward / np.linalg.norm(forward)
    r[0] = np.cross(u, r[2])
    if not np.linalg.norm(r[0]) > 1e-12 * np.linalg.norm(u):
        raise ValueError("camera up vector is parallel to its direction (or zero)")
    r[0] /= np.linalg.norm(r[0])
    r[1] = np.cross(r[2], r[0])
    r[1] /= np.linalg.norm(r[1])
    e = np.eye(4)
    e[:3, :3] = r
    e[:3, 3] = -r @ o
    return rays_from_matrices(k, e, w, h)


def create_rays_pinhole(*args, **kwargs) -> np.ndarray:
    """Either of Open3D's forms, picked as Open3D's overloads are: (intrinsic_matrix, extrinsic_matrix, width_px,
    height_px) or (fov_deg, center, eye, up, width_px, height_px), positional or by name."""
    if "intrinsic_matrix" in kwargs or "extrinsic_matrix" in kwargs or (
            args and np.ndim(array(args[0])) == 2):
        return rays_from_matrices(*args, **kwargs)
    return rays_look_at(*args, **kwargs)
