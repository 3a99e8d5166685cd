"""preview/server.py, session.py and command.py without a browser: the HTTP routes (Starlette's TestClient) and
the WebSocket protocol against a real server on a free port, every wait bounded.

References (durer render, explain) are computed before a server starts: all Numba work of the server runs on its
one worker thread, and the tests never render at the same time from another thread.
"""

from __future__ import annotations

import base64
import io
import json
import socket
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("starlette", reason="the preview extra (starlette) is not installed")
pytest.importorskip("uvicorn", reason="the preview extra (uvicorn) is not installed")
pytest.importorskip("httpx", reason="Starlette's TestClient needs httpx")
ws_client = pytest.importorskip("websockets.sync.client", reason="the preview extra (websockets) is not installed")

from PIL import Image  # noqa: E402
from starlette.testclient import TestClient  # noqa: E402

import durer  # noqa: E402
from durer.cli import main  # noqa: E402
from durer.io.images import encode_srgb, normal_visualization, quantize_course  # noqa: E402
from durer.preview.server import PreviewServer, create_app  # noqa: E402
from durer.preview.session import PreviewSession  # noqa: E402
from durer.rendering.explain import explain  # noqa: E402
from durer.rendering.renderer import make_options  # noqa: E402

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spheres.txt"
W, H = 48, 32
OPTIONS = dict(shadows=True, bounces=2)
TIMEOUT = 60.0  # seconds for any one wait (first renders may compile kernels)


class Client:
    """A WebSocket to the server that reads messages until one matches, within TIMEOUT."""

    def __init__(self, url: str):
        self.ws = ws_client.connect(url.replace("http://", "ws://") + "ws", open_timeout=TIMEOUT).__enter__()

    def send(self, **message) -> None:
        self.ws.send(json.dumps(message))

    def until(self, predicate, timeout: float = TIMEOUT) -> dict:
        end = time.monotonic() + timeout
        while True:
            left = end - time.monotonic()
            if left <= 0:
                raise AssertionError("no matching message within the time limit")
            message = json.loads(self.ws.recv(timeout=left))
            if predicate(message):
                return message

    def final_frame(self, generation: int | None = None) -> dict:
        return self.until(lambda m: m["type"] == "frame" and m["final"]
                          and (generation is None or m["generation"] >= generation))

    def close(self) -> None:
        self.ws.close()


def png_pixels(message: dict) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(message["png"]))).convert("RGB"))


@pytest.fixture(scope="module")
def references():
    scene = durer.load(EXAMPLE)
    result = durer.render(scene, W, H, **OPTIONS)
    tree = explain(scene, W, H, 30, 20, **OPTIONS)
    return {"color": encode_srgb(result.color), "normals": quantize_course(normal_visualization(result.normals)),
            "tree": tree}


@pytest.fixture(scope="module")
def server(references):
    session = PreviewSession(EXAMPLE, W, H, make_options(**OPTIONS))
    srv = PreviewServer(session, "127.0.0.1", 0).start()
    yield srv
    srv.stop()


@pytest.fixture
def client(server):
    c = Client(server.url)
    yield c
    c.close()


def test_page_script_and_state_routes():
    session = PreviewSession(EXAMPLE, W, H, make_options(**OPTIONS))
    with TestClient(create_app(session)) as http:
        page = http.get("/")
        assert page.status_code == 200 and "text/html" in page.headers["content-type"]
        assert 'src="static/preview.js"' in page.text and 'id="tree"' in page.text
        script = http.get("/static/preview.js")
        assert script.status_code == 200 and "new WebSocket" in script.text
        state = http.get("/state").json()
        assert (state["width"], state["height"], state["bounces"], state["shadows"]) == (W, H, 2, True)
        assert state["camera"]["type"] == "PerspectiveCamera" and state["camera"]["angle"] == 35.0
        with http.websocket_connect("/ws") as ws:  # the state is sent at once on connection
            assert ws.receive_json()["type"] == "state"
        assert http.get("/static/missing.js").status_code == 404


def test_progressive_frames_end_in_durer_renders_image(server, client, references):
    first = client.until(lambda m: m["type"] == "state")  # sent on connection
    client.send(type="set", bounces=2)  # a new generation: watch all its levels
    state = client.until(lambda m: m["type"] == "state" and m["generation"] > first["generation"])
    frames = []
    while not (frames and frames[-1]["final"]):
        frames.append(client.until(lambda m: m["type"] == "frame" and m["generation"] == state["generation"]))
    assert [f["frame_width"] for f in frames] == [6, 12, 24, 48]  # 1/8, 1/4, 1/2, full
    assert frames[0]["seconds"] < 0.5  # the coarse image: a fraction of a second
    assert np.array_equal(png_pixels(frames[-1]), references["color"])


