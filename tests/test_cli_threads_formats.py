"""`--threads N` on every command and `durer.render(nthreads=N)`; the .jpg, .tiff and .hdr outputs (issue 25)."""

from __future__ import annotations

from pathlib import Path

import numba
import numpy as np
import pytest
from PIL import Image

import durer
from durer.cli import main
from durer.io.images import rgbe, save_image
from durer.options import thread_count

EXAMPLE = str(Path(__file__).resolve().parents[1] / "examples" / "spheres.txt")


@pytest.fixture
def seen_threads(monkeypatch):
    """Numba's thread count inside every render the commands start (the render itself is skipped)."""
    import durer.rendering.renderer as renderer

    seen: list[int] = []
    real = renderer.render

    def record(*args, **kwargs):
        seen.append(numba.get_num_threads())
        return real(*args, **kwargs)

    monkeypatch.setattr(renderer, "render", record)
    return seen


@pytest.mark.parametrize("argv", [
    ["render", EXAMPLE, "-o", "{tmp}/o.png", "--size", "8", "8", "-q", "--threads", "1"],
    ["raycast", "-input", EXAMPLE, "-size", "8", "8", "-output", "{tmp}/o.tga", "-threads", "1"],
    ["explain", EXAMPLE, "--pixel", "4", "4", "--size", "8", "8", "--draw", "{tmp}/o.png", "--threads", "1"],
])
def test_threads_flag_sets_numbas_count_for_the_render_and_restores_it(tmp_path, capsys, seen_threads, argv):
    before = numba.get_num_threads()
    assert main([a.format(tmp=tmp_path) for a in argv]) == 0
    assert seen_threads == [1]
    assert numba.get_num_threads() == before
    capsys.readouterr()


def test_threads_flag_is_checked(tmp_path, capsys):
    assert main(["render", EXAMPLE, "-o", str(tmp_path / "o.png"), "--threads", "-2"]) == 2
    assert "argument --threads/-threads: expected a non-negative integer, got '-2'" in capsys.readouterr().err


def test_every_rendering_command_takes_threads():
    from durer.cli import COMMANDS

    for name, (_, parser) in COMMANDS.items():
        if name == "warmup":  # compiles kernels: nothing to spread over threads
            continue
        help_text = parser().format_help()
        assert "--threads N" in help_text, name


def test_render_takes_nthreads():
    scene = durer.load(EXAMPLE)
    before = numba.get_num_threads()
    one = durer.render(scene, 16, 16, nthreads=1, shadows=True)
    assert numba.get_num_threads() == before
    np.testing.assert_array_equal(one.color, durer.render(scene, 16, 16, nthreads=0, shadows=True).color)
    with pytest.raises(ValueError, match="nthreads must be 0 .all cores. or a positive integer, got -1"):
        durer.render(scene, 16, 16, nthreads=-1)
    with thread_count(1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before


# --- output formats ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("ext, fmt, tolerance", [(".jpg", "JPEG", 40), (".jpeg", "JPEG", 40), (".tif", "TIFF", 0),
                                                 (".tiff", "TIFF", 0)])
def test_jpeg_and_tiff_outputs(tmp_path, capsys, ext, fmt, tolerance):
    out = tmp_path / f"o{ext}"
    assert main(["render", EXAMPLE, "-o", str(out), "--size", "32", "24", "-q"]) == 0
    image = Image.open(out)
    assert image.format == fmt and image.size == (32, 24) and image.mode == "RGB"
    expected = durer.render(durer.load(EXAMPLE), 32, 24, shade_back=True).to_srgb8().astype(int)
    diff = np.abs(np.asarray(image).astype(int) - expected)
    assert diff.max() <= tolerance and diff.mean() <= tolerance / 8


def _read_rgbe(path: Path) -> np.ndarray:
    """The float image of an uncompressed Radiance file (the decoder of Ward's rgbe.c: (m + 0.5) 2^(e - 136))."""
    data = path.read_bytes()
    header, _, rest = data.partition(b"\n\n")
    assert header.startswith(b"#?RADIANCE") and b"FORMAT=32-bit_rle_rgbe" in header
    size, _, pixels = rest.partition(b"\n")
    _, h, _, w = size.split()
    p = np.frombuffer(pixels, np.uint8).reshape(int(h), int(w), 4).astype(np.float64)
    scale = np.where(p[..., 3] > 0, np.ldexp(1.0, p[..., 3].astype(int) - 136), 0.0)
    return (p[..., :3] + 0.5) * scale[..., None] * (p[..., 3:] > 0)


def test_hdr_output_holds_the_linear_floats(tmp_path, capsys):
    out = tmp_path / "o.hdr"
    assert main(["render", EXAMPLE, "-o", str(out), "--size", "32", "24", "-q", "--shadows"]) == 0
    color = durer.render(durer.load(EXAMPLE), 32, 24, shade_back=True, shadows=True).color
    got = _read_rgbe(out)
    assert got.shape == (24, 32, 3) and color.max() > 1.0  # values above 1 survive, as in .exr and .pfm
    step = color.max(axis=2, keepdims=True) / 128  # 8 mantissa bits of the largest channel
    assert (np.abs(got - color) <= step + 1e-12).all()


def test_rgbe_encodes_exactly_where_it_can():
    data = np.array([[[1.0, 0.5, 0.25], [0.0, 0.0, 0.0]], [[-1.0, np.nan, 2.0], [np.inf, 0.0, 0.0]]])
    out = rgbe(data)
    assert out[0, 0].tolist() == [128, 64, 32, 129]   # 1.0 = 0.5 * 2^1: mantissa 128, exponent 1 + 128
    assert out[0, 1].tolist() == [0, 0, 0, 0]
    assert out[1, 0].tolist() == [0, 0, 128, 130]     # negative and NaN are 0; 2.0 = 0.5 * 2^2
    assert out[1, 1].tolist() == [150, 0, 0, 255]     # inf: 1e38 = 0.588 * 2^127, near RGBE's largest value


def test_hdr_matches_mitsubas_reader(tmp_path):
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    data = np.random.default_rng(3).uniform(0, 40, (5, 7, 3))
    save_image(str(tmp_path / "x.hdr"), data)
    got = np.array(mi.Bitmap(str(tmp_path / "x.hdr")))  # Mitsuba decodes m 2^(e - 136), without the half step
    assert got.shape == (5, 7, 3)
    assert (np.abs(got - data) <= data.max(axis=2, keepdims=True) / 128).all()
