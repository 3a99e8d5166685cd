"""`durer explain` and rendering/explain.py: one pixel's ray tree, whose contributions add up to the rendered pixel.

Covers rendering/explain.py (the tree), explain_text.py (the text), explain_draw.py (--draw) and cli_explain.py.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import COURSE, needs_course
from PIL import Image

import durer
from durer.cli import main
from durer.rendering.explain import explain, explain_in, walk
from durer.rendering.explain_draw import COLORS, draw_tree
from durer.rendering.renderer import make_context, make_options

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "spheres.txt"

# an orthographic view of a unit sphere on a plane, one directional light straight down, half ambient
SHADOW_SCENE = """\
OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 4 }
Lights { numLights 1 DirectionalLight { direction 0 -1 0 color 0.8 0.8 0.8 } }
Background { color 0.1 0.2 0.3 ambientLight 0.5 0.5 0.5 }
Materials { numMaterials 2
    PhongMaterial { diffuseColor 1 0 0 }
    PhongMaterial { diffuseColor 0.5 0.5 0.5 reflectiveColor 0.5 0.5 0.5 } }
Group { numObjects 2
    MaterialIndex 0 Sphere { center 0 0 0 radius 1 }
    MaterialIndex 1 Plane { normal 0 1 0 offset -1 } }
