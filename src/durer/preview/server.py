"""The preview's web server: a Starlette app (the page, its script, a WebSocket per page) run by uvicorn.

The WebSocket carries JSON both ways. From the server: `state` (size, mode, options, camera), `frame` (a PNG in
base64, its level and whether it is final), `tree` (a pixel's ray tree, its text and its rays projected into the
image), `error` (a scene file's `FILE:LINE: message`, or null once fixed), `notice` (a refused request). From the
page: `orbit`/`pan` {dx, dy} in image pixels, `zoom` {factor}, `reset`, `set` {mode, samples, bounces, shadows,
denoise}, `explain` {x, y}, `clear`. Renders run on the session's worker thread; the event loop only relays messages.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import socket
import threading
from pathlib import Path

from starlette.applications import Starlette
from starlette.responses import FileResponse, JSONResponse
from starlette.routing import Mount, Route, WebSocketRoute
from starlette.staticfiles import StaticFiles
from starlette.websockets import WebSocket, WebSocketDisconnect

from .session import PreviewSession

STATIC = Path(__file__).resolve().parent / "static"


def create_app(session: PreviewSession) -> Starlette:
    """The app for one session; its lifespan starts and stops the session's worker thread."""

    async def index(request):
        return FileResponse(STATIC / "index.html", media_type="text/html")

    async def state(request):
        return JSONResponse(session.state())

    async def stream(ws: WebSocket):
        await ws.accept()
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue = asyncio.Queue()

        def listener(message: dict) -> None:  # called on the worker thread (or here): hand over to the loop
            loop.call_soon_threadsafe(queue.put_nowait, message)

        unsubscribe = session.subscribe(listener)
        sender = asyncio.create_task(_send_all(ws, queue))
        try:
            while True:
                try:
                    request = json.loads(await ws.receive_text())
                    await _handle(session, request)
                except (ValueError, TypeError, KeyError) as e:  # a bad request: tell the page, keep serving
                    queue.put_nowait({"type": "notice", "message": str(e)})
        except WebSocketDisconnect:
            pass
        finally:
            unsubscribe()
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await sender

    @contextlib.asynccontextmanager
    async def lifespan(app):
        session.start()
        try:
            yield
        finally:
            await asyncio.to_thread(session.stop)

    routes = [Route("/", index), Route("/state", state), WebSocketRoute("/ws", stream),
              Mount("/static", StaticFiles(directory=STATIC), name="static")]
    return Starlette(routes=routes, lifespan=lifespan)


async def _send_all(ws: WebSocket, queue: asyncio.Queue) -> None:
    while True:
        message = await queue.get()
        try:
            await ws.send_text(json.dumps(message, allow_nan=False))
        except (WebSocketDisconnect, RuntimeError):
            return


async def _handle(session: PreviewSession, request: dict) -> None:
    """Apply one request from the page. Explain waits for the worker without blocking the loop."""
    kind = request["type"]
    if kind == "orbit":
        session.orbit(float(request["dx"]), float(request["dy"]))
    elif kind == "pan":
        session.pan(float(request["dx"]), float(request["dy"]))
    elif kind == "zoom":
        session.zoom(float(request["factor"]))
    elif kind == "reset":
        session.reset()
    elif kind == "set":
        session.configure(**{k: request[k] for k in ("mode", "samples", "bounces", "shadows", "denoise")
                                if k in request})
    elif kind == "explain":
        await asyncio.wrap_future(session.explain(int(request["x"]), int(request["y"])))
    elif kind == "clear":
        session.clear_tree()
    else:
        raise ValueError(f"unknown request {kind!r}")


def bind(host: str, port: int) -> socket.socket:
    """A listening socket on host:port (0: a free port); OSError when the port is taken."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((host, port))
        sock.listen(128)
    except OSError:
        sock.close()
        raise
    sock.set_inheritable(True)
    return sock


class PreviewServer:
    """uvicorn serving create_app(session) on a bound socket, in the calling thread (run) or a thread (start)."""

    def __init__(self, session: PreviewSession, host: str = "127.0.0.1", port: int = 0):
        import uvicorn

        self.session = session
        self.socket = bind(host, port)
        self.host, self.port = host, self.socket.getsockname()[1]
        config = uvicorn.Config(create_app(session), log_level="warning", lifespan="on", ws="auto")
        self.server = uvicorn.Server(config)
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    def run(self) -> None:
        """Serve until stopped (Ctrl+C)."""
        try:
            self.server.run(sockets=[self.socket])
        finally:
            self.socket.close()

    def start(self, timeout: float = 20.0) -> PreviewServer:
        """Serve in a daemon thread; returns once the server accepts connections."""
        self._thread = threading.Thread(target=self.run, name="durer-preview-server", daemon=True)
        self._thread.start()
        waited = 0.0
        while not self.server.started and waited < timeout and self._thread.is_alive():
            threading.Event().wait(0.02)
            waited += 0.02
        if not self.server.started:
            raise RuntimeError(f"the preview server did not start within {timeout} s")
        return self

    def stop(self, timeout: float = 20.0) -> None:
        self.server.should_exit = True
        if self._thread is not None:
            self._thread.join(timeout)
