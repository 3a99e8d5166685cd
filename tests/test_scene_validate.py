"""scene/validate.py: mistakes in a Python-built scene are ValueErrors naming the object, before any rendering."""

from __future__ import annotations

import numpy as np
import pytest

import durer
from durer.scene.validate import check_scene


def scene(objects, materials=None, **kw) -> durer.Scene:
    return durer.Scene(camera=durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 40),
                       group=durer.Group(objects), materials=materials or [durer.PhongMaterial()], **kw)


@pytest.mark.parametrize(("make", "message"), [
    (lambda: scene([durer.Sphere((0, 0, 0), 1, material=3)]),
     r"scene\.group\.objects\[0\] \(Sphere\): material 3 out of range \(the scene has 1 materials, 0\.\.0\)"),
    (lambda: scene([durer.Group([durer.Plane((0, 1, 0), 0), durer.Sphere((0, 0, 0), 1, material=-1)])]),
     r"scene\.group\.objects\[0\]\.objects\[1\] \(Sphere\): material -1 out of range"),
    (lambda: scene([durer.Transform(durer.transforms.translate((1, 0, 0)), durer.Sphere((0, 0, 0), 1, material=1.5))]),
     r"scene\.group\.objects\[0\]\.object \(Sphere\): material must be an integer index, got 1\.5"),
    (lambda: scene(["sphere"]), r"scene\.group\.objects\[0\]: expected a Group, Transform or one of .*got str"),
    (lambda: scene([durer.Sphere((0, 0, 0), 1)], lights=[(0, 0, 1)]),
     r"scene\.lights\[0\]: expected one of DirectionalLight, PointLight, SpotLight, got tuple"),
    (lambda: scene([durer.Sphere((0, 0, 0), 1)], materials=[durer.PhongMaterial(), (1, 0, 0)]),
     r"scene\.materials\[1\]: expected a PhongMaterial or a solid texture"),
    (lambda: scene([durer.Sphere((0, 0, 0), 1)], materials=[durer.Checkerboard(0, 2)]),
     r"scene\.materials\[0\] \(Checkerboard\) material2: material 2 out of range"),
    (lambda: durer.Scene(camera=None, group=durer.Group([])), r"scene\.camera: expected one of .*got NoneType"),
])
def test_mistakes_name_the_object(make, message):
    s = make()
    with pytest.raises(ValueError, match=message):
        check_scene(s)
    with pytest.raises(ValueError, match=message):  # and durer.render says the same before rendering
        durer.render(s, 4, 4)


def test_a_good_scene_passes():
    check_scene(scene([durer.Sphere((0, 0, 0), 1), durer.Transform(durer.transforms.scale((2, 2, 2)),
                                                                   durer.Plane((0, 1, 0), 0, material=0))]))


def test_durer_lists_and_reaches_every_public_name():
    names = dir(durer)
    for name in durer.__all__:
        assert name in names
        assert getattr(durer, name) is not None
    assert "RaycastingScene" in names and "transforms" in names
    assert callable(durer.transforms.translate) and durer.RaycastingScene.__name__ == "RaycastingScene"


@pytest.mark.parametrize(("make", "message"), [
    (lambda: durer.PhongMaterial(diffuse_color="red"), r"PhongMaterial diffuse_color must be three numbers"),
    (lambda: durer.PhongMaterial(exponent="shiny"), r"PhongMaterial exponent must be a number, got 'shiny'"),
    (lambda: durer.PhongMaterial(specular_color=(1, 1, np.nan)), r"PhongMaterial specular_color must be finite"),
    (lambda: durer.DirectionalLight(direction=(0, 1)), r"DirectionalLight direction must be three numbers"),
    (lambda: durer.PointLight(position=(0, 0, 0), color="white"), r"PointLight color must be three numbers"),
    (lambda: durer.TriangleMesh(np.zeros((4, 2)), [[0, 1, 2]]), r"mesh vertices must be a \(V, 3\) array"),
    (lambda: durer.TriangleMesh(np.zeros((4, 3)), [0, 1, 2, 3]), r"mesh faces must be an \(F, 3\) array"),
    (lambda: durer.Transform(np.eye(3), durer.Sphere((0, 0, 0), 1)), r"transform matrix must be 4x4 numbers"),
])
def test_wrong_values_name_the_field(make, message):
    with pytest.raises(ValueError, match=message):
        make()
