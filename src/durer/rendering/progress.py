"""What a user sees of a render in progress: a progress bar on a terminal, and a notice before Numba compiles
the kernels of a cold cache."""

from __future__ import annotations

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

