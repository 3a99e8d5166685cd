"""Mitsuba 3 scenes: the examples load, load_dict builds the same scene, and every mistake or element outside the
subset is one `file:line:` SceneError naming it (exit 2 from the CLI)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import durer
from durer.errors import SceneError
from durer.scene.bsdfs import Dielectric, Principled, PrincipledThin, Surface
from durer.scene.textures import Bitmap, Checker

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CAM = ('<sensor type="perspective"><float name="fov" value="40"/>'
       '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>')


def write(tmp_path, body: str, sensor: bool = True) -> Path:
    p = tmp_path / "s.xml"
    p.write_text('<scene version="3.0.0">\n' + (CAM + "\n" if sensor else "") + body + "\n</scene>\n")
    return p


def test_cornell_box_loads():
    s = durer.load(EXAMPLES / "cornell_box.xml")
    assert len(s.group.objects) == 8
    assert s.render_defaults == {"integrator": "path", "max_depth": 8, "rr_depth": 5, "hide_emitters": False,
                                 "samples": 64, "filter": "box", "filter_radius": 0.5, "width": 256, "height": 256}
    emitting = [m for m in s.materials if isinstance(m, Surface) and m.radiance is not None]
    np.testing.assert_allclose(emitting[0].radiance, [18.387, 13.9873, 6.75357])
    np.testing.assert_allclose(s.camera.center, [0, 0, 3.9])


def test_caustic_scene_and_defaults(tmp_path):
    s = durer.load(EXAMPLES / "caustic.xml")
    assert any(isinstance(m.bsdf, Dielectric) for m in s.materials)
    p = write(tmp_path, '<default name="r" value="0.25"/><shape type="sphere">'
                        '<float name="radius" value="$r"/></shape>')
    assert durer.load(p).group.objects[0].object.radius == 0.25


def test_principled_reads_mitsubas_parameters(tmp_path):
    Image.fromarray(np.full((2, 2), 128, np.uint8), mode="L").save(tmp_path / "r.png")
    p = write(tmp_path, '<shape type="sphere"><bsdf type="principled"><rgb name="base_color" value="0.2 0.4 0.6"/>'
                        '<texture type="bitmap" name="roughness"><string name="filename" value="r.png"/></texture>'
                        '<float name="metallic" value="0.3"/><float name="specular" value="0.6"/>'
                        '<float name="clearcoat" value="0.5"/><float name="clearcoat_sampling_rate" value="2"/>'
                        '</bsdf></shape>')
    b = durer.load(p).materials[0].bsdf
    assert isinstance(b, Principled) and isinstance(b.roughness, Bitmap)
    np.testing.assert_allclose(b.base_color, [0.2, 0.4, 0.6])
    assert (b.metallic, b.clearcoat, b.clearcoat_sampling_rate, b.spec_trans, b.sheen) == (0.3, 0.5, 2.0, 0.0, 0.0)
    assert b.relative_eta == pytest.approx(2 / (1 - np.sqrt(0.08 * 0.6)) - 1)  # Mitsuba's eta from specular
    q = write(tmp_path, '<shape type="sphere"><bsdf type="principled"><float name="eta" value="1.33"/></bsdf></shape>')
    b = durer.load(q).materials[0].bsdf
    assert b.relative_eta == 1.33 and b.roughness == 0.5 and np.allclose(b.base_color, 0.5)  # Mitsuba's defaults
    q = write(tmp_path, '<shape type="rectangle"><bsdf type="principledthin"><float name="diff_trans" value="1.2"/>'
                        '<float name="flatness" value="0.4"/><float name="eta" value="1.3"/>'
                        '<float name="specular_transmittance_sampling_rate" value="0.5"/></bsdf></shape>')
    b = durer.load(q).materials[0].bsdf
    assert isinstance(b, PrincipledThin) and (b.diff_trans, b.flatness, b.eta, b.spec_trans) == (1.2, 0.4, 1.3, 0.0)
    assert b.specular_transmittance_sampling_rate == 0.5 and b.diffuse_transmittance_sampling_rate == 1.0


def test_principled_reads_textures_on_every_parameter_mitsuba_textures(tmp_path):
    """A texture (nested or referenced) on metallic, clearcoat, ... and principledthin's eta loads as that texture;
    Mitsuba's number-only parameters are refused above (ERRORS)."""
    Image.fromarray(np.full((2, 2), 200, np.uint8), mode="L").save(tmp_path / "m.png")
    p = write(tmp_path, '<texture type="checkerboard" id="chk"><float name="color0" value="0.1"/></texture>'
                        '<shape type="sphere"><bsdf type="principled">'
                        '<texture type="bitmap" name="metallic"><string name="filename" value="m.png"/></texture>'
                        '<ref name="clearcoat" id="chk"/><float name="sheen" value="0.3"/></bsdf></shape>')
    b = durer.load(p).materials[0].bsdf
    assert isinstance(b.metallic, Bitmap) and isinstance(b.clearcoat, Checker) and b.sheen == 0.3
    np.testing.assert_allclose(b.metallic.image, (200 / 255) ** 2.2, rtol=0.05)  # sRGB-decoded, not raw
    np.testing.assert_allclose(b.clearcoat.color0, 0.1)
    q = write(tmp_path, '<shape type="rectangle"><bsdf type="principledthin">'
                        '<texture type="checkerboard" name="eta"><float name="color1" value="1.6"/></texture>'
                        '<texture type="checkerboard" name="diff_trans"/><float name="flatness" value="0.2"/>'
                        '</bsdf></shape>')
    b = durer.load(q).materials[0].bsdf
    assert isinstance(b.eta, Checker) and isinstance(b.diff_trans, Checker) and b.flatness == 0.2
    np.testing.assert_allclose(b.eta.color1, 1.6)


