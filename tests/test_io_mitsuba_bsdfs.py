"""Mitsuba's BSDF plugins read by io/mitsuba_bsdfs.py: normalmap's and bumpmap's flip_invalid_normals and
use_shadowing_function (true by default, as in Mitsuba 3), carried into the BSDF table's MAP_FLIP and MAP_SHADOW
columns, and a value that is not a boolean is one FILE:LINE SceneError."""

from __future__ import annotations

import pytest

from durer.errors import SceneError
from durer.io.mitsuba import load_mitsuba
from durer.kernels.path.columns import MAP_FLIP, MAP_SHADOW
from durer.rendering.bsdfs import BSDFTable
from durer.scene.bsdfs import BumpMap, NormalMap

CAM = ('<sensor type="perspective"><float name="fov" value="40"/>'
       '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>')
CHECKER = '<texture type="checkerboard" name="{}"/>'


def _load(tmp_path, wrapper: str, options: str):
    """The BSDF of a rectangle under a normalmap or bumpmap (a checkerboard as its texture) with `options`."""
    inner = CHECKER.format("normalmap" if wrapper == "normalmap" else "t")
    p = tmp_path / "s.xml"
    p.write_text(f'<scene version="3.0.0">\n{CAM}\n<shape type="rectangle">\n<bsdf type="{wrapper}">\n{options}\n'
                 f'{inner}<bsdf type="diffuse"/></bsdf></shape>\n</scene>\n')
    s = load_mitsuba(str(p))
    return p, s.materials[s.group.objects[0].object.material].bsdf


@pytest.mark.parametrize("wrapper,cls", [("normalmap", NormalMap), ("bumpmap", BumpMap)])
def test_map_options_default_to_mitsubas_and_reach_the_table(tmp_path, wrapper, cls):
    _, b = _load(tmp_path, wrapper, "")
    assert isinstance(b, cls) and b.flip_invalid_normals and b.use_shadowing_function
    P = BSDFTable.from_materials([b]).packed()[0]
    assert P[0, MAP_FLIP] == 1 and P[0, MAP_SHADOW] == 1
    for flip, shadow in ((False, True), (True, False), (False, False)):
        opts = (f'<boolean name="flip_invalid_normals" value="{str(flip).lower()}"/>'
                f'<boolean name="use_shadowing_function" value="{str(shadow).lower()}"/>')
        _, b = _load(tmp_path, wrapper, opts)
        assert (b.flip_invalid_normals, b.use_shadowing_function) == (flip, shadow)
        P = BSDFTable.from_materials([b]).packed()[0]
        assert (P[0, MAP_FLIP], P[0, MAP_SHADOW]) == (float(flip), float(shadow))


@pytest.mark.parametrize("wrapper", ["normalmap", "bumpmap"])
@pytest.mark.parametrize("option,message", [
    ('<float name="flip_invalid_normals" value="1"/>', "flip_invalid_normals of bsdf '{}' must be true or false"),
    ('<string name="use_shadowing_function" value="yes"/>',
     "use_shadowing_function of bsdf '{}' must be true or false"),
    ('<boolean name="use_shadowing_function" value="maybe"/>', "use_shadowing_function: not a boolean"),
])
def test_a_bad_map_option_is_one_line_with_file_and_line(tmp_path, wrapper, option, message):
    with pytest.raises(SceneError) as e:
        _load(tmp_path, wrapper, option)
    text = str(e.value)
    assert text.startswith(f"{tmp_path / 's.xml'}:5: "), text
    assert message.format(wrapper) in text and "\n" not in text


def test_map_options_must_be_booleans_in_the_python_api():
    from durer.scene.textures import Checker

    with pytest.raises(ValueError, match="use_shadowing_function must be true or false"):
        NormalMap(None, Checker(0.4, 0.2), True, "yes")
    with pytest.raises(ValueError, match="flip_invalid_normals must be true or false"):
        BumpMap(None, Checker(0.4, 0.2), 1.0, 1)
