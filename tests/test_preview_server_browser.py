"""`durer preview` in a real browser: headless Chromium (Debian's `chromium` package, driven by Playwright's Python
package with executable_path; no browser is ever downloaded) against a server started in-process on a free port.

The page loads, converges to the pixels of `durer render` (within 2/255), a drag moves the camera and the image,
a click lists and draws the pixel's ray tree exactly as `durer explain` prints it, and a malformed scene shows its
FILE:LINE message. Every wait is bounded. With DURER_PREVIEW_SCREENSHOT=PATH set, the ray-tree test also saves a
screenshot of the page there (how docs/images/preview.png is made).
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("starlette", reason="the preview extra (starlette) is not installed")
pytest.importorskip("uvicorn", reason="the preview extra (uvicorn) is not installed")
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (the test extra has it)")

CHROMIUM = os.environ.get("DURER_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
if not os.access(CHROMIUM, os.X_OK):
    pytest.skip(f"no chromium browser at {CHROMIUM} (Debian: apt-get install chromium; .ci/run installs it)",
                allow_module_level=True)

import durer  # noqa: E402
from durer.io.images import encode_srgb  # noqa: E402
from durer.preview.server import PreviewServer  # noqa: E402
from durer.preview.session import PreviewSession  # noqa: E402
from durer.rendering.explain import explain  # noqa: E402
from durer.rendering.renderer import make_options  # noqa: E402

pytestmark = pytest.mark.slow  # a real browser: seconds each

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spheres.txt"
W, H = 96, 64
OPTIONS = dict(shadows=True, bounces=3)
PIXEL = (35, 24)  # on the mirror sphere: camera, shadow and reflection rays
WAIT_MS = 60_000
ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update"]


@pytest.fixture(scope="module")
def references():
    """durer render and durer explain of the scene's own view, computed before any server renders."""
    scene = durer.load(EXAMPLE)
    return {"image": encode_srgb(durer.render(scene, W, H, **OPTIONS).color),
            "tree": explain(scene, W, H, *PIXEL, **OPTIONS).text()}


@pytest.fixture(scope="module")
def browser():
    with sync_api.sync_playwright() as p:
        try:
            b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS, timeout=WAIT_MS)
        except sync_api.Error as e:
            pytest.skip(f"chromium at {CHROMIUM} does not start: {str(e).splitlines()[0]}")
        yield b
        b.close()


def _serve(source, width, height, options):
    session = PreviewSession(source, width, height, make_options(**options), poll=0.1)
    return PreviewServer(session, "127.0.0.1", 0).start()


@pytest.fixture(scope="module")
def server(references):
    srv = _serve(EXAMPLE, W, H, OPTIONS)
    yield srv
    srv.stop()


@pytest.fixture
def page(browser, server):
    pg = browser.new_page(viewport={"width": 1400, "height": 800})
    pg.set_default_timeout(WAIT_MS)
    pg.goto(server.url)
    yield pg
    pg.close()


def _wait_final(page, camera_differs_from: str | None = None) -> str:
    """Wait until the image shows the final frame of the current state (of a camera other than the given one);
    returns that frame's camera as JSON. The state message announcing a new camera arrives before its first
    frame, so the condition is on the frame drawn (its generation and camera), not on the state."""
    page.wait_for_function(
        """(old) => { const i = document.getElementById('image');
                      return i.dataset.final === '1' && i.dataset.generation === document.body.dataset.generation
                             && (old === null || i.dataset.camera !== old); }""",
        arg=camera_differs_from, timeout=WAIT_MS)
    return page.evaluate("document.getElementById('image').dataset.camera")


def _pixels(page) -> np.ndarray:
    data = page.evaluate("""() => { const c = document.getElementById('image');
        return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data); }""")
    return np.array(data, dtype=np.uint8).reshape(H, W, 4)[:, :, :3]


def _reset(page) -> str:
    """Back to the scene's camera: its final frame, of the generation the click started. The page may still show
    the final frame of an earlier test's camera (the server's session outlives a page) until the click's state
    message arrives, so the wait starts once the generation has moved past the one before the click."""
    page.wait_for_function("document.body.dataset.generation !== undefined", timeout=WAIT_MS)  # connected
    before = int(page.evaluate("Number(document.body.dataset.generation)"))
    page.click("#reset")
    page.wait_for_function("(g) => Number(document.body.dataset.generation) > g", arg=before, timeout=WAIT_MS)
    return _wait_final(page)


