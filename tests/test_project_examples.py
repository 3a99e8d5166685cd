"""examples/: the notebook runs top to bottom in a real kernel, and shows RenderResults as images."""

from __future__ import annotations

import base64
import io
import os
from pathlib import Path

import numpy as np
import pytest
from conftest import REPO
from PIL import Image

NOTEBOOK = REPO / "examples" / "notebook.ipynb"


@pytest.mark.slow
def test_notebook_runs_and_shows_images(monkeypatch):
    nbformat = pytest.importorskip("nbformat", reason="the notebook test needs nbformat (the 'test' extra)")
    nbclient = pytest.importorskip("nbclient", reason="the notebook test needs nbclient (the 'test' extra)")
    pytest.importorskip("ipykernel", reason="the notebook test needs ipykernel's python3 kernel (the 'test' extra)")
    import durer

    # the kernel imports the same durer as these tests (a relative PYTHONPATH would not survive its working folder)
    src = str(Path(durer.__file__).resolve().parents[1])
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(p for p in (src, os.environ.get("PYTHONPATH")) if p))
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(NOTEBOOK.parent)}}).execute()
    code = [c for c in nb.cells if c.cell_type == "code"]
    images = []
    for cell in code:
        for out in cell.outputs:
            assert out.output_type != "error"
            if "image/png" in out.get("data", {}):
                images.append(np.asarray(Image.open(io.BytesIO(base64.b64decode(out.data["image/png"])))))
    assert [im.shape for im in images] == [(180, 240, 3), (180, 240, 3), (160, 240, 3)]
    for im in images:
        assert im.std() > 10  # a picture, not a flat colour
    text = "".join(o.get("text", "") for o in code[1].outputs)
    assert text.startswith("<RenderResult 240x180: ")
    assert "(180, 240, 3)" in code[1].outputs[-1].data["text/plain"]


def test_example_models_are_what_the_script_makes():
    import json

    import make_examples  # tools/, on the path through conftest

    for name, make in make_examples.MODELS.items():
        assert json.loads((REPO / "examples" / name).read_text()) == json.loads(json.dumps(make())), name
