"""`durer explain` on path-traced pixels (rendering/explain_path.py) and on every kind of scene file.

The contributions of every sample's path add up to the pixel `durer render` writes with the same options and seed:
the float32 image's value to within 1e-6 relative (a few float32 units in the last place: the paths are the
renderer's own, bit for bit, and only the order of the filter's sums differs).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import MITSUBA_SCENES

import durer
from durer.cli import main
from durer.rendering.explain import explain, walk
from durer.rendering.texturing import leaf_weights

needs_scenes = pytest.mark.skipif(not MITSUBA_SCENES.is_dir(), reason=f"Mitsuba scenes not found at {MITSUBA_SCENES} "
                                  "(they live in ../shared beside the repository)")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CORNELL, CAUSTIC = EXAMPLES / "cornell_box.xml", EXAMPLES / "caustic.xml"
RTOL = 1e-6  # float32 rounding of the rendered image (its .npy is float32)


def _json(argv, capsys) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("scene, flags, pixels", [
    (CORNELL, ["--size", "16", "16", "--samples", "4", "--seed", "3"], [(8, 8), (2, 13), (5, 3), (8, 1)]),
    (CORNELL, ["--size", "12", "12", "--samples", "2", "--filter", "tent:1.0", "--max-depth", "4"], [(6, 6), (0, 11)]),
    (CAUSTIC, ["--size", "16", "12", "--samples", "2", "--seed", "1"], [(8, 6), (3, 9), (12, 2)]),
], ids=["cornell", "cornell-tent", "caustic"])
def test_path_contributions_add_up_to_the_rendered_pixel(scene, flags, pixels, tmp_path, capsys):
    out = tmp_path / "image.npy"
    assert main(["render", str(scene), "-o", str(out), "--quiet", *flags]) == 0
    image = np.load(out)
    for x, y in pixels:
        tree = _json(["explain", str(scene), "--pixel", str(x), str(y), "--json", *flags], capsys)
        total = np.sum([n["contribution"] for n in walk(tree["rays"])], axis=0)
        np.testing.assert_allclose(tree["color"], total, atol=1e-12)
        np.testing.assert_allclose(total, image[y, x], rtol=RTOL, atol=1e-9, err_msg=f"pixel {x} {y}")
        weights = [n["sample"]["filter_weight"] for n in tree["rays"]]
        assert sum(weights) == pytest.approx(1.0)


def _check_light_samples(node: dict, filter_weight: float) -> int:
    """Each light sample below a vertex: its contribution (the kernel's) is the product of the listed terms,
    throughput x BSDF x emitter weight x MIS weight x filter weight. Returns how many were unblocked."""
    unblocked = 0
    for shadow in (c for c in node["children"] if c["kind"] == "shadow"):
        s = shadow["light_sample"]
        assert 0.0 <= s["mis_weight"] <= 1.0 and s["pdf"] > 0
        if not shadow["blocked"]:
            expected = (np.array(node["throughput"]) * np.array(s["bsdf"]) * np.array(s["emitter_weight"])
                        * s["mis_weight"] * filter_weight)
            np.testing.assert_allclose(shadow["contribution"], expected, rtol=1e-9, atol=1e-300)
            unblocked += np.any(expected > 0)
    return unblocked


def test_each_sample_is_a_path_of_vertices_light_and_bsdf_samples():
    """A 2-sample pixel on the Cornell box's back wall: each sample is a chain camera -> bounce -> ... whose
    light samples carry the emitter's and the BSDF's values, and whose contribution is their product with the
    throughput, the MIS weight and the filter weight (the kernel's estimate, recomputed from the listed terms)."""
    scene = durer.load(CORNELL)
    tree = explain(scene, 16, 16, 8, 8, integrator="path", samples=2, max_depth=8, seed=3)
    assert len(tree.rays) == 2 and [n["sample"]["index"] for n in tree.rays] == [0, 1]
    shadows = 0
    for root in tree.rays:
        assert root["kind"] == "camera" and root["depth"] == 0
        assert root["hit"]["material_type"] == "Diffuse"
        node, depth = root, 0
        while node is not None:
            assert node["depth"] == depth
            nxt = [c for c in node["children"] if c["kind"] == "bounce"]
            shadows += _check_light_samples(node, root["sample"]["filter_weight"])
            if nxt:
                np.testing.assert_allclose(nxt[0]["throughput"], node["next"]["throughput"])
                np.testing.assert_allclose(nxt[0]["origin"], node["hit"]["point"], atol=1e-6)  # offset off the surface
            else:
                assert "path_ends" in node
            node, depth = (nxt[0] if nxt else None), depth + 1
    assert shadows >= 4


def test_a_camera_ray_on_the_light_sees_its_emission_with_mis_weight_one():
    """A pixel on the ceiling light: the camera ray hits the emitter; nothing sampled it before,
    so its emission counts fully (MIS weight 1) and is the radiance times the filter weight."""
    scene = durer.load(CORNELL)
    tree = explain(scene, 16, 16, 8, 2, integrator="path", samples=1, max_depth=8)
    root = tree.rays[0]
    assert "emitter" in root["hit"]["material_type"]
    assert root["emission"]["mis_weight"] == 1.0
    np.testing.assert_allclose(root["contribution"], root["emission"]["radiance"])
    text = tree.text()
    assert "emission (" in text and "x MIS weight 1" in text and "light sample" in text


def test_text_lists_the_path_and_the_default_size_is_the_scenes_film(capsys):
    assert main(["explain", str(CORNELL), "--pixel", "255", "255", "--samples", "1"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("pixel (255, 255) of 256x256:")  # the film of the file, as durer render uses
    assert "sample 1/1 (sample index 0)" in text and " miss " in text and "path ends: escaped the scene" in text
    assert main(["explain", str(CORNELL), "--pixel", "128", "128", "--samples", "1"]) == 0
    text = capsys.readouterr().out
    assert "camera o=" in text and "BSDF sample (pdf" in text and "-> light sample:" in text


@pytest.mark.parametrize("argv, message", [
    (["--pixel", "256", "0"], "--pixel 256 0 is outside the 256x256 image"),
    (["--pixel", "1", "1", "--integrator", "whitted"], "physically based materials"),
])
def test_user_errors_are_one_line_exit_2(argv, message, capsys):
    assert main(["explain", str(CORNELL), *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert message in err[-1]


def test_leaf_weights_leave_non_texture_materials_whole():
    """A Mitsuba scene's Surface materials are leaves (the explain of issue 19 failed on Surface.matrix)."""
    scene = durer.load(CORNELL)
    mat = np.arange(len(scene.materials))
    (leaf, weight), = leaf_weights(scene.materials, mat, np.zeros((len(mat), 3)))
    np.testing.assert_array_equal(leaf, mat)
    np.testing.assert_array_equal(weight, 1.0)


@pytest.mark.parametrize("name", ["spheres.txt", "fisheye.txt", "panorama.txt", "still_life.gltf",
                                  "spotlights.gltf", "cube.obj"])
def test_every_example_path_traced_adds_up(name, tmp_path, capsys):
    """Course scenes (textures, background, fisheye pixels without a ray), models and their lights: the path
    tracer's explain adds up to its render for every kind of file durer.load reads."""
    flags = ["--size", "12", "10", "--integrator", "path", "--samples", "2", "--max-depth", "4", "--seed", "5"]
    out = tmp_path / "image.npy"
    assert main(["render", str(EXAMPLES / name), "-o", str(out), "--quiet", *flags]) == 0
    image = np.load(out)
    for x, y in [(5, 5), (0, 0), (11, 9), (3, 7)]:
        tree = _json(["explain", str(EXAMPLES / name), "--pixel", str(x), str(y), "--json", *flags], capsys)
        np.testing.assert_allclose(tree["color"], image[y, x], rtol=RTOL, atol=1e-9, err_msg=f"{name} {x} {y}")
        assert main(["explain", str(EXAMPLES / name), "--pixel", str(x), str(y), *flags]) == 0
        assert capsys.readouterr().out.startswith(f"pixel ({x}, {y}) of 12x10")


def test_a_camera_ray_on_a_textured_light_sees_the_texture_at_its_uv():
    """A checkerboard area light seen by camera rays: each ray's emission is one of the two colours (the texture
    at the hit's UV, as the kernel looked it up, not the texture's mean), counted with MIS weight 1."""
    from durer.io.mitsuba_values import look_at

    look = look_at(np.array([0.0, 0, 0]), np.array([0.0, 0, 1]), np.array([0.0, 1, 0]))
    light = look_at(np.array([0.3, 0, 0.7]), np.array([-1.0, 0, 0.7]), np.array([0.0, 1, 0]))
    scene = durer.load_dict({
        "type": "scene", "sensor": {"type": "perspective", "fov": 70, "to_world": look},
        "light": {"type": "rectangle", "to_world": light @ np.diag([0.15, 0.15, 1, 1]),
                  "emitter": {"type": "area", "radiance": {
                      "type": "checkerboard", "color0": {"type": "rgb", "value": [1.0, 0.25, 0.1]},
                      "color1": {"type": "rgb", "value": [0.05, 0.1, 0.8]}, "to_uv": np.diag([4.0, 3, 1, 1])}}}})
    colours = set()
    for x, y in [(4, 12), (5, 14), (6, 16), (4, 18), (5, 13), (6, 15), (4, 17), (5, 19)]:
        tree = explain(scene, 32, 32, x, y, integrator="path", samples=2, filter="box", max_depth=2)
        for root in tree.rays:
            assert "emitter" in root["hit"]["material_type"] and root["emission"]["mis_weight"] == 1.0
            radiance = root["emission"]["radiance"]
            assert radiance in ([1.0, 0.25, 0.1], [0.05, 0.1, 0.8])
            colours.add(tuple(radiance))
            np.testing.assert_allclose(root["contribution"], np.multiply(radiance, root["sample"]["filter_weight"]),
                                       rtol=1e-12)
    assert len(colours) == 2


@needs_scenes
@pytest.mark.parametrize("name", ["bsdf_normalmap_with.xml", "bsdf_roughconductor_anisotropic_aluminium.xml",
                                  "bsdf_roughdielectric_textured.xml"])
def test_light_samples_show_the_bsdf_in_the_kernels_shading_frame(name):
    """A normal map, anisotropic roughness (tangents along dp/du) and a textured roughness: the listed BSDF value
    and MIS weight are those the kernel used, so they multiply to its contribution (a plain frame around the
    normal, at the texture's default, gives other values on these materials)."""
    scene = durer.load(MITSUBA_SCENES / "mitsuba-data/docs/scenes" / name)
    checked = 0
    for x, y in [(10, 10), (12, 9), (9, 13), (14, 12)]:
        tree = explain(scene, 24, 24, x, y, integrator="path", samples=2, max_depth=3, seed=2)
        for root in tree.rays:
            node = root
            while node is not None:
                checked += _check_light_samples(node, root["sample"]["filter_weight"])
                node = next((c for c in node["children"] if c["kind"] == "bounce"), None)
    assert checked >= 4