def test_load_dict_matches_the_xml():
    """The dict of mi.cornell_box()'s structure (plain arrays for transforms) gives the XML's scene."""
    xml = durer.load(EXAMPLES / "cornell_box.xml")
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": 8},
         "sensor": {"type": "perspective", "fov": 39.3077, "fov_axis": "smaller", "near_clip": 0.001,
                    "to_world": np.array([[-1, 0, 0, 0], [0, 1, 0, 0], [0, 0, -1, 3.9], [0, 0, 0, 1.0]]),
                    "sampler": {"type": "independent", "sample_count": 64},
                    "film": {"type": "hdrfilm", "width": 256, "height": 256, "rfilter": {"type": "box"}}},
         "white": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.885809, 0.698859, 0.666422]}},
         "back": {"type": "rectangle", "to_world": np.diag([1, 1, 1, 1.0]) + np.array([[0, 0, 0, 0], [0, 0, 0, 0],
                                                                                          [0, 0, 0, -1], [0] * 4]),
                  "bsdf": {"type": "ref", "id": "white"}}}
    s = durer.load_dict(d)
    assert s.render_defaults == xml.render_defaults
    np.testing.assert_allclose(s.camera.direction, xml.camera.direction)
    assert s.camera.angle == pytest.approx(xml.camera.angle)
    np.testing.assert_allclose(s.group.objects[0].matrix, xml.group.objects[3].matrix)


def test_load_dict_of_mitsuba_itself():
    mi = pytest.importorskip("mitsuba", reason="mi.cornell_box() is the dict to compare with")
    mi.set_variant("scalar_rgb")
    s = durer.load_dict(mi.cornell_box())
    assert len(s.group.objects) == 8 and s.render_defaults["filter"] == "mitsuba_gaussian"