def test_page_loads_and_converges_to_durer_render(page, references):
    assert page.title() == "durer preview"
    assert page.evaluate("[document.getElementById('image').width, document.getElementById('image').height]") == [W, H]
    _reset(page)
    diff = np.abs(_pixels(page).astype(int) - references["image"].astype(int))
    assert diff.max() <= 2, f"{(diff.max(axis=2) > 2).sum()} pixels differ by more than 2/255"
    assert page.inner_text("#status").startswith("done")


def test_drag_changes_camera_and_image(page, references):
    home = _reset(page)
    box = page.locator("#image").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    page.mouse.move(x, y)
    page.mouse.down()
    for step in range(1, 9):
        page.mouse.move(x + 10 * step, y + 2 * step)
    page.mouse.up()
    moved = _wait_final(page, camera_differs_from=home)
    assert moved != home
    assert np.abs(_pixels(page).astype(int) - references["image"].astype(int)).max() > 2
    _reset(page)


def test_click_shows_the_ray_tree_of_durer_explain(page, references):
    _reset(page)
    box = page.locator("#image").bounding_box()
    scale = box["width"] / W
    page.mouse.click(box["x"] + (PIXEL[0] + 0.5) * scale, box["y"] + (PIXEL[1] + 0.5) * scale)
    page.wait_for_function(f"document.getElementById('tree').dataset.pixel === '[{PIXEL[0]},{PIXEL[1]}]'",
                           timeout=WAIT_MS)
    shown = page.evaluate("document.getElementById('tree').textContent")
    assert shown == references["tree"] + "\n"
    assert "reflection o=" in shown and "shadow o=" in shown
    # the rays are drawn: the overlay has opaque red (reflection) pixels
    red = page.evaluate("""() => { const c = document.getElementById('overlay');
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
        for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 200 && d[i] > 200 && d[i + 1] < 100) n++; return n; }""")
    assert red > 10
    shot = os.environ.get("DURER_PREVIEW_SCREENSHOT")
    if shot:  # turn the view a little so the camera ray shows as a line too, as in the course's ray-tree window
        home = page.evaluate("document.body.dataset.camera")
        page.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        page.mouse.down()
        for step in range(1, 7):
            page.mouse.move(box["x"] + box["width"] / 2 - 6 * step, box["y"] + box["height"] / 2 + step)
        page.mouse.up()
        _wait_final(page, camera_differs_from=home)
        page.wait_for_timeout(300)
        from PIL import Image

        png = page.screenshot(clip={"x": 0, "y": 0, "width": 1180, "height": 370})
        Image.open(io.BytesIO(png)).convert("RGB").quantize(96).save(shot, optimize=True)
        _reset(page)


def test_malformed_scene_shows_file_and_line(browser, tmp_path):
    scene = tmp_path / "broken.txt"
    (tmp_path / "cube.obj").write_bytes((EXAMPLE.parent / "cube.obj").read_bytes())  # the scene's mesh, beside it
    text = EXAMPLE.read_text()
    scene.write_text(text.replace("angle 35", "angle thirty-five"))
    line = 1 + next(i for i, x in enumerate(text.splitlines()) if "angle 35" in x)
    srv = _serve(scene, 16, 12, {})
    pg = browser.new_page()
    try:
        pg.set_default_timeout(WAIT_MS)
        pg.goto(srv.url)
        pg.wait_for_selector("#error", state="visible", timeout=WAIT_MS)
        assert pg.inner_text("#error").startswith(f"{scene}:{line}:")
        scene.write_text(text)  # fixed: the page clears the message and shows the image
        pg.wait_for_selector("#error", state="hidden", timeout=WAIT_MS)
        _wait_final(pg)
    finally:
        pg.close()
        srv.stop()


CORNELL = EXAMPLE.parent / "cornell_box.xml"
PATH = dict(integrator="path", samples=8, max_depth=8)


