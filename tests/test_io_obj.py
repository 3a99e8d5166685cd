"""The course OBJ reader: faces in file order, fans, v/vt/vn corners, and line-accurate errors."""

from __future__ import annotations

import pytest

from durer import SceneError
from durer.io.obj import read_obj


def test_quads_fan_and_slash_corners(tmp_path):
    p = tmp_path / "m.obj"
    p.write_text("# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -1 -2 -3\n")
    v, f = read_obj(str(p))
    assert v.shape == (4, 3)
    assert f.tolist() == [[0, 1, 2], [0, 2, 3], [3, 2, 1]]


@pytest.mark.parametrize("text, line, message", [
    ("v 0 0\nf 1 1 1\n", 1, "three coordinates"),
    ("v 0 0 x\n", 1, "not a number"),
    ("v 0 0 0\nf 1 2\n", 2, "at least three"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 a\n", 4, "not an integer"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "face index 0 out of range"),
    ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 1 2\n", 4, "face index -4 out of range"),
])
def test_errors_name_the_line(tmp_path, text, line, message):
    p = tmp_path / "bad.obj"
    p.write_text(text)
    with pytest.raises(SceneError, match=message) as e:
        read_obj(str(p))
    assert e.value.line == line and e.value.path == str(p)


def test_no_faces(tmp_path):
    p = tmp_path / "empty.obj"
    p.write_text("v 0 0 0\n")
    with pytest.raises(SceneError, match="no faces"):
        read_obj(str(p))