ERRORS = [
    ("<shape type=\"sphere\">", 4, "malformed XML"),
    ("<shape type=\"bunny\"/>", 3, "unsupported shape 'bunny'"),
    ("<bsdf type=\"null\" id=\"x\"/>", 3, "unsupported bsdf 'null'"),
    ("<bsdf type=\"principledthin\" id=\"x\">\n<texture type=\"checkerboard\" "
     "name=\"diffuse_transmittance_sampling_rate\"/></bsdf>", 4,
     "principledthin's diffuse_transmittance_sampling_rate is a number, not a texture (as in Mitsuba)"),
    ("<bsdf type=\"principledthin\" id=\"x\">\n<float name=\"diff_trans\" value=\"2.5\"/></bsdf>", 3,
     "principledthin diff_trans must be in [0, 2], got 2.5"),
    ("<bsdf type=\"principledthin\" id=\"x\">\n<float name=\"metallic\" value=\"0.5\"/></bsdf>", 4,
     "unsupported parameter 'metallic' of bsdf 'principledthin'"),
    ("<bsdf type=\"principled\" id=\"x\">\n<texture type=\"checkerboard\" name=\"eta\"/></bsdf>", 4,
     "principled's eta is a number, not a texture (as in Mitsuba)"),
    ("<bsdf type=\"principled\" id=\"x\">\n<texture type=\"checkerboard\" name=\"specular\"/></bsdf>", 4,
     "principled's specular is a number, not a texture (as in Mitsuba)"),
    ("<bsdf type=\"principled\" id=\"x\"><float name=\"eta\" value=\"1.4\"/>\n"
     "<float name=\"specular\" value=\"0.3\"/></bsdf>", 4, "principled: give eta or specular, not both"),
    ("<bsdf type=\"principled\" id=\"x\">\n<float name=\"metallic\" value=\"1.5\"/></bsdf>", 3,
     "principled metallic must be in [0, 1], got 1.5"),
    ("<bsdf type=\"principled\" id=\"x\">\n<rgb name=\"roughness\" value=\"0.1 0.2 0.3\"/></bsdf>", 4,
     "roughness"),
    ("<emitter type=\"photon\"/>", 3, "unsupported emitter 'photon'"),
    ("<emitter type=\"spot\">\n<texture type=\"bitmap\" name=\"texture\"/></emitter>", 4,
     "bitmap needs a filename"),
    ("<shape type=\"sphere\"><emitter type=\"area\">\n<texture type=\"checkerboard\" name=\"irradiance\"/>"
     "</emitter></shape>", 4, "<texture> cannot appear in emitter 'area'"),
    ("<shape type=\"sdfgrid\"/>", 3, "sdfgrid needs a filename or a grid"),
    ("<integrator type=\"volpath\"/>", 3, "unsupported integrator 'volpath'"),
    ("<texture type=\"voronoi\"/>", 3, "unsupported texture 'voronoi'"),
    ("<shape type=\"sphere\">\n<float name=\"radius\" value=\"1\"/>\n<float name=\"size\" value=\"2\"/></shape>", 5,
     "unsupported parameter 'size' of shape 'sphere'"),
    ("<shape type=\"sphere\"><bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"phong\"/>"
     "</bsdf></shape>", 3, "unknown distribution 'phong'"),
    ("<shape type=\"sphere\">\n<float name=\"radius\" value=\"abc\"/></shape>", 4, "radius: not a number"),
    ("<shape type=\"sphere\">\n<float name=\"radius\" value=\"$nope\"/></shape>", 4, "undefined parameter $nope"),
    ("<shape type=\"sphere\">\n<ref id=\"missing\"/></shape>", 4, "reference to unknown id 'missing'"),
    ("<shape type=\"obj\">\n<string name=\"filename\" value=\"none.obj\"/></shape>", 4, "mesh file not found"),
    ("<emitter type=\"area\"/>", 3, "an area emitter belongs inside a shape"),
    ("<shape type=\"sphere\"><emitter type=\"point\"/></shape>", 3, "cannot be attached to a shape"),
    ("<shape type=\"sphere\"><bsdf type=\"diffuse\"/>\n<bsdf type=\"diffuse\"/></shape>", 4, "one bsdf"),
    ("<bsdf type=\"twosided\" id=\"t\"/>", 3, "twosided needs exactly one nested bsdf"),
    ("<shape type=\"cube\"><transform name=\"to_world\">\n<shear value=\"1\"/></transform></shape>", 4,
     "unsupported transform element <shear>"),
    ("<bsdf type=\"diffuse\" id=\"d\">\n<texture type=\"bitmap\" name=\"reflectance\">\n"
     "<string name=\"filename\" value=\"none.png\"/></texture></bsdf>", 5, "texture image not found: none.png"),
    ("<bsdf type=\"diffuse\" id=\"d\">\n<texture type=\"checkerboard\" name=\"albedo\"/></bsdf>", 4,
     "<texture> 'albedo' cannot appear in bsdf 'diffuse'"),
    ("<integrator type=\"path\">\n<integer name=\"max_depth\" value=\"2.5\"/></integrator>", 4, "not an integer"),
    ("<shape type=\"sphere\"><bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"unobtainium\"/></bsdf>"
     "</shape>", 3, "unknown int_ior 'unobtainium'"),
    ("<shape type=\"sphere\"><bsdf type=\"conductor\"><string name=\"material\" value=\"Zz\"/></bsdf></shape>", 3,
     "unknown conductor material 'Zz'"),
    ("<emitter type=\"envmap\">\n<string name=\"filename\" value=\"sky.exr\"/></emitter>", 4,
     "environment map not found: sky.exr"),
    ("<emitter type=\"envmap\"/>", 3, "envmap needs a filename"),
    ("<emitter type=\"constant\"/>\n<emitter type=\"constant\"/>", 4, "only one constant or envmap emitter"),
]


