"""The `durer` command's argument checks, shared by every subcommand: a parser that raises UsageError, number
types with messages naming what was expected, the --threads flag, and the checks made once the flags are parsed
(depth range, zoomed debug image sizes, writable outputs, RenderOptions.validate)."""

from __future__ import annotations

import argparse

from .errors import UsageError
from .io.images import check_writable
from .options import RenderOptions


class _Parser(argparse.ArgumentParser):
    """argparse that raises UsageError instead of exiting, so every error path ends in the same place."""

    def error(self, message: str):
        raise UsageError(f"{self.format_usage().strip()}\n{self.prog}: error: {message}")


def _int_at_least(minimum: int, what: str):
    """An argparse type: an integer >= minimum, with a message naming what was expected."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or value < minimum:
            raise argparse.ArgumentTypeError(f"expected a {what} integer, got {text!r}")
        return value

    return parse


_positive_int = _int_at_least(1, "positive")
_nonneg_int = _int_at_least(0, "non-negative")


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _positive_number(text: str) -> float:
    value = _number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def _depth(values: list[str], flag: str) -> tuple[float, float, str]:
    near, far, path = values
    try:
        near_f, far_f = _number(near), _number(far)
    except argparse.ArgumentTypeError as e:
        raise UsageError(f"{flag}: {e} (usage: {flag} NEAR FAR FILE)") from None
    if not near_f < far_f:
        raise UsageError(f"{flag}: NEAR ({near}) must be less than FAR ({far}): near is drawn white, far black")
    return near_f, far_f, path


def _add_threads(p: argparse.ArgumentParser) -> None:
    p.add_argument("--threads", "-threads", type=_nonneg_int, default=None, metavar="N",
                   help="render on N threads (default and 0: every core; pbrt's --nthreads, Mitsuba's -t)")


def _validate(opts: RenderOptions) -> None:
    """RenderOptions.validate as a UsageError: every option and size checked before anything is read."""
    try:
        opts.validate()
    except ValueError as e:
        raise UsageError(str(e)) from None


MAX_DEBUG_SIDE = 16384  # pixels a side of a -render_samples / -render_filter image (the course's are 20x)
BYTES_PER_DEBUG_PIXEL = 100  # the float64 image, its 8-bit copy and NumPy's temporaries while drawing


def _zoom(values: list[str] | None, flag: str, width: int, height: int) -> tuple[str, int] | None:
    """FILE and ZOOM of a course debug image, ZOOM checked against the size of the image it makes."""
    if values is None:
        return None
    try:
        zoom = _positive_int(values[1])
    except argparse.ArgumentTypeError as e:
        raise UsageError(f"{flag} ZOOM: {e}") from None
    from .rendering.memory import physical_memory

    side = max(width, height) * zoom + 1
    need = (width * zoom + 1) * (height * zoom + 1) * BYTES_PER_DEBUG_PIXEL
    have = physical_memory()
    if side > MAX_DEBUG_SIDE or (have and need > have):
        most = (MAX_DEBUG_SIDE - 1) // max(width, height)
        raise UsageError(f"{flag} ZOOM: a {width}x{height} image zoomed {zoom} times would be "
                         f"{width * zoom}x{height * zoom} pixels; at most {MAX_DEBUG_SIDE} a side "
                         f"({f'ZOOM up to {most} here' if most else 'use a smaller -size'})")
    return values[0], zoom


def _check_outputs(paths: list[str]) -> None:
    """Fail before rendering if an output cannot be written: unknown extension, missing folder, no permission,
    a folder in the way (io/images.check_writable)."""
    for path in paths:
        check_writable(path)
