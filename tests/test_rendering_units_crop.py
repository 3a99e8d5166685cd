"""rendering/units.py's crop window and alpha channel (Mitsuba's hdrfilm crop_* and pixel_format rgba): a crop is
the whole image's window to the bit (its pixels keep their samples and filter halo), alpha is coverage, and both
agree with Mitsuba 3's films."""

from __future__ import annotations

import numpy as np
import pytest

import durer


def _scene(film: dict) -> dict:
    """A diffuse sphere in front of a dark sky, lit by a point light, seen through the film given."""
    return {"type": "scene", "integrator": {"type": "path", "max_depth": 3},
            "sensor": {"type": "perspective", "fov": 40, "film": {"type": "hdrfilm", "width": 40, "height": 30,
                                                                  "rfilter": {"type": "tent"}, **film}},
            "sphere": {"type": "sphere", "center": [0.3, 0.1, 4.0], "radius": 1.0,
                       "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.5, 0.3]}}},
            "light": {"type": "point", "position": [-2.0, 2.0, 0.0], "intensity": {"type": "rgb", "value": 20.0}},
            "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.05}}}


CROP = {"crop_offset_x": 7, "crop_offset_y": 5, "crop_width": 19, "crop_height": 13}


def test_a_crop_is_the_whole_images_window_to_the_bit():
    whole = durer.render(durer.load_dict(_scene({})), samples=8)
    scene = durer.load_dict(_scene(CROP))
    assert scene.render_defaults["crop"] == (7, 5, 19, 13)
    part = durer.render(scene, samples=8)
    assert part.color.shape == (13, 19, 3)
    assert np.array_equal(part.color, whole.color[5:18, 7:26])
    assert np.array_equal(part.depth, whole.depth[5:18, 7:26])


def test_a_crop_outside_the_film_is_refused():
    with pytest.raises(durer.SceneError, match="crop window"):
        durer.load_dict(_scene({**CROP, "crop_width": 40}))
    with pytest.raises(ValueError, match="does not fit"):
        durer.render(durer.load_dict(_scene({})), 20, 20, crop=(5, 5, 16, 4))


def test_alpha_is_the_share_of_samples_that_hit():
    result = durer.render(durer.load_dict(_scene({"pixel_format": "rgba"})), samples=16)
    alpha = result.alpha
    assert result.rgba.shape == (30, 40, 4) and np.array_equal(result.rgba[..., 3], alpha)
    assert alpha.min() == 0 and alpha.max() == 1 and ((alpha > 0) & (alpha < 1)).any()  # the sphere's rim
    assert durer.render(durer.load_dict(_scene({})), samples=1).alpha is None


def test_crop_and_alpha_match_mitsuba():
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference")
    mi.set_variant("scalar_rgb")
    film = {**CROP, "pixel_format": "rgba"}
    ours = durer.render(durer.load_dict(_scene(film)), samples=64)
    ref = np.array(mi.render(mi.load_dict(_scene(film)), spp=64, seed=2))
    assert ref.shape == (13, 19, 4) and ours.rgba.shape == ref.shape
    assert ours.color.mean() == pytest.approx(ref[..., :3].mean(), rel=0.03)
    assert ours.alpha.mean() == pytest.approx(ref[..., 3].mean(), abs=0.01)
    np.testing.assert_array_equal(ours.alpha > 0.5, ref[..., 3] > 0.5)