"""


@pytest.fixture(scope="module")
def shadow_scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("explain") / "shadow.txt"
    path.write_text(SHADOW_SCENE)
    return path


def _json(argv, capsys) -> dict:
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_closed_form_camera_ray_on_a_lit_sphere(shadow_scene):
    """The centre pixel of a 9x9 image looks straight down -z at the sphere's pole facing the camera:
    t = 10 - 1, normal +z, ambient 0.5 * kd, and the light from above grazes it (N.L = 0): no diffuse."""
    tree = explain(durer.load(shadow_scene), 9, 9, 4, 4)
    (ray,) = tree.rays
    assert ray["kind"] == "camera" and ray["t"] == pytest.approx(9.0, abs=1e-12)
    np.testing.assert_allclose(ray["hit"]["normal"], [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(ray["hit"]["point"], [0, 0, 1], atol=1e-12)
    assert ray["hit"]["object"] == "sphere" and ray["hit"]["material"] == 0
    np.testing.assert_allclose(ray["hit"]["shading"]["ambient"], [0.5, 0, 0])
    np.testing.assert_allclose(ray["hit"]["shading"]["lights"][0]["diffuse"], [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(tree.color, [0.5, 0, 0], atol=1e-12)
    assert ray["sample"] == {"film": [4.5, 4.5], "pixel": [4, 4], "filter_weight": 1.0}


def test_shadowed_floor_and_its_reflection(shadow_scene):
    """A floor point right under the sphere: its shadow ray up is blocked by the sphere (contribution 0,
    the light's term marked shadowed); the floor's mirror ray goes up and hits the sphere's underside, which
    faces away from the light. Colour = ambient * 0.5 (floor) + 0.5 * (ambient of the underside)."""
    scene = durer.load(shadow_scene)
    # look down at 45 degrees at the floor point (0, -1, 0.6), inside the sphere's shadow (radius 1 round (0,-1,0))
    scene.camera = durer.OrthographicCamera(center=(0, 4, 5.6), direction=(0, -1, -1), up=(0, 1, 0), size=1)
    tree = explain(scene, 5, 5, 2, 2, shadows=True, bounces=1)
    (ray,) = tree.rays
    assert ray["hit"]["object"] == "plane"
    shadow, reflection = ray["children"]
    assert shadow["kind"] == "shadow" and shadow["blocked"] and shadow["hit"]["object"] == "sphere"
    assert shadow["contribution"] == [0.0, 0.0, 0.0]
    assert ray["hit"]["shading"]["lights"][0]["shadowed"] is True
    assert reflection["kind"] == "reflection" and reflection["hit"]["object"] == "sphere"
    np.testing.assert_allclose(reflection["throughput"], [0.5, 0.5, 0.5])
    np.testing.assert_allclose(ray["contribution"], [0.25, 0.25, 0.25], atol=1e-12)
    np.testing.assert_allclose(reflection["contribution"], [0.25, 0, 0], atol=1e-12)
    np.testing.assert_allclose(tree.color, [0.5, 0.25, 0.25], atol=1e-12)
    np.testing.assert_allclose(tree.color, durer.render(scene, 5, 5, shadows=True, bounces=1).color[2, 2],
                               atol=1e-6)


FLAG_SETS = [
    [],
    ["--shadows", "--bounces", "3"],
    ["--shadows", "--bounces", "2", "--samples", "4", "--filter", "tent:1.0", "--seed", "7"],
    ["--shadows", "--bounces", "1", "--samples", "4", "--filter", "gaussian:0.5", "--shade-back"],
]


@pytest.mark.parametrize("flags", FLAG_SETS, ids=lambda f: " ".join(f) or "raycast")
def test_contributions_add_up_to_the_rendered_pixel(flags, tmp_path, capsys):
    """Against the float image `durer render` writes with the same flags (its .npy is float32)."""
    out = tmp_path / "image.npy"
    size = ["--size", "24", "16"]
    assert main(["render", str(EXAMPLE), "-o", str(out), "--quiet", *size, *flags]) == 0
    image = np.load(out)
    for x, y in [(12, 8), (4, 11), (20, 3), (16, 13)]:
        tree = _json(["explain", str(EXAMPLE), "--pixel", str(x), str(y), "--json", *size, *flags], capsys)
        total = np.sum([n["contribution"] for n in walk(tree["rays"])], axis=0)
        np.testing.assert_allclose(tree["color"], total, atol=1e-12)
        np.testing.assert_allclose(total, image[y, x], atol=2e-6, err_msg=f"pixel {x} {y}")
        assert tree["pixel"] == [x, y]


def test_json_nodes_have_the_documented_fields(capsys):
    tree = _json(["explain", str(EXAMPLE), "--pixel", "12", "8", "--json", "--size", "24", "16", "--shadows",
                  "--bounces", "3"], capsys)
    assert set(tree) == {"pixel", "color", "rays"}
    kinds = set()
    for node in walk(tree["rays"]):
        assert set(node) >= {"kind", "origin", "direction", "t", "hit", "contribution", "children"}
        kinds.add(node["kind"])
        if node["hit"] is None:
            assert node["t"] is None
        else:
            assert set(node["hit"]) >= {"point", "normal", "material"}
            assert math.isclose(np.linalg.norm(node["hit"]["normal"]), 1.0, rel_tol=1e-9)
    assert kinds == {"camera", "shadow", "reflection"}


def test_wide_filters_list_the_neighbours_samples():
    """A tent of radius 1.5 reaches the samples of the 8 neighbours; their weights are normalised."""
    tree = explain(durer.load(EXAMPLE), 12, 8, 5, 4, samples=4, filter="tent:1.5", seed=3)
    owners = {tuple(n["sample"]["pixel"]) for n in tree.rays}
    assert owners == {(x, y) for x in (4, 5, 6) for y in (3, 4, 5)}
    assert sum(n["sample"]["filter_weight"] for n in tree.rays) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(tree.color, durer.render(durer.load(EXAMPLE), 12, 8, samples=4, filter="tent:1.5",
                                                        seed=3).color[4, 5], atol=1e-6)


ALL, MIDDLE = range(10), range(3, 7)  # the glass sphere's scene traces instanced cubes: ~10 ms a call, so 4x4
COURSE_CASES = [  # scene, render options, pixel rows and columns, what the pixels' trees must contain between them
    ("assignment4/scene4_09_transparent_sphere_2.0.txt", dict(shadows=True, bounces=5, shade_back=True), MIDDLE,
     "refraction"),
    ("assignment4/scene4_14_faceted_gem.txt", dict(shadows=True, bounces=3, shade_back=True), ALL, "reflection"),
    ("assignment4/scene4_02_colored_shadows.txt", dict(shadows=True), ALL, "shadow"),
    ("assignment6/scene6_13_checkerboard.txt", dict(shadows=True, samples=4, filter="gaussian:0.6"), MIDDLE,
     "texture"),
    ("assignment1/scene1_03.txt", dict(), ALL, "flat"),
]


@needs_course
@pytest.mark.parametrize("name, options, pixels, feature", COURSE_CASES,
                         ids=[c[0].split("/")[1] for c in COURSE_CASES])
def test_course_scenes_every_pixel(name, options, pixels, feature):
    """Every pixel of a 10x10 render (or of its middle) equals the sum of its tree's contributions."""
    scene = durer.load(COURSE / name)
    image = durer.render(scene, 10, 10, **options).color
    ctx = make_context(scene, make_options(**options))
    seen = set()
    for y in pixels:
        for x in pixels:
            tree = explain_in(ctx, 10, 10, x, y)
            np.testing.assert_allclose(tree.color, image[y, x], atol=2e-6, err_msg=f"{name} pixel {x} {y}")
            for node in walk(tree.rays):
                seen.add(node["kind"])
                if node["hit"] and "leaves" in node["hit"]:
                    seen.add("texture")
                if node["hit"] and "flat" in node["hit"].get("shading", {}):
                    seen.add("flat")
    assert feature in seen


def test_text_tree(capsys):
    assert main(["explain", str(EXAMPLE), "--pixel", "12", "8", "--size", "24", "16", "--shadows",
                 "--bounces", "2"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].startswith("pixel (12, 8) of 24x16: linear colour")
    assert lines[1].startswith("sample 1/1 at film (12.5000, 7.5000)")
    assert lines[2].startswith("  camera o=(0, 2.2, 9)") and " hit sphere " in lines[2]
    assert any(line.lstrip().startswith("shadow o=") and "-> light" in line for line in lines)
    assert any(line.startswith("    reflection o=") for line in lines)  # the camera ray's child, one level in


def test_draw_writes_the_rays_over_the_image(tmp_path, capsys):
    out = tmp_path / "tree.png"
    assert main(["explain", str(EXAMPLE), "--pixel", "8", "11", "--size", "24", "16", "--shadows", "--bounces", "2",
                 "--draw", str(out)]) == 0
    image = np.asarray(Image.open(out).convert("RGB"))
    assert image.shape == (352, 528, 3)  # enlarged 22x to reach 512 pixels on the longer side
    colours = {tuple(c) for c in image.reshape(-1, 3)}
    assert COLORS["shadow"] in colours or COLORS["blocked"] in colours
    assert COLORS["reflection"] in colours
    assert (255, 255, 0) in colours  # the pixel's outline


def test_drawn_segments_end_at_the_projected_hit_points():
    """The camera ray of an orthographic view is a point on the image; its reflection's segment is drawn from
    that pixel to where the mirror ray's hit projects."""
    scene = durer.load(EXAMPLE)
    tree = explain(scene, 24, 16, 8, 11, bounces=1)
    image = draw_tree(tree, np.zeros((16, 24, 3)), scene.camera, min_size=24)
    assert image.size == (24, 16)
    reflection = tree.rays[0]["children"][0]
    film, seen = scene.camera.project(np.array([reflection["hit"]["point"]]), 24, 16)
    x, y = int(film[0, 0]), int(16 - film[0, 1])
    assert seen[0] and image.getpixel((x, y)) in (COLORS["reflection"], (255, 255, 0))


@pytest.mark.parametrize("argv, message", [
    (["--pixel", "24", "0"], "--pixel 24 0 is outside the 24x16 image"),
    (["--pixel", "0", "-1"], "--pixel 0 -1 is outside the 24x16 image"),
    (["--pixel", "1"], "--pixel: expected 2 arguments"),
    (["--pixel", "1", "1", "--draw", "out.webp"], "unknown image extension '.webp'"),
    (["--pixel", "1", "1", "--draw", "out.hdr"], "--draw: 'out.hdr' must be an 8-bit image (.png, .tga"),
])
def test_user_errors_exit_2(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["explain", str(EXAMPLE), "--size", "24", "16", *argv]) == 2
    out, err = capsys.readouterr()
    assert out == "" and message in err
    assert "Traceback" not in err and not list(tmp_path.iterdir())


def test_malformed_scene_is_one_line(tmp_path, capsys):
    bad = tmp_path / "bad.txt"
    bad.write_text(SHADOW_SCENE.replace("radius 1", "radius oops"))
    assert main(["explain", str(bad), "--pixel", "0", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"{bad}:") and len(err.splitlines()) == 1


def test_total_internal_reflection_is_marked_and_has_no_refracted_ray():
    """A camera inside a glass ball (index 1.5) at x = 0.9 looking along +y meets the surface at
    cos = sqrt(1 - 0.81) = 0.436, 64 degrees from the normal, beyond the critical angle asin(1/1.5) = 41.8:
    the light is totally reflected, so the node has a reflection child and no refraction child."""
    scene = durer.Scene(
        camera=durer.PerspectiveCamera(center=(0.9, 0, 0), direction=(0, 1, 0), up=(0, 0, 1), angle=1),
        group=durer.Group([durer.Sphere((0, 0, 0), 1, material=0)]),
        materials=[durer.PhongMaterial(diffuse_color=(0.1, 0.1, 0.1), reflective_color=(0.2, 0.2, 0.2),
                                       transparent_color=(0.8, 0.8, 0.8), index_of_refraction=1.5)],
        lights=[durer.DirectionalLight(direction=(0, -1, 0), color=(1, 1, 1))],
        background_color=(0.3, 0.5, 0.7), ambient_light=(0.2, 0.2, 0.2))
    options = dict(shadows=True, bounces=1, shade_back=True)
    tree = explain(scene, 1, 1, 0, 0, **options)
    (ray,) = tree.rays
    assert ray["hit"]["back_face"] and ray["t"] == pytest.approx(np.sqrt(1 - 0.81))
    assert ray["total_internal_reflection"] is True
    assert [c["kind"] for c in ray["children"]] == ["reflection"]
    np.testing.assert_allclose(tree.color, durer.render(scene, 1, 1, **options).color[0, 0], atol=1e-6)
    assert "total internal reflection: no refracted ray" in tree.text()


def test_a_camera_less_model_is_explained_through_the_camera_render_frames_for_the_image(tmp_path):
    """A model without a camera gets one framed for the image's shape (scene/cameras.image_camera): explain traces
    that same camera, so its sum is the rendered pixel for a wide image too."""
    import trimesh

    trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ball.ply")
    scene = durer.load(tmp_path / "ball.ply")
    image = durer.render(scene, 24, 12, shadows=True).color
    for x, y in ((12, 6), (5, 3), (20, 9)):
        tree = explain(scene, 24, 12, x, y, shadows=True)
        np.testing.assert_allclose(tree.color, image[y, x], atol=2e-6)
    assert image[6, 12].max() > 0.05  # the ball is in the middle of the wide image


def test_disks_and_cylinders_are_named_as_such():
    """A disk, a sphere and a cylinder (the first and last stored in the sphere slots with DISK_CODE and
    CYLINDER_CODE radii) side by side, seen from above: each pixel of the middle row names what it hit."""
    look_down = np.array([[-1.0, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 6], [0, 0, 0, 1]])  # Mitsuba's look_at from +z
    disk = np.diag([0.5, 0.5, 1.0, 1.0])
    disk[0, 3] = -1.5
    scene = durer.load_dict({
        "type": "scene", "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 60, "to_world": look_down,
                   "film": {"type": "hdrfilm", "width": 24, "height": 5, "rfilter": {"type": "box"}}},
        "light": {"type": "constant"},
        "d": {"type": "disk", "to_world": disk},
        "s": {"type": "sphere", "radius": 0.5},
        "c": {"type": "cylinder", "p0": [1.5, -1.0, 0.0], "p1": [1.5, 1.0, 0.0], "radius": 0.4}})
    names = []
    for x in range(24):
        (ray,) = explain(scene, 24, 5, x, 2, samples=1).rays
        names.append(ray["hit"]["object"] if ray["hit"] else None)
    seen = [n for n in names if n is not None]
    assert {"disk", "sphere", "cylinder"} == set(seen), names
    # from left to right in the image, as in the world (x = -1.5, 0, 1.5): disk, sphere, cylinder
    assert seen == sorted(seen, key=["disk", "sphere", "cylinder"].index), names
