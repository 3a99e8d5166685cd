"""The preview on Mitsuba scenes and the path tracer (preview/session.py), without a browser: progressive levels of
more and more samples ending in exactly `durer render`'s image, the ray tree of `durer explain`, the scene's own
defaults from the command, and a failing render reported as one line to every page, also pages that connect later.
"""

from __future__ import annotations

import base64
import io
import json
import os
import queue
import signal
import subprocess
import sys
import urllib.request
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import durer
from durer.io.images import encode_srgb
from durer.preview import session as session_module
from durer.preview.session import PreviewSession, levels_for
from durer.rendering.explain import explain
from durer.rendering.renderer import make_options

CORNELL = Path(__file__).resolve().parents[1] / "examples" / "cornell_box.xml"
SPHERES = CORNELL.parent / "spheres.txt"
TIMEOUT = 120.0  # seconds for any one wait (first renders may compile kernels)
PATH = dict(integrator="path", samples=8, max_depth=8, seed=2)


class Inbox:
    """A session listener: every message in a queue, read until one matches within TIMEOUT."""

    def __init__(self):
        self.messages: queue.Queue = queue.Queue()

    def __call__(self, message: dict) -> None:
        self.messages.put(message)

    def until(self, predicate) -> dict:
        while True:
            message = self.messages.get(timeout=TIMEOUT)
            if predicate(message):
                return message


def _pixels(message: dict) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(base64.b64decode(message["png"]))).convert("RGB"))


def test_path_levels_double_the_samples_up_to_the_requested_count():
    levels = levels_for(make_options(**PATH))
    assert [(f, o.samples) for f, o in levels] == [(8, 1), (4, 1), (2, 1), (1, 1), (1, 2), (1, 4), (1, 8)]
    assert levels[-1][1] == make_options(**PATH)
    whitted = levels_for(make_options(shadows=True, samples=4))
    assert [(f, o.samples) for f, o in whitted] == [(8, 1), (4, 1), (2, 1), (1, 1), (1, 4)]


def test_cornell_box_refines_to_durer_render_and_explains_its_pixels():
    scene = durer.load(CORNELL)
    reference = encode_srgb(durer.render(scene, 24, 20, options=make_options(**PATH)).color)
    tree = explain(scene, 24, 20, 12, 6, **PATH)
    session = PreviewSession(CORNELL, 24, 20, make_options(**PATH), poll=0.1)
    inbox = Inbox()
    session.subscribe(inbox)
    session.start()
    try:
        samples = [inbox.until(lambda m: m["type"] == "frame" and m["frame_width"] == 24)["samples"]]
        while samples[-1] < PATH["samples"]:
            samples.append(inbox.until(lambda m: m["type"] == "frame")["samples"])
        assert samples == [1, 2, 4, 8]
        last = session._last[0]
        assert last["final"] and np.array_equal(_pixels(last), reference)
        shown = session.explain(12, 6).result(TIMEOUT)
        assert shown["text"] == tree.text() and "light sample" in shown["text"]
        assert shown["overlay"] and {key for key, _ in shown["overlay"]} >= {"camera", "shadow"}
    finally:
        session.stop()


def test_a_failing_render_is_one_line_for_every_page_until_a_render_works(monkeypatch):
    real = session_module.render_view

    def broken(ctx, width, height):
        raise RuntimeError("the kernel fell over\nsecond line of detail")

    monkeypatch.setattr(session_module, "render_view", broken)
    session = PreviewSession(SPHERES, 16, 12, make_options(), poll=0.1)
    first = Inbox()
    session.subscribe(first)
    session.start()
    try:
        error = first.until(lambda m: m["type"] == "error")
        assert error["message"] == "render failed: RuntimeError: the kernel fell over"
        late = Inbox()  # a page that connects after the failure still sees it
        session.subscribe(late)
        assert late.until(lambda m: m["type"] == "error")["message"] == error["message"]
        monkeypatch.setattr(session_module, "render_view", real)
        session.configure(samples=4)  # any change renders again; the message goes once a frame is drawn
        assert late.until(lambda m: m["type"] == "error")["message"] is None
        assert late.until(lambda m: m["type"] == "frame" and m["final"])["samples"] == 4
    finally:
        session.stop()


@pytest.mark.slow
def test_the_command_takes_the_scenes_film_integrator_and_samples():
    """`durer preview examples/cornell_box.xml` starts as `durer render` would: 256x256, path tracer, 64 spp."""
    proc = subprocess.Popen([sys.executable, "-m", "durer", "preview", str(CORNELL), "--port", "0", "--no-browser"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))
    try:
        line = proc.stdout.readline()
        assert line.startswith("durer preview: "), line + proc.stderr.read()
        url = line.split(" at ")[1].split()[0]
        with urllib.request.urlopen(url + "state", timeout=TIMEOUT) as response:
            state = json.loads(response.read())
        assert (state["width"], state["height"], state["integrator"], state["samples"]) == (256, 256, "path", 64)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
    assert code == 130, proc.stderr.read()


@pytest.mark.parametrize("integrator", ["whitted", "raycast"])
def test_course_integrators_on_a_mitsuba_scene_say_why_in_one_line(integrator):
    session = PreviewSession(CORNELL, 8, 8, make_options(integrator=integrator), poll=0.1)
    inbox = Inbox()
    session.subscribe(inbox)
    session.start()
    try:
        message = inbox.until(lambda m: m["type"] == "error")["message"]
        assert message.startswith("render failed: ValueError: the scene has physically based materials")
        assert "\n" not in message
    finally:
        session.stop()


def test_notebook_preview_of_a_mitsuba_file_takes_its_integrator():
    handle = durer.preview(str(CORNELL), 16, 12, samples=2)
    try:
        session = handle.server.session
        assert (session.options.integrator, session.options.max_depth, session.options.samples) == ("path", 8, 2)
        inbox = Inbox()
        session.subscribe(inbox)
        assert inbox.until(lambda m: m["type"] == "frame" and m["final"])["samples"] == 2
    finally:
        handle.stop()
