"""What every kernel shares: Numba's options and the hit kinds.

The hit kinds are the `kind` of every hit record (accel/hits.py), the same in every kernel and in the query API.
"""

from __future__ import annotations

# cache compiled code on disk; NumPy's error model (a division by zero gives inf or nan, no exception and no check
# per division); release the GIL so kernels can run on Python threads (kernels/threads.py)
JIT = dict(cache=True, error_model="numpy", nogil=True)

# what a ray hit
MISS, TRIANGLE, SPHERE, PLANE = 0, 1, 2, 3
