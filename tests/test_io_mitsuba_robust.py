"""Bad Mitsuba XML (issue 25): a property of the wrong kind, references in a cycle, nesting without end, and
random mutations of valid scenes all end in one `file:line: what is wrong` SceneError, never a Python exception."""

from __future__ import annotations

import copy
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import durer
from durer.errors import SceneError
from durer.scene import bsdfs as B

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
CAM = ('<sensor type="perspective"><float name="fov" value="40"/>'
       '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>')
SENSOR = '<sensor type="perspective"><float name="fov" value="40"/>{}</sensor>'

# (scene body, the line of the error, what it says): every case the issue lists, and their relatives
PINNED = [
    ('<integrator type="path">\n<rgb name="max_depth" value="1, 2, 3"/></integrator>', 4,
     "max_depth of integrator 'path' must be an integer"),
    ('<integrator type="path">\n<string name="max_depth" value="x"/></integrator>', 4, "must be an integer"),
    (SENSOR.format('<sampler type="independent">\n<vector name="sample_count" x="1" y="2" z="3"/></sampler>'), 4,
     "sample_count of sampler 'independent' must be an integer"),
    (SENSOR.format('<film type="hdrfilm">\n<point name="width" x="1" y="2" z="3"/></film>'), 4,
     "width of film 'hdrfilm' must be an integer"),
    (SENSOR.format('<film type="hdrfilm">\n<transform name="width"><translate x="1"/></transform></film>'), 4,
     "width of film 'hdrfilm' must be an integer"),
    (SENSOR.format('<sampler type="independent">\n<float name="sample_count" value="1e30"/></sampler>'), 4,
     "must be an integer"),
    ('<bsdf type="dielectric" id="d">\n<rgb name="int_ior" value="1, 2, 3"/></bsdf>', 4,
     "int_ior of bsdf 'dielectric' must be a number or a material name"),
    ('<bsdf type="dielectric" id="d">\n<transform name="int_ior"><scale value="2"/></transform></bsdf>', 4,
     "int_ior of bsdf 'dielectric' must be a number"),
    ('<bsdf type="diffuse" id="d">\n<transform name="reflectance"><scale value="2"/></transform></bsdf>', 4,
     "reflectance of bsdf 'diffuse' must be a colour"),
    ('<bsdf type="twosided" id="a">\n<ref id="a"/></bsdf>', 4, "reference cycle: 'a'"),
    ('<bsdf type="twosided" id="a"><ref id="b"/></bsdf>\n<bsdf type="twosided" id="b">\n<ref id="a"/></bsdf>',
     5, "reference cycle: 'a'"),
    ('<integrator type="moment" id="m">\n<ref id="m"/></integrator>', 4, "reference cycle: 'm'"),
    ('<bsdf type="twosided" id="x">\n' + '<bsdf type="twosided">' * 20000 + '<bsdf type="diffuse"/>'
     + '</bsdf>' * 20001, 4, "elements nested more than 100 deep"),
    ('<include filename="s.xml"/>', 3, "s.xml includes itself"),
    ('<bsdf type="diffuse" id="q">\n<spectrum name="reflectance" value="500:1, 400:2"/></bsdf>', 4,
     "wavelengths must be finite and increasing"),
    ('<bsdf type="diffuse" id="q">\n<rgb name="reflectance" value="inf"/></bsdf>', 4, "numbers must be finite"),
]


def _write(d: Path, body: str) -> Path:
    p = d / "s.xml"
    p.write_text('<scene version="3.0.0">\n' + ("" if "<sensor" in body else CAM) + "\n" + body + "\n</scene>\n")
    return p


@pytest.mark.parametrize("body,line,message", PINNED, ids=[c[2][:40] for c in PINNED])
def test_bad_input_is_one_scene_error_at_its_line(tmp_path, body, line, message):
    p = _write(tmp_path, body)
    with pytest.raises(SceneError) as e:
        durer.load(p)
    text = str(e.value)
    assert text.startswith(f"{p}:{line}: ") and message in text and "\n" not in text, text


def test_python_values_of_the_wrong_kind_are_value_errors():
    """scene/bsdfs.py took float() of whatever it was given: an array index of refraction was a TypeError."""
    for make in (lambda: B.Dielectric(int_ior=np.eye(4)), lambda: B.Plastic(ext_ior=[1.0, 2.0, 3.0]),
                 lambda: B.RoughPlastic(alpha=[0.1, 0.2]), lambda: B.Dielectric(int_ior=True)):
        with pytest.raises(ValueError, match="must be one number"):
            make()
    assert B.Dielectric(int_ior=np.float32(1.25)).int_ior == 1.25


