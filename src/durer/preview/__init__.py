"""The live preview: `durer preview SCENE` in a browser, and `durer.preview(scene)` inline in a notebook.

    handle = durer.preview("examples/spheres.txt", 480, 320, shadows=True, bounces=3)
    handle            # in Jupyter: the live view in a frame; elsewhere handle.url is the page
    handle.stop()

The package is callable (durer.preview(...) is preview.show(...)), so the name works whether it is read as the
function or as the module. It needs the optional `durer[preview]` extra (Starlette, uvicorn, websockets).
"""

from __future__ import annotations

import os
import sys
import types

from ..scene.graph import Scene

_RUNNING: list = []  # servers started by show(), stopped by stop_all()


class PreviewHandle:
    """A running preview server: its `url`, `stop()`, and an inline frame when displayed in Jupyter."""

    def __init__(self, server, width: int, height: int):
        self.server, self.width, self.height = server, width, height

    @property
    def url(self) -> str:
        return self.server.url

    def stop(self) -> None:
        self.server.stop()
        if self.server in _RUNNING:
            _RUNNING.remove(self.server)

    def _repr_html_(self) -> str:
        # the page needs room for the image, the controls above it and the ray tree beside it
        return (f'<iframe src="{self.url}" width="{self.width + 460}" height="{self.height + 140}" '
                'style="border:1px solid #ccc" title="durer preview"></iframe>')

    def __repr__(self) -> str:
        return f"<durer preview at {self.url}>"


def show(scene: Scene | str | os.PathLike, width: int = 480, height: int = 360, *, host: str = "127.0.0.1",
         port: int = 0, mesh_path: list[str] | None = None, **options) -> PreviewHandle:
    """Serve a live view of `scene` (a Scene, or a scene file reloaded when it changes) in a background thread;
    keyword arguments are render options (shadows, bounces, samples, ...) over the scene's own defaults (a Mitsuba
    scene's integrator and samples), as render() takes them. Returns a PreviewHandle."""
    from ..errors import DurerError
    from ..io.loaders import load_scene
    from ..rendering.renderer import make_options
    from .server import PreviewServer
    from .session import PreviewSession

    try:
        loaded = scene if isinstance(scene, Scene) else load_scene(scene, mesh_path)
        defaults = dict(loaded.render_defaults or {})
    except (DurerError, ValueError, OSError):  # a malformed file: the page shows its FILE:LINE until it is fixed
        defaults = {}
    options = {**{k: v for k, v in defaults.items() if k not in ("width", "height")}, **options}
    session = PreviewSession(scene, width, height, make_options(**options), mesh_path=mesh_path)
    server = PreviewServer(session, host, port).start()
    _RUNNING.append(server)
    return PreviewHandle(server, width, height)


def stop_all() -> None:
    """Stop every server show() started."""
    while _RUNNING:
        _RUNNING.pop().stop()


class _CallableModule(types.ModuleType):
    def __call__(self, *args, **kwargs) -> PreviewHandle:
        return show(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
