"""Image writers: formats by extension, course quantisation, sRGB, raw floats, atomic writes."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from durer import UsageError
from durer.io.images import (
    depth_visualization,
    encode_srgb,
    normal_visualization,
    quantize_course,
    save_image,
    write_atomic,
)


def test_course_quantisation_truncates_like_the_course():
    assert quantize_course(np.array([0.0, 0.5, 0.999, 1.0, 1.5, -0.2])).tolist() == [0, 127, 254, 255, 255, 0]


def test_srgb_encoding_known_values():
    # 0.0031308 is where the linear segment meets the curve (12.92 * x = 0.0404); 0.18 is mid grey
    assert encode_srgb(np.array([0.0, 0.0031308, 0.18, 1.0])).tolist() == [0, 10, 118, 255]


def test_depth_visualisation_near_white_far_black_miss_black():
    t = np.array([9.0, 9.5, 10.0, 11.0, 8.0, np.inf])
    np.testing.assert_allclose(depth_visualization(t, 9, 10), [1, 0.5, 0, 0, 1, 0])


def test_normal_visualisation_is_absolute():
    np.testing.assert_allclose(normal_visualization(np.array([[0, 0, -1.0], [-0.6, 0.8, 0]])), [[0, 0, 1], [0.6, 0.8, 0]])


@pytest.mark.parametrize("ext", [".png", ".tga", ".ppm", ".bmp"])
def test_eight_bit_formats_round_trip(tmp_path, ext):
    data = np.zeros((2, 3, 3))
    data[0, 0] = [1, 0, 0]
    data[1, 2] = [0, 0.5, 1]
    path = tmp_path / f"x{ext}"
    save_image(str(path), data, course=True)
    back = np.asarray(Image.open(path).convert("RGB"))
    assert back.shape == (2, 3, 3)
    assert back[0, 0].tolist() == [255, 0, 0] and back[1, 2].tolist() == [0, 127, 255]


def test_grey_images_become_rgb(tmp_path):
    save_image(str(tmp_path / "g.png"), np.full((2, 2), 0.5), course=True)
    assert np.asarray(Image.open(tmp_path / "g.png")).shape == (2, 2, 3)


def test_npy_keeps_floats(tmp_path):
    data = np.array([[1.5, np.inf]])
    save_image(str(tmp_path / "d.npy"), data)
    back = np.load(tmp_path / "d.npy")
    assert back.dtype == np.float32 and back.tolist() == [[1.5, np.inf]]


def test_pfm_header_and_bottom_up_rows(tmp_path):
    data = np.arange(12, dtype=np.float32).reshape(2, 2, 3)
    save_image(str(tmp_path / "c.pfm"), data)
    raw = (tmp_path / "c.pfm").read_bytes()
    header = b"PF\n2 2\n-1.0\n"
    assert raw.startswith(header)
    pixels = np.frombuffer(raw[len(header):], dtype="<f4").reshape(2, 2, 3)
    np.testing.assert_array_equal(pixels, data[::-1])
    save_image(str(tmp_path / "d.pfm"), np.ones((2, 2)))
    assert (tmp_path / "d.pfm").read_bytes().startswith(b"Pf\n2 2\n")


def test_unknown_extension(tmp_path):
    with pytest.raises(UsageError, match="unknown image extension '.webp'"):
        save_image(str(tmp_path / "x.webp"), np.zeros((1, 1, 3)))
    assert not list(tmp_path.iterdir())


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "out.png"
    target.write_bytes(b"old")

    def fail(f):
        f.write(b"partial")
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError):
        write_atomic(str(target), fail)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["out.png"]


def test_written_files_get_the_usual_permissions(tmp_path):
    import os

    save_image(str(tmp_path / "x.png"), np.zeros((1, 1, 3)))
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "x.png").stat().st_mode & 0o777 == 0o666 & ~mask


def test_exr_keeps_floats_colour_and_grey(tmp_path):
    exr = pytest.importorskip("OpenEXR", reason="the openexr package writes .exr")
    from durer.io.images import save_image as save

    rgb = np.random.default_rng(0).random((5, 7, 3)).astype(np.float32) * 100
    grey = np.arange(35, dtype=np.float32).reshape(5, 7)
    save(str(tmp_path / "c.exr"), rgb)
    save(str(tmp_path / "g.exr"), grey)
    with exr.File(str(tmp_path / "c.exr")) as f:
        np.testing.assert_array_equal(f.channels()["RGB"].pixels, rgb)
    with exr.File(str(tmp_path / "g.exr")) as f:
        np.testing.assert_array_equal(f.channels()["Y"].pixels, grey)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.exr", "g.exr"]  # no temporary file left


def test_exr_without_the_package_is_a_clear_error(tmp_path, monkeypatch):
    import sys

    from durer.io.images import save_image as save

    monkeypatch.setitem(sys.modules, "OpenEXR", None)  # import fails as if not installed
    with pytest.raises(UsageError, match="needs the openexr package"):
        save(str(tmp_path / "c.exr"), np.zeros((2, 2, 3)))
    assert not list(tmp_path.iterdir())
