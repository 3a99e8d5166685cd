"""-stats: the counters of the course's RayTracingStats (assignment 6) and their printed summary.

Rays are counted where they are cast (closest_hit: eye, reflected and refracted rays; any_hit: shadow rays),
intersections as ray-primitive tests, and cells as grid cells entered by the 3D-DDA walk. The grid counts its
tests and cells in its kernels (per-ray slots summed afterwards); accelerators that do not count their own
tests are wrapped in CountingAccelerator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .hits import Accelerator, QueriedOnly


@dataclass
class RayStats:
    """Totals over a render. `intersections` is None when the accelerator cannot count its tests."""

    nonshadow_rays: int = 0
    shadow_rays: int = 0
    intersections: int | None = 0
    cells: int = 0
    bounds: tuple[np.ndarray, np.ndarray] | None = None
    grid: tuple[int, int, int] | None = None

    def add(self, rays: int, shadow: bool, tests: int | None, cells: int = 0) -> None:
        if shadow:
            self.shadow_rays += rays
        else:
            self.nonshadow_rays += rays
        if tests is None or self.intersections is None:
            self.intersections = None
        else:
            self.intersections += int(tests)
        self.cells += int(cells)

    def report(self, width: int, height: int, seconds: float) -> str:
        """The course's PrintStatistics summary (same lines and order), time with milliseconds."""
        rays = self.nonshadow_rays + self.shadow_rays
        per = (lambda x: x / rays) if rays else (lambda x: 0.0)
        minutes, secs = divmod(seconds, 60.0)
        hours, minutes = divmod(int(minutes), 60)
        if self.bounds is None:
            bounds = "NULL"
        else:
            lo, hi = self.bounds
            bounds = f"({lo[0]:0.2f} {lo[1]:0.2f} {lo[2]:0.2f}) -> ({hi[0]:0.2f} {hi[1]:0.2f} {hi[2]:0.2f})"
        if self.grid is None:
            cells = "NULL"
        else:
            nx, ny, nz = self.grid
            cells = f"{nx * ny * nz} ({nx}x{ny}x{nz})"
        isect = "n/a (not counted by this accelerator)" if self.intersections is None else str(self.intersections)
        isect_per = "n/a" if self.intersections is None else f"{per(self.intersections):0.1f}"
        rate = rays / seconds if seconds > 0 else 0.0
        lines = [
            "*" * 44,
            "RAY TRACING STATISTICS",
            f"  total time                 {hours}:{minutes:02d}:{secs:06.3f}",
            f"  num pixels                 {width * height} ({width}x{height})",
            f"  scene bounds               {bounds}",
            f"  num grid cells             {cells}",
            f"  num non-shadow rays        {self.nonshadow_rays}",
            f"  num shadow rays            {self.shadow_rays}",
            f"  total intersections        {isect}",
            f"  total cells traversed      {self.cells}",
            f"  rays per second            {rate:0.1f}",
            f"  rays per pixel             {rays / (width * height):0.1f}",
            f"  intersections per ray      {isect_per}",
            f"  cells traversed per ray    {per(self.cells):0.1f}",
            "*" * 44,
        ]
        return "\n".join(lines)


class CountingAccelerator(QueriedOnly):
    """Wraps an accelerator that does not count, to count its rays for -stats.

    Brute force tests every primitive for every ray, as the course's RayCast loop does, so its intersections
    are rays x primitives (the course counts a shadow ray's tests the same way); for any other accelerator
    the tests are unknown and reported as such.
    """

    def __init__(self, accel: Accelerator, stats: RayStats, tests_per_ray: int | None):
        self.accel = accel
        self.stats = stats
        self.tests_per_ray = tests_per_ray
        self.name = getattr(accel, "name", type(accel).__name__)

    def __getattr__(self, name):
        return getattr(self.accel, name)

    def _tests(self, n: int) -> int | None:
        return None if self.tests_per_ray is None else n * self.tests_per_ray

    def closest_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0):
        self.stats.add(len(origins), False, self._tests(len(origins)))
        return self.accel.closest_hit(origins, directions, t_min, t_max, width)

    def any_hit(self, origins, directions, t_min=0.0, t_max=np.inf, width: int = 0):
        self.stats.add(len(origins), True, self._tests(len(origins)))
        return self.accel.any_hit(origins, directions, t_min, t_max, width)
