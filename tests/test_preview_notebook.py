"""preview/__init__.py: durer.preview(...) in a Jupyter notebook shows the live view inline, in a frame.

Runs a real two-cell notebook in a fresh kernel (nbclient + ipykernel): the first cell's output is the frame
pointing at the server, the second reads the server's state from that address.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytest.importorskip("starlette", reason="the preview extra (starlette) is not installed")
pytest.importorskip("uvicorn", reason="the preview extra (uvicorn) is not installed")
nbformat = pytest.importorskip("nbformat", reason="nbformat is not installed")
nbclient = pytest.importorskip("nbclient", reason="nbclient is not installed")
pytest.importorskip("ipykernel", reason="ipykernel is not installed")

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spheres.txt"


@pytest.mark.slow
def test_notebook_shows_the_preview_in_a_frame():
    cells = [
        f"import durer\nhandle = durer.preview({str(EXAMPLE)!r}, 32, 24, shadows=True)\nhandle",
        "import json, urllib.request\n"
        "state = json.loads(urllib.request.urlopen(handle.url + 'state', timeout=30).read())\n"
        "print(state['width'], state['height'], state['shadows'])\nhandle.stop()",
    ]
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in cells])
    nbclient.NotebookClient(nb, timeout=120, kernel_name="python3").execute()
    html = nb.cells[0].outputs[0]["data"]["text/html"]
    match = re.fullmatch(r'<iframe src="(http://127\.0\.0\.1:\d+/)" width="492" height="164" .*</iframe>', html)
    assert match, html
    assert nb.cells[1].outputs[0]["text"] == "32 24 True\n"