def test_explain_over_the_socket_equals_explain(server, client, references):
    client.send(type="reset")
    client.final_frame()
    client.send(type="explain", x=30, y=20)
    message = client.until(lambda m: m["type"] == "tree" and m["tree"] and m["tree"]["pixel"] == [30, 20])
    assert message["text"] == references["tree"].text()
    assert message["tree"] == json.loads(json.dumps(references["tree"].to_json()))
    kinds = {key for key, _ in message["overlay"]}
    assert "camera" in kinds and kinds <= {"camera", "shadow", "blocked", "reflection", "refraction"}
    client.send(type="clear")
    # a redraw of the tree queued before the clear may still arrive first; the clear must then empty it
    cleared = client.until(lambda m: m["type"] == "tree" and m["tree"] is None)
    assert cleared["text"] == "" and cleared["overlay"] == []


def test_orbit_changes_camera_and_image_and_reset_restores_them(server, client, references):
    client.send(type="reset")
    home = client.final_frame()
    client.send(type="orbit", dx=8, dy=0)
    moved = client.until(lambda m: m["type"] == "frame" and m["final"] and m["camera"] != home["camera"])
    assert moved["camera"]["center"][0] != pytest.approx(home["camera"]["center"][0])
    assert not np.array_equal(png_pixels(moved), references["color"])
    client.send(type="zoom", factor=0.8)
    client.send(type="pan", dx=3, dy=2)
    client.send(type="reset")
    back = client.until(lambda m: m["type"] == "frame" and m["final"] and m["camera"] == home["camera"])
    assert np.array_equal(png_pixels(back), references["color"])


def test_modes_show_normals_and_depth(server, client, references):
    client.send(type="reset")
    client.final_frame()
    client.send(type="set", mode="normals")
    normals = client.until(lambda m: m["type"] == "frame" and m["mode"] == "normals" and m["final"])
    assert np.array_equal(png_pixels(normals), references["normals"])
    client.send(type="set", mode="depth")
    depth = png_pixels(client.until(lambda m: m["type"] == "frame" and m["mode"] == "depth" and m["final"]))
    assert depth.max() == 255 and depth[0, 0].tolist() == [0, 0, 0]  # nearest hit white; the sky is a miss
    client.send(type="set", mode="color")
    client.until(lambda m: m["type"] == "frame" and m["mode"] == "color")


@pytest.mark.parametrize("request_, message", [
    (dict(type="set", samples=0), "samples must be an integer from 1 to 64"),
    (dict(type="set", mode="infrared"), "unknown mode 'infrared'"),
    (dict(type="explain", x=W, y=0), f"pixel ({W}, 0) is outside the {W}x{H} image"),
    (dict(type="teleport"), "unknown request 'teleport'"),
])
def test_bad_requests_get_a_notice_and_the_server_goes_on(server, client, request_, message):
    client.send(**request_)
    assert message in client.until(lambda m: m["type"] == "notice")["message"]
    client.send(type="reset")
    client.until(lambda m: m["type"] == "state")


def test_malformed_scene_is_reported_and_fixing_it_reloads(tmp_path):
    scene = tmp_path / "scene.txt"
    (tmp_path / "cube.obj").write_bytes((EXAMPLE.parent / "cube.obj").read_bytes())  # the scene's mesh, beside it
    good = EXAMPLE.read_text()
    scene.write_text(good.replace("angle 35", "angle thirty-five"))
    line = 1 + good.splitlines().index(next(x for x in good.splitlines() if "angle 35" in x))
    session = PreviewSession(scene, 16, 12, make_options(), poll=0.1)
    srv = PreviewServer(session, "127.0.0.1", 0).start()
    try:
        client = Client(srv.url)
        error = client.until(lambda m: m["type"] == "error" and m["message"])
        assert error["message"].startswith(f"{scene}:{line}:")
        scene.write_text(good)
        assert client.until(lambda m: m["type"] == "error")["message"] is None
        assert client.final_frame()["frame_width"] == 16
        client.close()
    finally:
        srv.stop()


def test_notebook_handle_serves_the_page_in_a_frame():
    handle = durer.preview(durer.load(EXAMPLE), 32, 24)
    try:
        assert f'src="{handle.url}"' in handle._repr_html_()
        client = Client(handle.url)
        frame = client.final_frame()
        assert (frame["width"], frame["height"]) == (32, 24)
        client.close()
    finally:
        handle.stop()


