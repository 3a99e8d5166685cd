"""rendering/film.py's Mitsuba 3 filters (mitchell, lanczos, mitsuba_gaussian): separable weights equal to
Mitsuba's own filter `eval`, their support, and a filtered edge rendered as Mitsuba renders it at equal samples."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.options import RenderOptions
from durer.rendering import film

FILTERS = [("mitchell", {}, "mitchell", 2.0), ("lanczos", {}, "lanczos", 3.0),
           ("lanczos", {"lobes": 2}, "lanczos", 2.0), ("gaussian", {}, "mitsuba_gaussian", 0.5),
           ("gaussian", {"stddev": 0.8}, "mitsuba_gaussian", 0.8)]


def _opts(name: str, r: float) -> RenderOptions:
    o = RenderOptions(filter=name, filter_radius=r)
    o.validate()
    return o


@pytest.mark.parametrize("mi_name,params,name,r", FILTERS)
def test_weights_are_mitsubas_filter_eval_on_each_axis(mi_name, params, name, r):
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 gives the reference weights")
    mi.set_variant("scalar_rgb")
    theirs = mi.load_dict({"type": mi_name, **params})
    x = np.linspace(-5.0, 5.0, 81) + 0.013
    one = np.array([theirs.eval(float(v)) for v in x])
    # Mitsuba's gaussian evaluates exp in single precision with a fast approximation: 4e-4 apart at most
    tol = 1e-3 if mi_name == "gaussian" else 1e-6
    np.testing.assert_allclose(film.filter_weight(_opts(name, r), x, 0.0), one * theirs.eval(0.0), atol=tol)
    np.testing.assert_allclose(film.filter_weight(_opts(name, r), x, x[::-1]), one * one[::-1], atol=tol)
    reach = _opts(name, r).filter_reach()
    assert reach == pytest.approx(theirs.radius(), rel=1e-6)
    assert film.support_radius(_opts(name, r)) == int(np.ceil(reach - 0.5))


def test_mitsuba_scenes_default_to_mitsubas_gaussian():
    scene = durer.load_dict({"type": "scene", "sensor": {"type": "perspective", "film": {"type": "hdrfilm"}}})
    assert (scene.render_defaults["filter"], scene.render_defaults["filter_radius"]) == ("mitsuba_gaussian", 0.5)


@pytest.mark.parametrize("mi_name,params,name,r", [FILTERS[0], FILTERS[1], FILTERS[3]])
def test_a_filtered_edge_renders_as_in_mitsuba(mi_name, params, name, r):
    """An emitting rectangle whose edge crosses the image between pixel centres, seen by an orthographic camera:
    the image's mean and its profile across the edge (ringing of the negative lobes included) as Mitsuba's."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference")
    mi.set_variant("scalar_rgb")
    width, height = 24, 6
    edge = np.array([[1.0, 0, 0, 0.37], [0, 10, 0, 0], [0, 0, 1, 2.0], [0, 0, 0, 1]])  # x from -0.63 to 1.37
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 1},
             "sensor": {"type": "orthographic", "film": {"type": "hdrfilm", "width": width, "height": height,
                                                         "rfilter": {"type": mi_name, **params}}},
             "light": {"type": "rectangle", "flip_normals": True, "to_world": edge,
                       "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}}}
    ours = np.asarray(durer.render(durer.load_dict(scene), samples=256).color)[..., 0]
    convert = {**scene, "light": {**scene["light"], "to_world": mi.ScalarTransform4f(edge)}}
    ref = np.array(mi.render(mi.load_dict(convert), spp=256, seed=5))[..., 0]
    assert ref.shape == ours.shape == (height, width)
    profile, ref_profile = ours.mean(axis=0), ref.mean(axis=0)
    assert ref_profile.min() < 0.5 < ref_profile.max()
    assert profile.mean() == pytest.approx(ref_profile.mean(), abs=0.01)
    # Mitsuba's independent samples move its edge pixel by +-0.015 between seeds (256 spp); the rest is exact
    np.testing.assert_allclose(profile, ref_profile, atol=0.04)
    far = np.abs(np.arange(width) - 19.5) > 1.5
    np.testing.assert_allclose(profile[far], ref_profile[far], atol=0.01)
