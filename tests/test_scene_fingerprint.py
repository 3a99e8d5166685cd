"""The scene's content fingerprint (scene/fingerprint.py): equal content fingerprints equal, any change of a value,
an array element (in place), a list or the sharing of objects changes it, and what it cannot read is None."""

from __future__ import annotations

import copy

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from durer import Group, PerspectiveCamera, PhongMaterial, PointLight, Scene, Sphere, Transform, TriangleMesh
from durer.scene.fingerprint import fingerprint


def _scene() -> Scene:
    mesh = TriangleMesh(vertices=[[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], faces=[[0, 1, 2], [1, 3, 2]])
    return Scene(camera=PerspectiveCamera(center=(0, 0, 5), direction=(0, 0, -1), up=(0, 1, 0), angle=30),
                 group=Group([mesh, Transform(np.eye(4), mesh), Sphere(center=(0, 0, -1), radius=0.5)]),
                 materials=[PhongMaterial(diffuse_color=(0.5, 0.2, 0.1))], lights=[PointLight(position=(1, 2, 3))])


def test_equal_content_fingerprints_equal_and_the_camera_can_be_left_out():
    a, b = _scene(), _scene()
    assert fingerprint(a) == fingerprint(b) == fingerprint(copy.deepcopy(a))
    assert len(fingerprint(a)) == 32
    b.camera.angle = 40.0
    assert fingerprint(a) != fingerprint(b)
    assert fingerprint(a, skip=("camera",)) == fingerprint(b, skip=("camera",))


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 11), st.floats(-10, 10, allow_nan=False).filter(lambda v: v != 0.0))
def test_any_vertex_changed_in_place_changes_it(i, delta):
    s = _scene()
    before = fingerprint(s)
    flat = s.group.objects[0].vertices.reshape(-1)
    old = flat[i]
    flat[i] += delta
    assume(flat[i] != old)  # a delta below the value's rounding leaves the content as it was
    assert fingerprint(s) != before


def test_values_lists_and_sharing_change_it():
    base = fingerprint(_scene())
    edits = [lambda s: s.materials[0].diffuse_color.__setitem__(1, 0.3),  # an array element in place
             lambda s: setattr(s.group.objects[2], "radius", 0.6),
             lambda s: s.group.objects.append(Sphere(center=(1, 0, 0), radius=0.1)),
             lambda s: s.group.objects[1].matrix.__setitem__((0, 3), 1.0),
             lambda s: s.lights.pop(),
             lambda s: setattr(s, "environment", None) or s.render_defaults.update(samples=8),
             lambda s: setattr(s.group.objects[1], "object", copy.deepcopy(s.group.objects[0]))]  # a copy, not shared
    for k, edit in enumerate(edits):
        s = _scene()
        edit(s)
        assert fingerprint(s) != base, k


def test_what_it_cannot_read_is_none_and_deep_trees_are_no_limit():
    s = _scene()
    s.group.objects[2].note = lambda: 1  # not picklable: unknown
    assert fingerprint(s) is None
    deep = _scene()
    node = deep.group
    for _ in range(5000):  # far deeper than Python's recursion limit
        node.objects.append(Group([]))
        node = node.objects[-1]
    assert fingerprint(deep) != fingerprint(_scene())


@settings(max_examples=40, deadline=None)
@given(st.binary(min_size=1, max_size=120), st.data())
def test_any_byte_of_an_array_changed_changes_it(data, draw):
    i = draw.draw(st.integers(0, len(data) - 1))
    b = draw.draw(st.integers(0, 255).filter(lambda v: v != data[i]))
    changed = data[:i] + bytes([b]) + data[i + 1:]
    assert fingerprint([np.frombuffer(data, np.uint8)]) != fingerprint([np.frombuffer(changed, np.uint8)])


def test_array_views_read_their_own_elements_in_c_order():
    a = np.arange(24.0).reshape(4, 6)
    assert fingerprint([a[:, 1:]]) == fingerprint([np.ascontiguousarray(a[:, 1:])]) != fingerprint([a[:, :5]])
    assert fingerprint([a.T]) == fingerprint([np.ascontiguousarray(a.T)]) != fingerprint([a.reshape(6, 4)])
    assert fingerprint([np.zeros(3, np.uint8)]) != fingerprint([np.zeros(4, np.uint8)])
    unaligned = np.frombuffer(b"\x00" + a.tobytes(), np.uint8)[1:].view(np.float64).reshape(4, 6)
    assert fingerprint([unaligned]) == fingerprint([a])