def test_mitsuba_scene_refines_progressively_to_durer_render(browser):
    """The Cornell box path-traced: after a change the page shows 1, 2, 4, then 8 samples per pixel at full size,
    ending in `durer render`'s image."""
    size = (32, 24)
    expected = encode_srgb(durer.render(durer.load(CORNELL), *size, **PATH).color)
    srv = _serve(CORNELL, *size, PATH)
    pg = browser.new_page()
    received = []  # every frame message the page receives (a drawn frame may be skipped for a newer one)
    pg.on("websocket", lambda ws: ws.on("framereceived", lambda payload: received.append(payload)))
    try:
        pg.set_default_timeout(WAIT_MS)
        pg.goto(srv.url)
        _wait_final(pg)
        received.clear()
        pg.evaluate("""() => { window.seen = []; const i = document.getElementById('image');
            new MutationObserver(() => { if (i.dataset.level !== undefined)
                window.seen.push([+i.dataset.level, +i.dataset.samples, i.dataset.final]); })
              .observe(i, {attributes: true, attributeFilter: ['data-final']}); }""")
        pg.click("#reset")  # a new generation: the levels start again
        pg.wait_for_function("window.seen.some(s => s[2] === '1')", timeout=WAIT_MS)
        seen = pg.evaluate("window.seen")  # [level, spp, final] of each frame drawn (a frame may be skipped
        samples = [s for _, s, _ in seen]   # when a newer one arrives while it decodes)
        assert samples == sorted(samples) and seen[-1][1:] == [8, "1"]
        frames = [m for m in (json.loads(r) for r in received if isinstance(r, str)) if m.get("type") == "frame"]
        sent = [m["samples"] for m in frames if m["level"] >= 3]  # the full-size levels after the coarse ones
        assert any(1 < s < 8 for s in sent), f"no intermediate refinement sent: {sent}"
        shown = np.array(pg.evaluate("""() => { const c = document.getElementById('image');
            return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data); }"""), np.uint8)
        diff = np.abs(shown.reshape(size[1], size[0], 4)[:, :, :3].astype(int) - expected.astype(int))
        assert diff.max() <= 2
        assert pg.inner_text("#status").startswith("done") and "8 spp" in pg.inner_text("#status")
        assert pg.is_disabled("#bounces") and pg.is_disabled("#shadows")  # Whitted's switches, not the path's
    finally:
        pg.close()
        srv.stop()


def test_denoise_toggle_shows_durer_render_denoise(browser, page):
    """The course scene (Whitted) greys the toggle out, its tooltip saying why; on the path-traced Cornell box it
    is enabled and off, and ticking it shows `durer render --denoise`'s image, the status saying it is denoised."""
    assert page.is_disabled("#denoise") and not page.is_checked("#denoise")
    assert "path tracer" in page.get_attribute("#denoise-label", "title")
    pytest.importorskip("pyoidn", reason="the denoise extra (pyoidn) is not installed")
    size = (32, 24)
    expected = encode_srgb(durer.render(durer.load(CORNELL), *size, denoise=True, **PATH).color)
    srv = _serve(CORNELL, *size, PATH)
    pg = browser.new_page()
    try:
        pg.set_default_timeout(WAIT_MS)
        pg.goto(srv.url)
        _wait_final(pg)
        assert pg.is_enabled("#denoise") and not pg.is_checked("#denoise")
        assert pg.evaluate("document.getElementById('image').dataset.denoised") == "0"
        pg.check("#denoise")
        pg.wait_for_function("""() => { const i = document.getElementById('image');
            return i.dataset.denoised === '1' && i.dataset.final === '1'
                   && i.dataset.generation === document.body.dataset.generation; }""", timeout=WAIT_MS)
        shown = np.array(pg.evaluate("""() => { const c = document.getElementById('image');
            return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data); }"""), np.uint8)
        diff = np.abs(shown.reshape(size[1], size[0], 4)[:, :, :3].astype(int) - expected.astype(int))
        assert diff.max() <= 2
        assert "denoised" in pg.inner_text("#status")
    finally:
        pg.close()
        srv.stop()


def test_a_failing_render_shows_its_one_line_instead_of_connecting(browser, monkeypatch):
    """The render thread fails before the page connects: the page still shows why, in the error box."""
    from durer.preview import session as session_module

    def broken(ctx, width, height):
        raise RuntimeError("the kernel fell over\nmore detail")

    monkeypatch.setattr(session_module, "render_view", broken)
    srv = _serve(EXAMPLE, 16, 12, {})
    pg = browser.new_page()
    try:
        deadline = WAIT_MS / 1000
        while srv.session.failure is None and deadline > 0:
            pg.wait_for_timeout(50)
            deadline -= 0.05
        pg.set_default_timeout(WAIT_MS)
        pg.goto(srv.url)
        pg.wait_for_selector("#error", state="visible", timeout=WAIT_MS)
        assert pg.inner_text("#error") == "render failed: RuntimeError: the kernel fell over"
        assert not pg.inner_text("#status").startswith("connecting")
    finally:
        pg.close()
        srv.stop()
