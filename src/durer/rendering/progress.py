"""What a user sees of a render in progress: a progress bar on a terminal, and a notice before Numba compiles
the kernels of a cold cache."""

from __future__ import annotations

import os
import sys


class _NoBar:
    """The disabled progress bar: tqdm's interface without importing tqdm (27 ms of every CLI start-up)."""

    disable = True

    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> _NoBar:
        return self

    def __exit__(self, *exc) -> None:
        pass


def progress(total: int, quiet: bool, unit: str = "ray"):
    """A progress bar on stderr that appears only after a second, and never when quiet or not on a terminal."""
    if quiet or not sys.stderr.isatty():
        return _NoBar()
    from tqdm import tqdm

    return tqdm(total=total, unit=unit, unit_scale=unit == "ray", delay=1.0, disable=False, leave=False,
                desc="rendering", file=sys.stderr)


COLD_CHECK = ("build", "trace")  # kernel modules every render compiles and caches


def kernels_cold(folder: str | None = None) -> bool:
    """Is Numba's on-disk cache of the kernels still empty (the first render will compile for many seconds)?
    Cheap: looks for the cache's index files (*.nbi) beside the kernels, in kernels/bvh/__pycache__."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False  # a cache elsewhere: cannot tell cheaply, stay quiet
    if folder is None:
        from ..kernels import bvh

        folder = os.path.join(os.path.dirname(bvh.__file__), "__pycache__")
    try:
        names = os.listdir(folder)
    except OSError:
        return True
    return not all(any(n.startswith(m + ".") and n.endswith(".nbi") for n in names) for m in COLD_CHECK)
