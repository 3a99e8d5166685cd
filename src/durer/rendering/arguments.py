"""render()'s arguments: keyword arguments and a scene's own render defaults turned into an image size and
checked RenderOptions (ValueError or TypeError naming what is wrong)."""

from __future__ import annotations

from dataclasses import fields

from ..options import RenderOptions
from ..scene.graph import Scene
from ..scene.validate import PHYSICAL


def parse_filter(spec: str) -> tuple[str, float | None]:
    """'gaussian:0.4' -> ('gaussian', 0.4); 'tent' -> ('tent', None)."""
    name, _, width = spec.partition(":")
    if not width:
        return name, None
    try:
        return name, float(width)
    except ValueError:
        raise ValueError(f"filter width is not a number: {spec!r}") from None


def make_options(options: RenderOptions | None = None, **kwargs) -> RenderOptions:
    """RenderOptions from keyword arguments (those of RenderOptions; `filter` may be 'name' or 'name:width')."""
    if options is not None and kwargs:
        raise TypeError("pass either options or keyword arguments, not both")
    if options is None:
        known = {f.name for f in fields(RenderOptions)}
        unknown = set(kwargs) - known
        if unknown:
            raise TypeError(f"unknown render option(s): {', '.join(sorted(unknown))}")
        if isinstance(kwargs.get("filter"), str) and ":" in kwargs["filter"]:
            kwargs["filter"], kwargs["filter_radius"] = parse_filter(kwargs["filter"])
        options = RenderOptions(**kwargs)
    options.validate()
    return options


def resolve(scene: Scene, width: int | None, height: int | None, options: RenderOptions | None,
            kwargs: dict) -> tuple[int, int, RenderOptions]:
    """The image size and options of render(scene, width, height, options=..., **kwargs): the scene's render
    defaults (Mitsuba scenes: integrator, sampler, film) apply unless given; the size must be positive integers,
    and physically based materials need the path tracer."""
    defaults = dict(getattr(scene, "render_defaults", None) or {})
    width = width if width is not None else defaults.get("width")
    height = height if height is not None else defaults.get("height")
    if width is None or height is None:
        raise ValueError("give the image size (width, height): the scene does not define one")
    if options is None:
        kwargs = {**{k: v for k, v in defaults.items() if k not in ("width", "height")}, **kwargs}
    if int(width) != width or int(height) != height or width < 1 or height < 1:
        raise ValueError(f"image size must be positive integers, got {width} x {height}")
    options = make_options(options, **kwargs)
    if options.crop is not None:
        x, y, w, h = options.crop
        if x + w > width or y + h > height:
            raise ValueError(f"crop window {w} x {h} at ({x}, {y}) does not fit in the {width} x {height} image")
    if options.integrator != "path" and any(isinstance(m, PHYSICAL) for m in scene.materials):
        raise ValueError("the scene has physically based materials (a Mitsuba scene): render it with "
                         "integrator='path'")
    return int(width), int(height), options