@pytest.mark.parametrize("body,line,message", ERRORS, ids=[e[2][:30] for e in ERRORS])
def test_every_error_is_one_line_with_file_and_line(tmp_path, body, line, message):
    p = write(tmp_path, body)
    with pytest.raises(SceneError) as e:
        durer.load(p)
    text = str(e.value)
    assert text.startswith(f"{p}:{line}: "), text
    assert message in text and "\n" not in text


SENSOR_ERRORS = [
    ("<sensor type=\"thinlens\"/>", 2, "thinlens needs an aperture_radius"),
    ("<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<rfilter type=\"mitchell\"><float name=\"B\" "
     "value=\"nan\"/></rfilter></film></sensor>", 3, "B: not a finite number: 'nan'"),
    ("<sensor type=\"perspective\"><film type=\"hdrfilm\">\n<rfilter type=\"catmullrom\"><float name=\"B\" "
     "value=\"0.5\"/></rfilter></film></sensor>", 3, "B"),
    ("<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><integer name=\"crop_width\" value=\"900\"/></film>"
     "</sensor>", 3, "crop window 900 x 576 at (0, 0) must lie inside the 768 x 576 film"),
    ("<sensor type=\"perspective\">\n<film type=\"hdrfilm\"><string name=\"pixel_format\" value=\"xyz\"/>"
     "</film></sensor>", 3, "durer's films are rgb or rgba, not pixel_format 'xyz'"),
]


@pytest.mark.parametrize("body,line,message", SENSOR_ERRORS, ids=[e[2][:30] for e in SENSOR_ERRORS])
def test_sensor_and_film_errors_are_one_line_with_file_and_line(tmp_path, body, line, message):
    p = write(tmp_path, body, sensor=False)
    with pytest.raises(SceneError) as e:
        durer.load(p)
    text = str(e.value)
    assert text.startswith(f"{p}:{line}: "), text
    assert message in text and "\n" not in text


