"""Texture lookups of the path tracer (kernels/path/textures.py through rendering/textures.TextureTable) against
Mitsuba 3's own `bitmap` and `checkerboard` eval (and the checkerboard's eval_1) in scalar_rgb on the same image and UVs: both filters, every wrap
mode, sRGB-decoded and raw, to_uv; and the .hdr reader (io/images.read_hdr) against durer's own writer."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from durer.io.images import read_hdr, read_texture, save_image
from durer.rendering.textures import TextureTable
from durer.scene.textures import Bitmap, Checker

UV = np.array([[0.0, 0.0], [0.125, 5 / 6], [0.1, 0.9], [0.6, 0.3], [1.3, -0.2], [-0.4, 1.7], [0.999, 0.001],
               [2.51, -3.26], [0.5, 0.5]])


def _mitsuba():
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 is the reference for texture lookups")
    mi.set_variant("scalar_rgb")
    return mi


def _mi_eval(mi, tex: dict, uv: np.ndarray) -> np.ndarray:
    t = mi.load_dict(tex)
    out = []
    for u, v in uv:
        si = mi.SurfaceInteraction3f()
        si.uv = mi.Point2f(float(u), float(v))
        out.append(list(t.eval(si)))
    return np.array(out)


@pytest.fixture(scope="module")
def images(tmp_path_factory):
    d = tmp_path_factory.mktemp("tex")
    rng = np.random.default_rng(3)
    Image.fromarray((rng.random((5, 7, 3)) * 255).astype(np.uint8)).save(d / "rgb.png")
    Image.fromarray((rng.random((4, 3)) * 255).astype(np.uint8), mode="L").save(d / "grey.png")
    return d


@pytest.mark.parametrize("name", ["rgb.png", "grey.png"])
@pytest.mark.parametrize("filter_type", ["bilinear", "nearest"])
@pytest.mark.parametrize("wrap", ["repeat", "mirror", "clamp"])
@pytest.mark.parametrize("raw", [False, True])
def test_bitmap_matches_mitsuba(images, name, filter_type, wrap, raw):
    mi = _mitsuba()
    path = str(images / name)
    ref = _mi_eval(mi, {"type": "bitmap", "filename": path, "filter_type": filter_type, "wrap_mode": wrap,
                        "raw": raw}, UV)
    table = TextureTable()
    k = table.add(Bitmap(read_texture(path, raw), filter_type, wrap))
    assert np.allclose(table.eval3(k, UV), ref, atol=2e-6)


def test_to_uv_matches_mitsuba(images):
    mi = _mitsuba()
    m = np.array([[2.0, 0.5, 0.1], [-0.3, 3.0, 0.25], [0, 0, 1]])
    m4 = np.eye(4)
    m4[np.ix_([0, 1, 3], [0, 1, 3])] = m
    path = str(images / "rgb.png")
    ref = _mi_eval(mi, {"type": "bitmap", "filename": path, "to_uv": mi.ScalarTransform4f(m4)}, UV)
    table = TextureTable()
    k = table.add(Bitmap(read_texture(path), to_uv=m))
    assert np.allclose(table.eval3(k, UV), ref, atol=2e-6)


def test_checkerboard_matches_mitsuba():
    mi = _mitsuba()
    m4 = np.diag([4.0, 3.0, 1.0, 1.0])
    ref = _mi_eval(mi, {"type": "checkerboard", "color0": {"type": "rgb", "value": [0.9, 0.1, 0.2]},
                        "color1": {"type": "rgb", "value": [0.1, 0.3, 0.7]},
                        "to_uv": mi.ScalarTransform4f(m4)}, UV)
    table = TextureTable()
    k = table.add(Checker([0.9, 0.1, 0.2], [0.1, 0.3, 0.7], np.diag([4.0, 3.0, 1.0])))
    assert np.allclose(table.eval3(k, UV), ref, atol=1e-7)


@pytest.mark.parametrize("c0,c1", [(0.0, 0.4), ([0.1, 0.2, 0.3], [0.5, 0.6, 0.7])])
def test_checkerboard_number_matches_mitsuba_eval_1(c0, c1):
    """A number read from a checkerboard (a roughdielectric's alpha in bsdf_roughdielectric_textured.xml) is
    Mitsuba 3.9's eval_1, whose cells hold the other colour than eval's (0 and 0.4 the wrong way round made that
    scene 2.4% dark)."""
    from durer.kernels.path.textures import tex_eval1

    mi = _mitsuba()

    def value(c):
        return c if isinstance(c, float) else {"type": "rgb", "value": c}

    t = mi.load_dict({"type": "checkerboard", "color0": value(c0), "color1": value(c1),
                      "to_uv": mi.ScalarTransform4f(np.diag([5.0, 5.0, 1.0, 1.0]))})
    ref = []
    for u, v in UV:
        si = mi.SurfaceInteraction3f()
        si.uv = mi.Point2f(float(u), float(v))
        ref.append(t.eval_1(si))
    table = TextureTable()
    k = table.add(Checker(np.full(3, c0) if isinstance(c0, float) else c0,
                          np.full(3, c1) if isinstance(c1, float) else c1, np.diag([5.0, 5.0, 1.0])))
    TI, TD = table.packed()
    ours = [tex_eval1(TI, TD, k, u, v) for u, v in UV]
    assert np.allclose(ours, ref, atol=1e-6)
    assert len({round(x, 6) for x in ours}) == 2  # both cells are among the points


def test_textures_share_one_table(images):
    """Every bitmap lands in the one texel array at its own offset; the same object added twice is one texture."""
    a = Bitmap(read_texture(str(images / "rgb.png")))
    b = Bitmap(read_texture(str(images / "grey.png")))
    table = TextureTable()
    assert (table.add(a), table.add(b), table.add(a)) == (0, 1, 0)
    TI, TD = table.packed()
    assert TI.shape[0] == 2 and TD.size == 1 + a.image.size + b.image.size
    # a texel centre reads that texel exactly; a grey image gives its value in every channel
    assert np.allclose(table.eval3(1, [[0.5 / 3, 0.5 / 4]]), b.image[0, 0, 0])
    assert np.allclose(table.eval3(0, [[2.5 / 7, 3.5 / 5]]), a.image[3, 2])


def test_hdr_round_trip(tmp_path):
    """durer's .hdr (flat scanlines) and a run-length encoded one read back to the RGBE precision."""
    rng = np.random.default_rng(1)
    img = rng.random((6, 9, 3)) * np.array([1.0, 10.0, 1000.0])
    save_image(str(tmp_path / "a.hdr"), img)
    back = read_hdr(str(tmp_path / "a.hdr"))
    top = img.max(axis=2, keepdims=True)  # one shared exponent: each channel to 1/128 of the pixel's largest
    assert back.shape == img.shape and (np.abs(back - img) <= top / 128).all()
    # new-style RLE: one run of 10 equal pixels per component, then their exponent
    w = 10
    line = bytes([2, 2, 0, w]) + b"".join(bytes([128 + w, value]) for value in (128, 64, 32, 129))
    (tmp_path / "b.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 10\n" + line)
    rle = read_hdr(str(tmp_path / "b.hdr"))
    assert rle.shape == (1, 10, 3) and np.allclose(rle, [1.0, 0.5, 0.25])  # m 2^(e - 136)


def test_missing_texture_is_one_scene_error(tmp_path):
    from durer.errors import SceneError
    from durer.io.mitsuba import load_mitsuba

    (tmp_path / "s.xml").write_text(
        '<scene version="3.0.0">\n<sensor type="perspective"><float name="fov" value="40"/></sensor>\n'
        '<shape type="rectangle">\n<bsdf type="diffuse">\n<texture name="reflectance" type="bitmap">\n'
        '<string name="filename" value="nowhere.png"/>\n</texture></bsdf></shape></scene>\n')
    with pytest.raises(SceneError) as e:
        load_mitsuba(str(tmp_path / "s.xml"))
    assert str(e.value).startswith(f"{tmp_path / 's.xml'}:6:") and "texture image not found: nowhere.png" in str(e.value)
