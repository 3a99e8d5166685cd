"""Arguments of RaycastingScene as Open3D's RaycastingScene takes them, read into NumPy, and results given back.

Open3D's tensors (`open3d.core.Tensor`) and triangle meshes (`open3d.t.geometry.TriangleMesh`, or the legacy
`open3d.geometry.TriangleMesh`) are recognised by their type's module, so `open3d` is never imported here: a user
who has it passes its objects, one who has not never pays for it. Results are NumPy arrays of the `Tensor`
subclass, whose only addition is Open3D's `.numpy()`, so `scene.cast_rays(rays)["t_hit"].numpy()` runs unchanged.
"""

from __future__ import annotations

import contextlib

import numba
import numpy as np

INVALID_ID = 2**32 - 1  # Open3D's id of a miss: the kernels' -1 read as uint32


class Tensor(np.ndarray):
    """A NumPy array with Open3D's `.numpy()` (returning the plain array, no copy), so code written for
    `open3d.core.Tensor` results runs unchanged. Everything else is NumPy's."""

    def numpy(self) -> np.ndarray:
        return self.view(np.ndarray)


def results(arrays: dict) -> dict:
    """The dict of a query's results, each array viewed as a Tensor (nothing copied)."""
    return {key: tensor(a) for key, a in arrays.items()}


def tensor(a: np.ndarray) -> Tensor:
    return np.asarray(a).view(Tensor)


def ids(a: np.ndarray) -> np.ndarray:
    """int32 ids with -1 for a miss as Open3D's uint32 ids with INVALID_ID (a view: the same bits)."""
    return a.view(np.uint32)


def _from_open3d(a):
    """An Open3D tensor's NumPy array (moved to the CPU first), or a as it is."""
    module = type(a).__module__ or ""
    if module.startswith("open3d") and hasattr(a, "numpy"):
        if hasattr(a, "cpu"):
            a = a.cpu()
        return a.numpy()
    return a


def array(a) -> np.ndarray:
    """Any array-like, Open3D tensors and our Tensor included, as a plain NumPy array (no copy when possible)."""
    a = _from_open3d(a)
    arr = np.asarray(a)
    return arr.view(np.ndarray) if type(arr) is not np.ndarray else arr


def is_scalar(a) -> bool:
    """Whether a is a number (or a 0-d array): Open3D's nthreads / tnear where durer's old positional form has
    an array (directions)."""
    return a is None or np.ndim(_from_open3d(a)) == 0


def mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices, triangles) of an Open3D triangle mesh (tensor-based or legacy) or of anything with `vertices`
    and `faces` (trimesh); None for anything else."""
    module = type(mesh).__module__ or ""
    if module.startswith("open3d"):
        if hasattr(mesh, "vertex") and hasattr(mesh, "triangle"):  # open3d.t.geometry.TriangleMesh
            return array(mesh.vertex["positions"]), array(mesh.triangle["indices"])
        if hasattr(mesh, "vertices") and hasattr(mesh, "triangles"):  # open3d.geometry.TriangleMesh
            return np.asarray(mesh.vertices), np.asarray(mesh.triangles)
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return np.asarray(mesh.vertices), np.asarray(mesh.faces)
    return None


def numeric_array(name: str, a, shape_tail: tuple[int, ...], keep_float32: bool = False) -> np.ndarray:
    """a as a float64 array (..., *shape_tail), not necessarily contiguous (float32 kept as it is with
    keep_float32: the query kernels read it as it is); ValueError naming `name` otherwise."""
    arr = array(a)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)):
        raise ValueError(f"{name} must be a numeric array, got dtype {arr.dtype}")
    if arr.ndim < len(shape_tail) or tuple(arr.shape[arr.ndim - len(shape_tail):]) != shape_tail:
        want = "(..., " + ", ".join(map(str, shape_tail)) + ")"
        raise ValueError(f"{name} must have shape {want}, got {arr.shape}")
    if keep_float32 and arr.dtype == np.float32:
        return arr
    return arr.astype(np.float64, copy=False)


def finite_array(name: str, a, shape_tail: tuple[int, ...]) -> np.ndarray:
    """numeric_array, C-contiguous, and free of NaN and infinity."""
    arr = np.ascontiguousarray(numeric_array(name, a, shape_tail))
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} contains NaN or infinity")
    return arr


def transform(matrix) -> np.ndarray:
    """A 4x4 affine, invertible, finite matrix as float64; ValueError otherwise."""
    m = array(matrix).astype(np.float64)
    if m.shape != (4, 4):
        raise ValueError(f"transform must be a 4x4 matrix, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise ValueError("transform contains NaN or infinity")
    if not np.allclose(m[3], [0.0, 0.0, 0.0, 1.0]):
        raise ValueError(f"transform must be affine (last row 0 0 0 1), got {m[3]}")
    if abs(np.linalg.det(m[:3, :3])) < 1e-300:
        raise ValueError("transform is singular")
    return m


def t_range(t_min, t_max, tnear, tfar) -> tuple:
    """(t_min, t_max) from durer's names or Open3D's tnear / tfar (one of each pair; defaults 0 and inf)."""
    if tnear is not None and t_min is not None:
        raise ValueError("give t_min or Open3D's tnear, not both")
    if tfar is not None and t_max is not None:
        raise ValueError("give t_max or Open3D's tfar, not both")
    lo = tnear if tnear is not None else t_min
    hi = tfar if tfar is not None else t_max
    lo, hi = (0.0 if lo is None else _from_open3d(lo)), (np.inf if hi is None else _from_open3d(hi))
    if is_scalar(lo) and is_scalar(hi) and float(np.asarray(lo)) > float(np.asarray(hi)):
        raise ValueError(f"the t range is empty: t_min {float(np.asarray(lo))} > t_max {float(np.asarray(hi))}")
    return lo, hi


@contextlib.contextmanager
def threads(nthreads: int | None):
    """Numba's thread count set to nthreads for the block, restored after. 0, a negative count (Open3D accepts
    -1) or None: automatic, which leaves Numba's current count; more than the cores: all cores."""
    n = 0 if nthreads is None else int(nthreads)
    if n <= 0:
        yield
        return
    old = numba.get_num_threads()
    numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
    try:
        yield
    finally:
        numba.set_num_threads(old)


def check_device(device) -> None:
    """Open3D's device argument: durer runs on the CPU, so a CPU device (or None) is accepted, others refused."""
    if device is None:
        return
    name = str(device)
    if "CPU" not in name.upper():
        raise ValueError(f"durer runs on the CPU; device {name} is not supported")