def test_load_dict_refuses_deep_nesting_and_cycles():
    d: dict = {"type": "diffuse"}
    for _ in range(2000):
        d = {"type": "twosided", "inner": d}
    with pytest.raises(SceneError, match="nested more than 100 deep"):
        durer.load_dict({"type": "scene", "b": d})
    with pytest.raises(SceneError, match="reference cycle: 'a'"):
        durer.load_dict({"type": "scene", "a": {"type": "twosided", "x": {"type": "ref", "id": "a"}}})


# --- fuzzing: random edits of valid scenes ------------------------------------------------------------------------
SEEDS = [(EXAMPLES / "cornell_box.xml").read_text(), (EXAMPLES / "caustic.xml").read_text(),
         '<scene version="3.0.0"><default name="r" value="1"/>' + CAM +
         '<integrator type="moment"><integrator type="direct"/></integrator>'
         '<emitter type="area" id="light"><spectrum name="radiance" value="400:1, 700:2"/></emitter>'
         '<bsdf type="conductor" id="metal"><spectrum name="eta" value="400:0.2, 700:1.1"/>'
         '<spectrum name="k" value="3"/></bsdf>'
         '<shape type="shapegroup" id="g"><shape type="sphere"><float name="radius" value="$r"/>'
         '<ref id="metal"/></shape></shape>'
         '<shape type="instance"><ref id="g"/></shape>'
         '<shape type="instance"><transform name="to_world"><translate x="3"/></transform><ref id="g"/></shape>'
         '<shape type="rectangle"><ref id="light"/></shape></scene>']
TAGS = ["scene", "bsdf", "shape", "emitter", "texture", "integrator", "sensor", "film", "rfilter", "sampler",
        "float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform", "ref",
        "include", "path", "default", "lookat", "translate", "medium", "foo"]
VALUES = st.one_of(
    st.sampled_from(["", "0", "-1", "1e400", "nan", "inf", "true", "1, 2, 3", "1 2 3 4", "$r", "$missing",
                     "400:1, 500:2", "500:1, 400:2", "diffuse", "twosided", "sphere", "light", "metal", "g",
                     "s.xml", "../", "50mm", "x"]),
    st.integers(-3, 70000).map(str), st.floats(allow_nan=True).map(repr), st.text(max_size=6))


@st.composite
def mutated(draw) -> str:
    root = ET.fromstring(draw(st.sampled_from(SEEDS)))
    for _ in range(draw(st.integers(1, 4))):
        elems = list(root.iter())
        e = draw(st.sampled_from(elems))
        parent = next((p for p in elems if e in list(p)), None)
        op = draw(st.sampled_from(["attr", "newattr", "tag", "drop", "dup", "nest", "ref"]))
        if op == "attr" and e.attrib:
            e.set(draw(st.sampled_from(sorted(e.attrib))), draw(VALUES))
        elif op == "newattr":
            e.set(draw(st.sampled_from(["name", "value", "type", "id", "x", "angle", "filename", "version"])),
                  draw(VALUES))
        elif op == "tag":
            e.tag = draw(st.sampled_from(TAGS))
        elif op == "drop" and parent is not None:
            parent.remove(e)
        elif op == "dup" and parent is not None:
            parent.append(copy.deepcopy(e))
        elif op == "nest" and parent is not None:
            other = draw(st.sampled_from(elems))
            if other is not e and e not in other.iter():
                parent.remove(e)
                other.append(e)
        elif op == "ref":
            e.append(ET.Element("ref", {"id": draw(VALUES), **({"name": "reflectance"} if draw(st.booleans())
                                                              else {})}))
    return ET.tostring(root, encoding="unicode")


@settings(max_examples=1000, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
@given(mutated())
@example('<scene version="3.0.0"><integrator type="path"><rgb name="max_depth" value="1"/></integrator></scene>')
@example('<scene version="0.5.0"/>')
@example('<scene>' + CAM + '<shape type="sphere"><ref id="a\nb\u2028c"/></shape></scene>')
@example('<scene>' + CAM + '<shape type="cube"><transform name="to_world"><rotate x="1" angle="1e400"/>'
         '<scale value="1e300"/><scale value="1e300"/></transform></shape></scene>')
@example('<scene><bsdf type="twosided" id="a"><ref id="a"/></bsdf></scene>')
@pytest.mark.slow
def test_mutated_scenes_load_or_raise_one_scene_error(text):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "s.xml"
        p.write_text(text)
        try:
            scene = durer.load(p)
        except SceneError as e:
            assert len(str(e).splitlines()) == 1 and str(e).startswith(str(p)), str(e)
        else:
            assert scene.camera is not None