def test_structural_errors(tmp_path):
    p = tmp_path / "r.xml"
    p.write_text("<sensor type=\"perspective\"/>\n")
    with pytest.raises(SceneError, match=r"r\.xml:1: the root element must be <scene>"):
        durer.load(p)
    with pytest.raises(SceneError, match="no sensor"):
        durer.load(write(tmp_path, "", sensor=False))
    with pytest.raises(SceneError, match="unsupported plugin type 'heightfield'"):
        durer.load_dict({"type": "scene", "t": {"type": "heightfield"}})


def test_cli_reports_one_line_and_exit_2(tmp_path):
    p = write(tmp_path, "<shape type=\"bunny\"/>")
    out = tmp_path / "o.png"
    r = subprocess.run([sys.executable, "-m", "durer", "render", str(p), "-o", str(out)], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and f"{p}:3:" in r.stderr
    assert not out.exists()


def test_cli_renders_xml_to_exr(tmp_path):
    pytest.importorskip("OpenEXR", reason="the openexr package writes .exr")
    import OpenEXR

    p = write(tmp_path, '<shape type="sphere"><point name="center" x="0" y="0" z="3"/>'
                        '<emitter type="area"><rgb name="radiance" value="2, 3, 4"/></emitter></shape>')
    out = tmp_path / "o.exr"
    r = subprocess.run([sys.executable, "-m", "durer", "render", str(p), "-o", str(out), "--samples", "1",
                        "--max-depth", "1", "-q"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    with OpenEXR.File(str(out)) as f:
        rgb = f.channels()["RGB"].pixels
    assert rgb.shape == (6, 8, 3)
    np.testing.assert_allclose(rgb.reshape(-1, 3).max(0), [2, 3, 4])


@pytest.mark.parametrize("kind", ["ply", "obj"])
def test_mesh_files_through_trimesh(tmp_path, kind):
    trimesh = pytest.importorskip("trimesh")
    box = trimesh.creation.box(extents=(2, 2, 2))
    box.export(tmp_path / f"box.{kind}")
    p = write(tmp_path, f'<shape type="{kind}"><string name="filename" value="box.{kind}"/>'
                        '<boolean name="flip_normals" value="true"/><transform name="to_world">'
                        '<translate x="1" y="2" z="3"/></transform></shape>')
    s = durer.load(p)
    t = s.group.objects[0]
    assert len(t.object.faces) == 12 and s.materials[t.object.material].flip_normals
    np.testing.assert_allclose(t.matrix[:3, 3], [1, 2, 3])
    np.testing.assert_allclose(np.abs(t.object.vertices).max(), 1.0)


def test_shapes_become_durer_geometry(tmp_path):
    p = write(tmp_path, '<shape type="rectangle"/><shape type="cube"/><shape type="disk"/>'
                        '<shape type="sphere"><float name="radius" value="2"/></shape>'
                        '<shape type="cylinder"><float name="radius" value="0.5"/><point name="p1" x="0" y="2" z="0"/>'
                        '</shape>')
    rect, cube, disk, sphere, cylinder = (o.object for o in durer.load(p).group.objects)

    def area(m):
        v = m.vertices[m.faces]
        return 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1).sum()

    def outward(m):  # every face normal points away from the origin (Mitsuba's orientation)
        v = m.vertices[m.faces]
        n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
        return (np.einsum("ij,ij->i", n, v.mean(axis=1)) > 0).all()

    assert area(rect) == pytest.approx(4) and (np.cross(*(rect.vertices[rect.faces[:, 1:]] -
                                                          rect.vertices[rect.faces[:, :1]]).transpose(1, 0, 2))[:, 2] > 0).all()
    assert area(cube) == pytest.approx(24) and outward(cube)
    assert isinstance(disk, durer.Disk) and isinstance(cylinder, durer.Cylinder)  # analytic, not triangle fans
    assert cylinder.radius == 0.5 and np.array_equal(cylinder.p1, [0, 2, 0])
    assert sphere.radius == 2
