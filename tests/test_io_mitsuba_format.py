"""The Mitsuba 3 file format beyond single files and plain values: <path>, <include>, <default> and loader
parameters, <spectrum>, serialized meshes, focal lengths, wrapper integrators, shapegroups and checkerboards,
checked against Mitsuba itself where it is installed."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from durer.errors import SceneError
from durer.io.mitsuba import load_dict, load_mitsuba
from durer.io.serialized import read_serialized
from durer.io.spectra import spectrum_to_rgb
from durer.scene.bsdfs import Conductor, Diffuse, TwoSided
from durer.scene.textures import Checker

CAM = ('<sensor type="perspective"><float name="fov" value="40"/>'
       '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>')
PAIRS = ([400.0, 500.0, 600.0, 700.0], [0.092, 0.4, 0.16, 0.159])


def scene(tmp_path, body: str, name: str = "s.xml", cam: str = CAM):
    p = tmp_path / name
    p.write_text(f'<scene version="3.0.0">{cam}{body}</scene>')
    return p


def test_path_and_include_resolve_as_mitsuba(tmp_path):
    """<include> splices a file's children in place; files resolve in <path> folders (relative to the file that
    names them), newest first, then the scene's folder; defaults apply to included files and parameters override
    them."""
    (tmp_path / "lib" / "frag").mkdir(parents=True)
    (tmp_path / "lib" / "frag" / "f.xml").write_text(
        '<scene version="3.0.0"><bsdf type="diffuse" id="grey"><float name="reflectance" value="$g"/></bsdf>'
        '</scene>')
    p = scene(tmp_path, '<default name="g" value="0.25"/><path value="lib"/><include filename="frag/f.xml"/>'
              '<shape type="sphere"><ref id="grey"/></shape>')
    s = load_mitsuba(str(p))
    assert np.allclose(s.materials[0].bsdf.reflectance, 0.25)
    assert np.allclose(load_mitsuba(str(p), params={"g": 0.5}).materials[0].bsdf.reflectance, 0.5)
    with pytest.raises(SceneError, match=r"s\.xml:1: included file not found: nope\.xml"):
        load_mitsuba(str(scene(tmp_path, '<include filename="nope.xml"/>')))


def test_version_and_out_of_scope_elements(tmp_path):
    with pytest.raises(SceneError, match="Mitsuba 0.x scenes"):
        load_mitsuba(str(_raw(tmp_path, '<scene version="0.6.0"/>')))
    with pytest.raises(SceneError, match="participating media outside durer's scope"):
        load_mitsuba(str(scene(tmp_path, '<medium type="homogeneous" id="m"/>')))
    with pytest.raises(SceneError, match="participating media are outside durer's scope"):
        load_mitsuba(str(scene(tmp_path, '<integrator type="volpath"/>')))


def _raw(tmp_path, text: str):
    p = tmp_path / "raw.xml"
    p.write_text(text)
    return p


def test_spectra_become_rgb_as_in_mitsubas_rgb_variants(tmp_path):
    body = ('<bsdf type="diffuse" id="d"><spectrum name="reflectance" value="400:0.092, 500:0.4, 600:0.16, '
            '700:0.159"/></bsdf><shape type="sphere"><ref id="d"/><emitter type="area"><spectrum name="radiance" '
            'value="400:0, 500:8, 600:15.6, 700:18.4"/></emitter></shape>'
            '<shape type="sphere"><bsdf type="conductor"><spectrum name="eta" value="0.2"/><spectrum name="k" '
            'value="300:1.8, 400:1.65, 500:0.9, 600:0.2, 700:0.16, 800:0.18"/></bsdf></shape>')
    s = load_mitsuba(str(scene(tmp_path, body)))
    assert isinstance(s.materials[0].bsdf, Diffuse) and isinstance(s.materials[1].bsdf, Conductor)
    # Mitsuba 3.9.1 scalar_rgb, read back with mi.traverse
    assert np.allclose(s.materials[0].bsdf.reflectance, [0.0925723, 0.314136, 0.255851], atol=2e-6)
    assert np.allclose(s.materials[0].radiance, [20.7108, 10.8546, 2.77115], atol=2e-4)
    assert np.allclose(s.materials[1].bsdf.eta, 0.2)
    mi = pytest.importorskip("mitsuba", reason="Mitsuba's spectrum_list_to_srgb is the reference")
    mi.set_variant("scalar_rgb")
    for d65 in (True, False):
        ref = np.array(mi.spectrum_list_to_srgb(*PAIRS, bounded=False, d65=d65))
        assert np.allclose(spectrum_to_rgb(*PAIRS, emitter=not d65, bounded=False), ref, atol=2e-6)


def _serialized(vertices, faces, uvs=None, name="m") -> bytes:
    flags = 0x1000 | (0x0002 if uvs is not None else 0)
    body = struct.pack("<I", flags) + name.encode() + b"\0" + struct.pack("<QQ", len(vertices), len(faces))
    body += np.asarray(vertices, "<f4").tobytes() + (b"" if uvs is None else np.asarray(uvs, "<f4").tobytes())
    body += np.asarray(faces, "<u4").tobytes()
    data = struct.pack("<HH", 0x041C, 4) + zlib.compress(body)
    return data + struct.pack("<QI", 0, 1)


def test_serialized_meshes(tmp_path):
    v = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    (tmp_path / "q.serialized").write_bytes(_serialized(v, [[0, 1, 2], [0, 2, 3]], uvs=[[0, 0], [1, 0], [1, 1],
                                                                                       [0, 1]]))
    m = read_serialized((tmp_path / "q.serialized").read_bytes())
    assert m.name == "m" and np.array_equal(m.vertices, v) and m.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    assert m.uvs is not None and m.normals is None
    s = load_mitsuba(str(scene(tmp_path, '<shape type="serialized"><string name="filename" value="q.serialized"/>'
                                         '</shape>')))
    assert np.array_equal(s.group.objects[0].object.vertices, v)
    with pytest.raises(ValueError, match="shape_index 3 out of range"):
        read_serialized((tmp_path / "q.serialized").read_bytes(), 3)
    with pytest.raises(ValueError, match="not a Mitsuba serialized mesh"):
        read_serialized(b"\0" * 16)


def test_serialized_matches_mitsuba(tmp_path):
    from conftest import SHARED

    path = SHARED / "scenes" / "mitsuba" / "mitsuba-data" / "common" / "meshes" / "matpreview.serialized"
    if not path.is_file():
        pytest.skip(f"{path} not found (the shared Mitsuba scenes live in ../shared)")
    mi = pytest.importorskip("mitsuba", reason="Mitsuba's own reader is the reference")
    mi.set_variant("scalar_rgb")
    for index in range(3):
        ref = mi.load_dict({"type": "serialized", "filename": str(path), "shape_index": index})
        m = read_serialized(path.read_bytes(), index)
        params = mi.traverse(ref)
        assert np.allclose(np.array(params["vertex_positions"]).reshape(-1, 3), m.vertices, atol=1e-5)
        assert np.array_equal(np.array(params["faces"]).reshape(-1, 3), m.faces)


@pytest.mark.parametrize("focal,size,x_fov", [(None, (8, 6), 38.184841), ("35mm", (8, 6), 52.622543),
                                              ("50mm", (6, 8), 29.105461)])
def test_focal_length_gives_mitsubas_field_of_view(tmp_path, focal, size, x_fov):
    """Mitsuba: fov = 2 atan(43.27 mm / 2 f) along the diagonal; x_fov read back from Mitsuba 3.9.1."""
    f = "" if focal is None else f'<string name="focal_length" value="{focal}"/>'
    cam = (f'<sensor type="perspective">{f}<film type="hdrfilm"><integer name="width" value="{size[0]}"/>'
           f'<integer name="height" value="{size[1]}"/></film></sensor>')
    c = load_mitsuba(str(scene(tmp_path, "", cam=cam))).camera
    tan_long = np.tan(np.radians(c.angle) / 2)
    tan_x = tan_long if size[0] >= size[1] else tan_long * size[0] / size[1]
    assert np.degrees(2 * np.arctan(tan_x)) == pytest.approx(x_fov, abs=1e-3)


def test_wrapper_integrators_and_direct(tmp_path):
    s = load_mitsuba(str(scene(tmp_path, '<integrator type="moment"><integrator type="path">'
                                         '<integer name="max_depth" value="7"/></integrator></integrator>')))
    assert s.render_defaults["max_depth"] == 7
    s = load_mitsuba(str(scene(tmp_path, '<integrator type="aov"><string name="aovs" value="dd.y:depth"/>'
                                         '<integrator type="direct"/></integrator>')))
    assert s.render_defaults["max_depth"] == 2
    s = load_mitsuba(str(scene(tmp_path, '<integrator type="aov"><string name="aovs" value="p:position, u:uv,"/>'
                                         '<integrator type="path"/></integrator>')))  # Mitsuba skips empty items
    assert s.render_defaults["aov_outputs"] == ("position", "uv") and s.render_defaults["hit_aovs"]
    with pytest.raises(SceneError, match="exactly one nested integrator"):
        load_mitsuba(str(scene(tmp_path, '<integrator type="aov"><string name="aovs" value="d:depth"/>'
                                         '</integrator>')))
    for aovs, message in (("p:bogus", "unknown AOV type 'bogus'"), ("position", "not a name:type pair"),
                          ("d:depth, i:prim_index", "does not compute the 'prim_index' output")):
        with pytest.raises(SceneError, match=message) as e:
            load_mitsuba(str(scene(tmp_path, f'<integrator type="aov"><string name="aovs" value="{aovs}"/>'
                                             '<integrator type="path"/></integrator>')))
        err = e.value  # one FILE:LINE: line, at the aov integrator
        assert err.line is not None and str(err).startswith(f"{err.path}:{err.line}: ") and "\n" not in str(err)
    with pytest.raises(SceneError, match="emitter_samples >= 1"):
        load_mitsuba(str(scene(tmp_path, '<integrator type="direct"><integer name="bsdf_samples" value="0"/>'
                                         '</integrator>')))


def test_shapegroups_are_placed_once_per_instance(tmp_path):
    s = load_dict({"type": "scene", "cam": {"type": "perspective", "fov": 40.0},
                   "g": {"type": "shapegroup", "a": {"type": "rectangle", "bsdf": {"type": "twosided",
                                                                                    "b": {"type": "diffuse"}}}},
                   "i1": {"type": "instance", "x": {"type": "ref", "id": "g"}},
                   "i2": {"type": "instance", "to_world": np.diag([2.0, 2, 2, 1]), "x": {"type": "ref", "id": "g"}}})
    a, b = s.group.objects
    assert a.object is b.object and np.allclose(b.matrix, np.diag([2.0, 2, 2, 1]))
    assert isinstance(s.materials[0].bsdf, TwoSided) and len(s.materials) == 1


def test_checkerboard_on_a_bsdf_parameter(tmp_path):
    body = ('<texture type="checkerboard" id="c"><rgb name="color0" value="0.4"/><rgb name="color1" value="0.2"/>'
            '<transform name="to_uv"><scale x="8" y="4"/></transform></texture>'
            '<shape type="rectangle"><bsdf type="twosided"><bsdf type="diffuse"><ref name="reflectance" id="c"/>'
            '</bsdf></bsdf></shape>')
    s = load_mitsuba(str(scene(tmp_path, body)))
    tex = s.materials[s.group.objects[0].object.material].bsdf.bsdf.reflectance
    assert isinstance(tex, Checker) and np.allclose(tex.to_uv, np.diag([8.0, 4.0, 1.0]))
    assert np.allclose(tex.color0, 0.4) and np.allclose(tex.color1, 0.2)
    from durer.rendering.textures import TextureTable

    uv = np.array([[0.01, 0.01], [0.07, 0.01], [0.07, 0.13], [0.2, 0.2]])  # scaled: (.08,.04) (.56,.04) ...
    table = TextureTable()
    assert np.allclose(table.eval3(table.add(tex), uv)[:, 0], [0.4, 0.2, 0.4, 0.4])
    with pytest.raises(SceneError, match="bitmap needs a filename"):
        load_mitsuba(str(scene(tmp_path, '<shape type="rectangle"><bsdf type="diffuse"><texture type="bitmap" '
                                         'name="reflectance"/></bsdf></shape>')))
    with pytest.raises(SceneError, match="unsupported texture 'voronoi'"):
        load_mitsuba(str(scene(tmp_path, '<shape type="rectangle"><bsdf type="diffuse"><texture type="voronoi" '
                                         'name="reflectance"/></bsdf></shape>')))
    # spheres have Mitsuba's texture coordinates; a mesh file without any cannot carry a checkerboard
    load_mitsuba(str(scene(tmp_path, body.replace('type="rectangle"', 'type="sphere"'))))
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(SceneError, match="no texture coordinates"):
        load_mitsuba(str(scene(tmp_path, body.replace('type="rectangle">', 'type="obj"><string name="filename" '
                                                                           'value="flat.obj"/>'))))


def test_area_emitter_radiance_may_be_a_texture(tmp_path):
    """<texture name="radiance"> in an area emitter (nested or by reference) is the Surface's radiance; a mesh file
    without texture coordinates cannot carry it (one FILE:LINE error, as for a BSDF's texture)."""
    body = ('<texture type="checkerboard" id="c"><rgb name="color0" value="0.9"/><rgb name="color1" value="0.1"/>'
            '</texture><shape type="rectangle"><emitter type="area"><ref name="radiance" id="c"/></emitter></shape>'
            '<shape type="sphere"><emitter type="area"><texture type="checkerboard" name="radiance">'
            '<rgb name="color0" value="0.5, 0.25, 0"/></texture></emitter></shape>')
    s = load_mitsuba(str(scene(tmp_path, body)))
    rect, ball = (s.materials[o.object.material].radiance for o in s.group.objects)
    assert isinstance(rect, Checker) and np.allclose(rect.color0, 0.9) and np.allclose(rect.color1, 0.1)
    assert isinstance(ball, Checker) and np.allclose(ball.color0, [0.5, 0.25, 0]) and np.allclose(ball.color1, 0.2)
    (tmp_path / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    p = scene(tmp_path, '<shape type="obj">\n<string name="filename" value="flat.obj"/><emitter type="area">'
                        '<texture type="checkerboard" name="radiance"/></emitter></shape>')
    with pytest.raises(SceneError) as e:
        load_mitsuba(str(p))
    assert str(e.value) == (f"{p}:1: shape 'obj' has no texture coordinates for its emitter's textured radiance "
                            "(its mesh file has none)")


def test_thindielectric_reads_its_parameters(tmp_path):
    """thindielectric: int_ior / ext_ior (numbers or Mitsuba's names) and both colours, Mitsuba's defaults."""
    from durer.scene.bsdfs import ThinDielectric

    body = ('<shape type="rectangle"><bsdf type="thindielectric"><string name="int_ior" value="water"/>'
            '<float name="ext_ior" value="1.2"/><rgb name="specular_transmittance" value="0.5, 0.6, 0.7"/>'
            '</bsdf></shape><shape type="sphere"><bsdf type="thindielectric"/></shape>')
    s = load_mitsuba(str(scene(tmp_path, body)))
    a, b = (s.materials[getattr(o, "object", o).material].bsdf for o in s.group.objects)
    assert isinstance(a, ThinDielectric) and (a.int_ior, a.ext_ior) == (1.333, 1.2)
    assert np.allclose(a.specular_transmittance, [0.5, 0.6, 0.7]) and np.allclose(a.specular_reflectance, 1)
    assert (b.int_ior, b.ext_ior) == (1.5046, 1.000277)
    with pytest.raises(SceneError, match="cannot appear in bsdf 'thindielectric'"):
        load_mitsuba(str(scene(tmp_path, '<shape type="sphere"><bsdf type="thindielectric"><bsdf type="diffuse"/>'
                                         '</bsdf></shape>')))
