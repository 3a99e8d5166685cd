"""`durer preview SCENE`: serve the live view (server.py) and open it in the browser.

cli.py registers the command and hands over its shared render flags, so the view starts as `durer render` with
the same flags would draw it.
"""

from __future__ import annotations

import argparse
import os
import sys

from ..errors import UsageError

DEFAULT_PORT = 8765


# how `durer preview` introduces itself; cli.py builds the parser and adds the shared render flags
PARSER = dict(prog="durer preview",
              usage="durer preview SCENE [--host H] [--port P] [--no-browser] [render options]",
              description="Show a scene live in the browser: progressive rendering, orbit (drag), pan "
                          "(shift- or right-drag), zoom (wheel), colour/depth/normals, samples and bounces, "
                          "and a click shows that pixel's ray tree. Editing the scene file reloads it.",
              epilog="Needs the preview extra: pip install 'durer[preview]'. Exit status 2 on a user error "
                     "(a missing scene file, a port in use); a malformed scene is shown on the page.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The flags of `durer preview` besides the render flags every rendering command shares."""
    p.add_argument("scene", help="scene file (reloaded when it changes)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default: 127.0.0.1, this machine only)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT,
                   help=f"port to listen on, 0 for any free port (default: {DEFAULT_PORT})")
    p.add_argument("--no-browser", action="store_true", help="only print the address, do not open a browser")


def preview_command(a: argparse.Namespace, render_options, scene_size) -> int:
    """Run `durer preview` on parsed arguments until interrupted; render_options and scene_size make the options
    and the image size as `durer render` would from the same flags and scene."""
    render_options(a)  # a bad flag is reported before anything is read
    if not os.path.isfile(a.scene):
        raise UsageError(f"{a.scene}: no such scene file")
    if not 0 <= a.port <= 65535:
        raise UsageError(f"--port: expected 0 to 65535, got {a.port}")
    from ..errors import DurerError
    from ..io.loaders import load_scene

    try:  # the scene's own defaults (a Mitsuba scene's integrator, samples, film), as `durer render` applies them
        scene = load_scene(a.scene, a.mesh_path)
    except (DurerError, ValueError, OSError):  # a malformed file: the page shows its FILE:LINE until it is fixed
        opts, size = render_options(a), a.size or (512, 512)
    else:
        opts, size = render_options(a, scene.render_defaults), scene_size(a, scene)
    try:
        from .server import PreviewServer
    except ImportError as e:
        raise UsageError(f"durer preview needs the preview extra ({e.name} is missing): "
                         "pip install 'durer[preview]'") from None
    from .session import PreviewSession

    session = PreviewSession(a.scene, size[0], size[1], opts, mesh_path=a.mesh_path)
    try:
        server = PreviewServer(session, a.host, a.port)
    except OSError as e:
        raise UsageError(f"cannot listen on {a.host}:{a.port}: {e.strerror or e}") from None

    def report(message: dict) -> None:  # scene errors go to the terminal too, one line each
        if message.get("type") == "error" and message.get("message"):
            print(message["message"], file=sys.stderr, flush=True)

    session.subscribe(report)
    print(f"durer preview: {a.scene} at {server.url} (Ctrl+C stops)", flush=True)
    if not a.no_browser:
        import webbrowser

        webbrowser.open(server.url)
    server.run()
    # the server stops only on a signal (uvicorn takes SIGINT/SIGTERM and returns, re-raising the signal only when no
    # asyncio runner's handler intercepts it first): stopping is an interruption, status 130 like any durer command
    raise KeyboardInterrupt