def test_cli_errors_exit_2(tmp_path, capsys):
    assert main(["preview", str(tmp_path / "missing.txt"), "--no-browser"]) == 2
    assert "missing.txt: no such scene file" in capsys.readouterr().err
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        assert main(["preview", str(EXAMPLE), "--no-browser", "--port", str(port)]) == 2
    err = capsys.readouterr().err
    assert f"cannot listen on 127.0.0.1:{port}" in err and "Traceback" not in err


def test_the_command_prints_its_address_and_serves_the_page(tmp_path):
    """`durer preview SCENE --port 0 --no-browser` as a user runs it: the URL on stdout, the page there, and
    Ctrl+C (SIGINT) stops it cleanly: status 130 as for any interrupted durer command, no traceback."""
    import os
    import signal
    import subprocess
    import sys
    import urllib.request

    proc = subprocess.Popen([sys.executable, "-m", "durer", "preview", str(EXAMPLE), "--port", "0", "--no-browser",
                             "--size", "16", "12"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ))
    try:
        line = proc.stdout.readline()  # printed once the socket listens
        assert line.startswith(f"durer preview: {EXAMPLE} at http://127.0.0.1:"), line + proc.stderr.read()
        url = line.split(" at ")[1].split()[0]
        with urllib.request.urlopen(url + "state", timeout=TIMEOUT) as response:
            assert json.loads(response.read())["width"] == 16
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
    assert code == 130 and "Traceback" not in proc.stderr.read()


CORNELL = EXAMPLE.parent / "cornell_box.xml"
PATH = dict(integrator="path", samples=4, max_depth=8, seed=2)


def test_denoise_toggle_is_off_by_default_and_says_why_it_is_disabled(monkeypatch):
    """The state the page's toggle shows: off; disabled, with the reason as its tooltip, for a course scene's
    Whitted image and, without pyoidn, with the line that says what to install; a request to denoise there is
    refused with a notice and the server goes on."""
    from durer.errors import MissingDependency
    from durer.preview import session as session_module
    from durer.rendering.denoise import INSTALL

    whitted = PreviewSession(EXAMPLE, W, H, make_options(**OPTIONS))
    with TestClient(create_app(whitted)) as http:
        state = http.get("/state").json()
        assert state["denoise"] is False and "path tracer" in state["denoise_unavailable"]
        page = http.get("/").text
        assert 'id="denoise"' in page and "disabled" in page.split('id="denoise"')[1].split(">")[0]

    def missing():
        raise MissingDependency(INSTALL)

    monkeypatch.setattr(session_module, "require_oidn", missing)
    path = PreviewSession(CORNELL, 16, 16, make_options(**PATH))
    with TestClient(create_app(path)) as http:
        assert http.get("/state").json()["denoise_unavailable"] == INSTALL
        with http.websocket_connect("/ws") as ws:
            ws.send_json({"type": "set", "denoise": True})
            while (m := ws.receive_json())["type"] != "notice":
                pass
            assert m["message"] == f"cannot denoise: {INSTALL}"
        assert http.get("/state").json()["denoise"] is False


def test_denoise_toggle_shows_durer_render_denoise_and_off_again():
    """On: every level of the progressive path-traced image comes denoised, the last one exactly `durer render
    --denoise`'s image of the view; off: the undenoised levels again, ending in `durer render`'s."""
    pytest.importorskip("pyoidn", reason="the denoise extra (pyoidn) is not installed")
    scene = durer.load(CORNELL)
    plain = encode_srgb(durer.render(scene, 24, 24, **PATH).color)
    denoised = durer.render(scene, 24, 24, denoise=True, **PATH)
    assert not np.array_equal(encode_srgb(denoised.color), plain)
    session = PreviewSession(CORNELL, 24, 24, make_options(**PATH))
    srv = PreviewServer(session, "127.0.0.1", 0).start()
    try:
        client = Client(srv.url)
        start = client.final_frame()
        assert start["denoised"] is False and np.array_equal(png_pixels(start), plain)
        client.send(type="set", denoise=True)
        state = client.until(lambda m: m["type"] == "state" and m["denoise"])
        assert state["denoise_unavailable"] is None
        frames = [client.until(lambda m: m["type"] == "frame" and m["generation"] == state["generation"])]
        while not frames[-1]["final"]:
            frames.append(client.until(lambda m: m["type"] == "frame" and m["generation"] == state["generation"]))
        assert all(f["denoised"] and f["denoise_seconds"] > 0 for f in frames)
        assert [f["samples"] for f in frames if f["frame_width"] == 24] == [1, 2, 4]
        assert np.array_equal(png_pixels(frames[-1]), encode_srgb(denoised.color))
        client.send(type="set", denoise=False)
        off = client.until(lambda m: m["type"] == "frame" and m["final"] and not m["denoised"])
        assert np.array_equal(png_pixels(off), plain)
        client.close()
    finally:
        srv.stop()
