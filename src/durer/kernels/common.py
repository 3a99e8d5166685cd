"""What every kernel shares: Numba's options and the hit kinds.

The hit kinds are the `kind` of every hit record (accel/hits.py), the same in every kernel and in the query API.
"""

from __future__ import annotations

# cache compiled code on disk; NumPy's error model (a division by zero gives inf or nan, no exception and no check
# per division); release the GIL so kernels can run on Python threads (kernels/threads.py)
JIT = dict(cache=True, error_model="numpy", nogil=True)

# what a ray hit
MISS, TRIANGLE, SPHERE, PLANE = 0, 1, 2, 3

# Analytic shapes share the spheres' arrays and hit kind (SPHERE: a quadric seen through its world-to-object
# matrix). A positive radius is a sphere about its centre; Mitsuba's disk (the unit disk in z = 0) and cylinder
# (radius 1, open, z from 0 to 1), both fixed shapes in object space, carry these codes in the radius slot instead.
DISK_CODE, CYLINDER_CODE = -1.0, -2.0
