"""rendering/film.py's Mitsuba 3 filters (mitchell with its B and C, catmullrom, lanczos, mitsuba_gaussian): separable
weights equal to
Mitsuba's own filter `eval`, their support, and a filtered edge rendered as Mitsuba renders it at equal samples."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.options import RenderOptions
from durer.rendering import film

FILTERS = [("mitchell", {}, "mitchell", 2.0), ("lanczos", {}, "lanczos", 3.0),
           ("lanczos", {"lobes": 2}, "lanczos", 2.0), ("gaussian", {}, "mitsuba_gaussian", 0.5),
           ("gaussian", {"stddev": 0.8}, "mitsuba_gaussian", 0.8), ("mitchell", {"B": 0.0, "C": 0.5}, "mitchell", 2.0),
           ("mitchell", {"B": 1.0, "C": 0.0}, "mitchell", 2.0), ("mitchell", {"B": 0.2, "C": 0.75}, "mitchell", 2.0),
           ("catmullrom", {}, "catmullrom", 2.0)]


def _opts(name: str, r: float, params: dict | None = None) -> RenderOptions:
    bc = {f"filter_{k.lower()}": v for k, v in (params or {}).items() if k in ("B", "C")}
    o = RenderOptions(filter=name, filter_radius=r, **bc)
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
    o = _opts(name, r, params)
    np.testing.assert_allclose(film.filter_weight(o, x, 0.0), one * theirs.eval(0.0), atol=tol)
    np.testing.assert_allclose(film.filter_weight(o, x, x[::-1]), one * one[::-1], atol=tol)
    reach = o.filter_reach()
    assert reach == pytest.approx(theirs.radius(), rel=1e-6)
    assert film.support_radius(o) == int(np.ceil(reach - 0.5))


@pytest.mark.parametrize("mi_name,params,name,r", FILTERS[-4:])
def test_mitsuba_rfilters_load_with_their_parameters(mi_name, params, name, r):
    """A scene's rfilter (mitchell's B and C, catmullrom) becomes the render defaults whose weights the test above
    checks; a film without one keeps Mitsuba's gaussian."""
    rfilter = {"type": mi_name, **params}
    scene = durer.load_dict({"type": "scene", "sensor": {"type": "perspective",
                                                          "film": {"type": "hdrfilm", "rfilter": rfilter}}})
    d = scene.render_defaults
    assert (d["filter"], d["filter_radius"]) == (name, r)
    assert (d.get("filter_b"), d.get("filter_c")) == ((params["B"], params["C"]) if params else (None, None))
    o = RenderOptions(**{k: v for k, v in d.items() if k not in ("width", "height")})
    expected = {"catmullrom": (0.0, 0.5)}.get(mi_name, (params.get("B"), params.get("C")))
    assert film.cubic(o) == expected


def test_mitsuba_scenes_default_to_mitsubas_gaussian():
    scene = durer.load_dict({"type": "scene", "sensor": {"type": "perspective", "film": {"type": "hdrfilm"}}})
    assert (scene.render_defaults["filter"], scene.render_defaults["filter_radius"]) == ("mitsuba_gaussian", 0.5)


@pytest.mark.parametrize("mi_name,params,name,r", [FILTERS[0], FILTERS[1], FILTERS[3], FILTERS[7], FILTERS[8]])
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


def test_mitchell_parameters_must_be_finite():
    with pytest.raises(ValueError, match="mitchell's B and C must be finite numbers"):
        RenderOptions(filter="mitchell", filter_radius=2.0, filter_c=float("nan")).validate()


def test_a_command_line_filter_drops_the_scenes_mitchell_parameters():
    """`--filter mitchell` on a scene whose film has mitchell B = 1, C = 0 gets Mitsuba's default 1/3, 1/3."""
    import argparse

    from durer.cli import render_options

    scene = durer.load_dict({"type": "scene", "sensor": {"type": "perspective", "film": {
        "type": "hdrfilm", "rfilter": {"type": "mitchell", "B": 1.0, "C": 0.0}}}})
    flags = dict(filter=None, shade_back=False, shadows=False, bounces=0, weight=0.01, seed=0, accel="bvh",
                 integrator=None, max_depth=None, samples=None, sampler=None)
    assert film.cubic(render_options(argparse.Namespace(**flags), scene.render_defaults)) == (1.0, 0.0)
    flags["filter"] = "mitchell:2"
    assert film.cubic(render_options(argparse.Namespace(**flags), scene.render_defaults)) == (1 / 3, 1 / 3)
