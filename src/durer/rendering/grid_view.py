"""The course's -visualize_grid (assignment 5): an integrator that draws the uniform grid's occupied cells.

Each ray shows the first occupied cell it enters as an opaque box, coloured by how many primitives the cell holds
and lit like a diffuse surface; the grid itself (accel/grid.py) answers which cell that is.
"""

from __future__ import annotations

import numpy as np

from ..accel.grid import GridAccelerator
from .context import SampleResult
from .shading import light_directions, phong

# -visualize_grid colours a cell by how many primitives it holds: white 1, magenta 2, then through blue, cyan,
# green and yellow to red for 17 or more (the colours measured off the course's reference images).
COUNT_COLORS = np.array([
    (1.0, 1.0, 1.0), (1.0, 0.0, 1.0), (0.7, 0.0, 1.0), (0.3, 0.0, 1.0), (0.0, 0.0, 1.0), (0.0, 0.3, 1.0),
    (0.0, 0.7, 1.0), (0.0, 1.0, 1.0), (0.0, 1.0, 0.7), (0.0, 1.0, 0.3), (0.0, 1.0, 0.0), (0.3, 1.0, 0.0),
    (0.7, 1.0, 0.0), (1.0, 1.0, 0.0), (1.0, 0.7, 0.0), (1.0, 0.3, 0.0), (1.0, 0.0, 0.0),
])



def visualize_grid(ctx, origins: np.ndarray, directions: np.ndarray, t_min: float, pixel: np.ndarray | None = None,
                   sample: np.ndarray | None = None) -> SampleResult:
    """Integrator for -visualize_grid: each ray shows the first occupied cell it enters, as an opaque box.

    The face's normal is that of the cell face crossed to enter it (the axis the 3D-DDA stepped last, facing
    the ray); its colour is COUNT_COLORS by the cell's primitive count, lit like a diffuse material by the
    scene's lights and ambient light. Planes are not in the grid and are not drawn.
    """
    grid = ctx.accel
    if not isinstance(grid, GridAccelerator):
        raise ValueError("-visualize_grid needs the grid accelerator (-grid NX NY NZ)")
    b = ctx.bundle
    n = len(origins)
    t, axis, count = grid.first_occupied(origins, directions, t_min)
    hit = np.isfinite(t)
    color = np.broadcast_to(b.background, (n, 3)).copy()
    normals = np.zeros((n, 3))
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    rows = np.flatnonzero(hit & (axis >= 0))
    normals[rows, axis[rows]] = -np.sign(d[rows, axis[rows]])
    inside = hit & (axis < 0)
    normals[inside] = -d[inside]
    if hit.any():
        kd = COUNT_COLORS[np.minimum(count[hit], len(COUNT_COLORS)) - 1]
        if b.lights is None:
            color[hit] = kd
        else:
            points = origins[hit] + t[hit, None] * directions[hit]
            shaded = b.ambient * kd
            zero = np.zeros_like(kd)
            for light in b.lights:
                to_light, light_color, _ = light_directions(light, points)
                shaded = shaded + phong(normals[hit], -d[hit], to_light, light_color, kd, zero,
                                        np.ones(len(kd)))
            color[hit] = shaded
    return SampleResult(color, t, normals)
