"""The Whitted ray tracer (assignment 4): directions against closed forms, shadows without acne, energy bounds,
bounce and weight limits, and the wavefront against a plain recursive traceRay written out per ray."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import durer
from durer import (
    DirectionalLight,
    Group,
    OrthographicCamera,
    PerspectiveCamera,
    PhongMaterial,
    Plane,
    PointLight,
    Scene,
    Sphere,
    Transform,
    Triangle,
)
from durer.options import RenderOptions
from durer.rendering.renderer import make_context
from durer.rendering.whitted import RAY_EPSILON, mirror_direction, transmitted_direction, whitted


def unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def one(v) -> np.ndarray:
    return np.asarray(v, dtype=np.float64).reshape(1, 3)


vectors = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: np.linalg.norm(v) > 1e-2)


# --- directions ----------------------------------------------------------------------------------------------
def test_mirror_direction_closed_form():
    r = mirror_direction(one([0, 1, 0]), unit(one([1, -1, 0])))
    np.testing.assert_allclose(r, unit(one([1, 1, 0])), atol=1e-15)
    # the normal's orientation does not matter
    np.testing.assert_allclose(mirror_direction(one([0, -1, 0]), unit(one([1, -1, 0]))), r, atol=1e-15)
    # head-on: straight back
    np.testing.assert_allclose(mirror_direction(one([0, 0, 1]), one([0, 0, -1])), [[0, 0, 1]])


@settings(max_examples=200, deadline=None)
@given(vectors, vectors)
def test_mirror_direction_properties(n, d):
    n, d = unit(one(n)), unit(one(d))
    r = mirror_direction(n, d)
    assert np.linalg.norm(r) == pytest.approx(1.0, abs=1e-12)
    assert float(r[0] @ n[0]) == pytest.approx(-float(d[0] @ n[0]), abs=1e-12)   # angle of reflection
    np.testing.assert_allclose(np.cross(r - d, n), 0, atol=1e-12)                  # change only along N
    np.testing.assert_allclose(mirror_direction(n, r), d, atol=1e-12)              # involution


def test_refraction_closed_form_air_to_glass():
    """30 degrees from the normal into index 1.5: sin t = sin 30 / 1.5 = 1/3, bent towards the normal."""
    a = np.radians(30)
    d = one([np.sin(a), -np.cos(a), 0])
    t, ok = transmitted_direction(one([0, 1, 0]), d, 1.0, 1.5)
    assert ok.tolist() == [True]
    s = 1 / 3
    np.testing.assert_allclose(t, [[s, -np.sqrt(1 - s * s), 0]], atol=1e-15)


def test_refraction_normal_incidence_and_equal_indices_go_straight():
    d = unit(one([0.3, -1, 0.2]))
    t, ok = transmitted_direction(one([0, 1, 0]), d, 1.3, 1.3)
    assert ok.all()
    np.testing.assert_allclose(t, d, atol=1e-15)
    t, ok = transmitted_direction(one([0, 1, 0]), one([0, -1, 0]), 1.0, 2.4)
    np.testing.assert_allclose(t, [[0, -1, 0]], atol=1e-15)


@settings(max_examples=300, deadline=None)
@given(vectors, vectors, st.floats(1.0, 3.0), st.floats(1.0, 3.0))
def test_refraction_obeys_snell(n, d, n1, n2):
    n, d = unit(one(n)), unit(one(d))
    if float(d[0] @ n[0]) > -1e-3:          # the normal must face the incoming ray
        n = -n
        if float(d[0] @ n[0]) > -1e-3:
            return
    t, ok = transmitted_direction(n, d, n1, n2)
    cos_i = -float(d[0] @ n[0])
    sin_i = np.sqrt(max(0.0, 1 - cos_i * cos_i))
    if n1 * sin_i > n2 * (1 + 1e-9):
        assert not ok[0] and np.all(t == 0)  # beyond the critical angle: total internal reflection
        return
    if n1 * sin_i < n2 * (1 - 1e-9):
        assert ok[0]
    if not ok[0]:
        return
    assert np.linalg.norm(t) == pytest.approx(1.0, abs=1e-9)
    cos_t = -float(t[0] @ n[0])
    assert cos_t >= -1e-9                                                       # crosses the surface
    sin_t = np.sqrt(max(0.0, 1 - cos_t * cos_t))
    assert n1 * sin_i == pytest.approx(n2 * sin_t, abs=1e-7)                   # Snell's law
    assert abs(float(np.cross(d[0], n[0]) @ t[0])) < 1e-9                       # in the plane of incidence


@pytest.mark.parametrize("n_glass", [1.1, 1.5, 2.0, 2.4, 4.0])
def test_total_internal_reflection_at_the_critical_angle(n_glass):
    """Leaving glass into vacuum: at exactly the critical angle asin(1/n) the ray still leaves, grazing the
    surface; a millionth of a radian steeper it is totally reflected; a millionth shallower it refracts."""
    critical = np.arcsin(1 / n_glass)
    normal = one([0, 1, 0])

    def leave(angle):
        return transmitted_direction(normal, one([np.sin(angle), -np.cos(angle), 0]), n_glass, 1.0)

    t, ok = leave(critical)
    assert ok.tolist() == [True]
    np.testing.assert_allclose(t, [[1, 0, 0]], atol=1e-6)   # tangent to the surface
    t, ok = leave(critical + 1e-6)
    assert ok.tolist() == [False] and np.all(t == 0)
    t, ok = leave(critical - 1e-6)
    assert ok.tolist() == [True]
    assert t[0, 1] < 0 and t[0, 0] == pytest.approx(1.0, abs=1e-2)
    assert n_glass * np.sin(critical - 1e-6) == pytest.approx(t[0, 0], rel=1e-9)
    # entering the denser medium never reflects totally, even at grazing incidence
    _, ok = transmitted_direction(normal, one([np.sin(1.5707), -np.cos(1.5707), 0]), 1.0, n_glass)
    assert ok.all()


# --- scenes --------------------------------------------------------------------------------------------------
def ortho_down(size=4.0, height=10.0):
    return OrthographicCamera(center=(0, height, 0), direction=(0, -1, 0), up=(0, 0, -1), size=size)


def grazing(deg_from_horizon: float) -> tuple[float, float, float]:
    """Direction of light travelling down at `deg_from_horizon` degrees above the horizon (along +x)."""
    a = np.radians(deg_from_horizon)
    return (np.cos(a), -np.sin(a), 0.0)


@pytest.mark.parametrize("elevation", [0.5, 2.0, 5.0, 15.0])
def test_no_shadow_acne_on_a_lit_plane_at_grazing_angles(elevation):
    """A plane under a grazing directional light: every pixel is exactly the unshadowed value, no speckles."""
    kd = np.array([0.9, 0.8, 0.7])
    light = np.array([1.0, 1.0, 1.0])
    for plane in (Plane((0, 1, 0), -0.37), Plane((0.02, 1, -0.03), 0.5)):
        scene = Scene(camera=PerspectiveCamera(center=(-3, 4, 9), direction=(0.3, -0.5, -1), up=(0, 1, 0), angle=60),
                      group=Group([plane]), materials=[PhongMaterial(diffuse_color=kd)],
                      lights=[DirectionalLight(grazing(elevation), light)], ambient_light=(0.1, 0.1, 0.1))
        plain = durer.render(scene, 48, 48)
        shadowed = durer.render(scene, 48, 48, shadows=True)
        hit = np.isfinite(shadowed.depth)
        assert hit.mean() > 0.3
        np.testing.assert_array_equal(shadowed.color, plain.color)
        n = unit(plane.normal)
        expected = 0.1 * kd + max(0.0, float(n @ -unit(grazing(elevation)))) * kd
        np.testing.assert_allclose(shadowed.color[hit], np.broadcast_to(expected, (int(hit.sum()), 3)), rtol=1e-5)


@pytest.mark.parametrize("light", [DirectionalLight(grazing(3.0), (1, 1, 1)),
                                   DirectionalLight((0.2, -1, 0.1), (1, 1, 1)),
                                   PointLight((2.5, 0.3, 0.0), (1, 1, 1))])
def test_no_self_shadowing_on_convex_objects(light):
    """A lone sphere, an ellipsoid and a triangle fan are convex: shadow rays must not hit them where they are
    lit, so -shadows changes nothing, right up to the terminator."""
    objects = [Sphere((0, 0, 0), 1.0),
               Transform(np.diag([2.0, 0.5, 1.0, 1.0]) @ np.eye(4), Sphere((0, 0, 0), 1.0)),
               Group([Triangle((-3, -1, -3), (-3, -1, 3), (3, -1.2, 3)), Triangle((-3, -1, -3), (3, -1.2, 3), (3, -1, -3))])]
    for obj in objects:
        scene = Scene(camera=PerspectiveCamera(center=(0, 3, 8), direction=(0, -0.35, -1), up=(0, 1, 0), angle=40),
                      group=Group([obj]), materials=[PhongMaterial(diffuse_color=(1, 1, 1))], lights=[light],
                      ambient_light=(0.05, 0.05, 0.05))
        plain = durer.render(scene, 40, 40)
        shadowed = durer.render(scene, 40, 40, shadows=True)
        assert (plain.color.max(axis=2) > 0.06).any()
        np.testing.assert_array_equal(shadowed.color, plain.color)


def sphere_over_plane(light, **kw) -> Scene:
    return Scene(camera=ortho_down(), group=Group([Sphere((0, 1.5, 0), 0.5, material=0), Plane((0, 1, 0), 0, material=1)]),
                 materials=[PhongMaterial(diffuse_color=(1, 0, 0)), PhongMaterial(diffuse_color=(0, 1, 0))],
                 lights=[light], ambient_light=(0.2, 0.2, 0.2), **kw)


def test_shadow_is_cast():
    """Light at 45 degrees: the sphere's shadow falls 1.5 along +x on the plane (ambient only there), and the
    plane beyond it is lit."""
    scene = sphere_over_plane(DirectionalLight((1, -1, 0), (0.8, 0.8, 0.8)))
    lit_value = [0, 0.2 + 0.8 * np.sqrt(0.5), 0]
    for x, shadowed in ((1.5, [0, 0.2, 0]), (3.0, lit_value)):
        scene.camera = OrthographicCamera(center=(x, 10, 0), direction=(0, -1, 0), up=(0, 0, -1), size=0.2)
        np.testing.assert_allclose(durer.render(scene, 5, 5, shadows=True).color[2, 2], shadowed, rtol=1e-6)
        np.testing.assert_allclose(durer.render(scene, 5, 5).color[2, 2], lit_value, rtol=1e-6)


def test_point_light_shadow_stops_at_the_light():
    """An occluder beyond a point light casts no shadow; the same occluder between light and point does."""
    def scene(occluder):
        return Scene(camera=PerspectiveCamera(center=(0, 1, 0), direction=(0, -1, 0), up=(0, 0, -1), angle=1),
                     group=Group([Plane((0, 1, 0), 0), occluder]), materials=[PhongMaterial(diffuse_color=(1, 1, 1))],
                     lights=[PointLight((0, 2, 0), (1, 1, 1))], ambient_light=(0.1, 0.1, 0.1))
    beyond = durer.render(scene(Sphere((0, 3, 0), 0.3)), 1, 1, shadows=True)
    np.testing.assert_allclose(beyond.color[0, 0], [1.1, 1.1, 1.1])
    between = durer.render(scene(Sphere((0, 1.5, 0), 0.2)), 1, 1, shadows=True)   # behind the camera
    np.testing.assert_allclose(between.color[0, 0], [0.1, 0.1, 0.1])


def test_energy_bound_on_a_diffuse_scene():
    """Diffuse-only materials, shadows and bounces: no pixel exceeds ambient * kd + sum(light * kd), the most
    the lights can give, and the brightest pixels come close to it."""
    kd = [(0.9, 0.2, 0.5), (0.3, 0.8, 0.6), (1.0, 1.0, 1.0), (0.5, 0.5, 0.1)]
    objects = [Sphere((0, 1, 0), 1, material=0), Sphere((1.7, 0.6, 1), 0.6, material=1),
               Plane((0, 1, 0), 0, material=2), Triangle((-3, 0.1, -2), (-1, 0.1, -2), (-2, 2.5, -2), material=3)]
    lights = [DirectionalLight((0.3, -1, -0.2), (0.6, 0.5, 0.4)), DirectionalLight((-1, -0.4, 0.3), (0.3, 0.3, 0.5)),
              PointLight((0, 4, 3), (0.5, 0.5, 0.5), attenuation=(0.5, 0.1, 0.02))]
    ambient = np.array([0.15, 0.1, 0.2])
    scene = Scene(camera=PerspectiveCamera(center=(0, 4, 9), direction=(0, -0.4, -1), up=(0, 1, 0), angle=45),
                  group=Group(objects), materials=[PhongMaterial(diffuse_color=c) for c in kd], lights=lights,
                  ambient_light=ambient, background_color=(0, 0, 0))
    r = durer.render(scene, 64, 64, shadows=True, bounces=3, shade_back=True)
    kd_max = np.max(kd, axis=0)
    # a point light is brightest at distance 0, where 1 / (a + b d + c d^2) = 1 / a
    bound = kd_max * (ambient + np.array([0.6, 0.5, 0.4]) + np.array([0.3, 0.3, 0.5]) + np.array([0.5, 0.5, 0.5]) / 0.5)
    assert np.all(r.color <= bound + 1e-6)
    assert np.all(r.color >= 0)
    assert r.color.max() > 0.5 * bound.min()


# --- reflection and refraction through whole renders ---------------------------------------------------------
def mirror_scene(reflective=(0.5, 0.5, 0.5), background=(0.2, 0.4, 0.8)) -> Scene:
    return Scene(camera=ortho_down(), group=Group([Plane((0, 1, 0), 0)]),
                 materials=[PhongMaterial(diffuse_color=(0, 0, 0), reflective_color=reflective)],
                 lights=[DirectionalLight((0, -1, 0), (1, 1, 1))], background_color=background,
                 ambient_light=(0.3, 0.3, 0.3))


def test_mirror_reflects_the_background_times_reflective_colour():
    np.testing.assert_array_equal(durer.render(mirror_scene(), 4, 4, bounces=0, shadows=True).color, 0)
    r = durer.render(mirror_scene(reflective=(0.5, 0.25, 1.0)), 4, 4, bounces=1)
    np.testing.assert_allclose(r.color, np.broadcast_to([0.1, 0.1, 0.8], (4, 4, 3)), rtol=1e-6)


def test_weight_cutoff_uses_the_reflective_colour_magnitude():
    """A reflected ray carries weight |reflectiveColor| = 0.5 * sqrt(3) ~ 0.866 here: traced at -weight 0.86,
    cut off at -weight 0.87."""
    traced = durer.render(mirror_scene(), 2, 2, bounces=1, weight=0.86)
    cut = durer.render(mirror_scene(), 2, 2, bounces=1, weight=0.87)
    np.testing.assert_allclose(traced.color, np.broadcast_to([0.1, 0.2, 0.4], (2, 2, 3)), rtol=1e-6)
    np.testing.assert_array_equal(cut.color, 0)


def test_bounces_between_two_mirrors():
    """Looking straight down between two parallel mirrors facing each other: a ray bounces until -bounces runs
    out, each level adding the diffuse floor colour times the accumulated reflectivity."""
    # a pinhole inside the gap (an orthographic camera's rays start at infinity and would hit the top mirror first)
    mats = [PhongMaterial(diffuse_color=(0.4, 0.4, 0.4), reflective_color=(0.5, 0.5, 0.5))]
    scene = Scene(camera=PerspectiveCamera(center=(0, 0.5, 0), direction=(0, -1, 0), up=(0, 0, -1), angle=1),
                  group=Group([Plane((0, 1, 0), 0), Plane((0, -1, 0), -1)]), materials=mats,
                  lights=[], ambient_light=(1.0, 1.0, 1.0), background_color=(0, 0, 0))
    for bounces in range(5):
        r = durer.render(scene, 1, 1, bounces=bounces, weight=0.0)
        expected = sum(0.4 * 0.5 ** k for k in range(bounces + 1))
        np.testing.assert_allclose(r.color[0, 0], [expected] * 3, rtol=1e-6)


def test_transparent_sphere_multiplies_at_each_interface():
    """A clear sphere with index 1 bends nothing: the background behind it comes through times
    transparentColor at the way in and again at the way out, and only if enough bounces are allowed."""
    scene = Scene(camera=OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=0.1),
                  group=Group([Sphere((0, 0, 0), 1)]),
                  materials=[PhongMaterial(diffuse_color=(0, 0, 0), transparent_color=(0.5, 0.8, 1.0),
                                           index_of_refraction=1.0)],
                  lights=[DirectionalLight((0, 0, -1), (1, 1, 1))], background_color=(0.4, 0.5, 1.0))
    one_bounce = durer.render(scene, 3, 3, bounces=1, shade_back=True, shadows=True)
    np.testing.assert_array_equal(one_bounce.color, 0)  # the ray inside hits the black back face and stops
    two = durer.render(scene, 3, 3, bounces=2, shade_back=True, shadows=True)
    np.testing.assert_allclose(two.color[1, 1], [0.4 * 0.25, 0.5 * 0.64, 1.0], rtol=1e-6)


def test_refraction_through_a_glass_sphere_bends_like_a_lens():
    """A ray parallel to the axis at height h enters a glass ball (index n), bends by Snell's law on the way in
    and out, and crosses the wall behind the ball at a closed-form height: a thin black strip there darkens the
    pixel, the same strip moved by 0.05 either way does not."""
    n, h, wall_z = 1.5, 0.5, -3.0
    i = np.arcsin(h)                      # angle of incidence
    r = np.arcsin(np.sin(i) / n)          # refracted angle inside
    entry = np.array([0.0, h, np.cos(i)])
    exit_point = entry + 2 * np.cos(r) * np.array([0.0, -np.sin(i - r), -np.cos(i - r)])
    deviation = 2 * (i - r)
    y_wall = exit_point[1] - np.tan(deviation) * (exit_point[2] - wall_z)

    def pixel(y_strip: float) -> np.ndarray:
        z = wall_z + 0.01
        strip = Group([Triangle((-1, y_strip - 0.01, z), (1, y_strip - 0.01, z), (1, y_strip + 0.01, z), material=2),
                       Triangle((-1, y_strip - 0.01, z), (1, y_strip + 0.01, z), (-1, y_strip + 0.01, z), material=2)])
        scene = Scene(camera=OrthographicCamera(center=(0, h, 10), direction=(0, 0, -1), up=(0, 1, 0), size=1e-4),
                      group=Group([Sphere((0, 0, 0), 1, material=0), Plane((0, 0, 1), wall_z, material=1), strip]),
                      materials=[PhongMaterial(diffuse_color=(0, 0, 0), transparent_color=(1, 1, 1),
                                               index_of_refraction=n),
                                 PhongMaterial(diffuse_color=(1, 1, 1)), PhongMaterial(diffuse_color=(0, 0, 0))],
                      lights=[], ambient_light=(1, 1, 1), background_color=(0, 0, 0))
        return durer.render(scene, 1, 1, bounces=3, shade_back=True).color[0, 0]

    np.testing.assert_allclose(pixel(y_wall), 0, atol=1e-12)
    np.testing.assert_allclose(pixel(y_wall - 0.05), 1, atol=1e-6)
    np.testing.assert_allclose(pixel(y_wall + 0.05), 1, atol=1e-6)


# --- the wavefront against a per-ray recursive traceRay ------------------------------------------------------
def trace_ray(ctx, o, d, t_min, bounces, weight):
    """The course's recursive traceRay for one ray, written plainly (the wavefront must agree with it)."""
    from durer.rendering.raycaster import shade_local, surface
    from durer.rendering.whitted import shadow_visibility

    opts, table = ctx.options, ctx.materials
    hits = ctx.accel.closest_hit(o[None], d[None], t_min)
    if not hits.hit[0]:
        return ctx.bundle.background.copy()
    p, n, m = surface(ctx, o[None], d[None], hits)
    back = float(d @ n[0]) > 0
    facing = -n if back else n
    vis = shadow_visibility(ctx, p, facing) if opts.shadows else None
    colour = shade_local(ctx, p, n, d[None], m, light_visible=vis)[0]
    if bounces >= opts.bounces or (back and not opts.shade_back):
        return colour
    refl, tran, ior = table.reflective[m[0]], table.transparent[m[0]], table.ior[m[0]]
    if refl.any() and weight * np.linalg.norm(refl) >= opts.weight:
        r = mirror_direction(facing, d[None])[0]
        colour = colour + refl * trace_ray(ctx, p[0], r, RAY_EPSILON, bounces + 1, weight * np.linalg.norm(refl))
    if tran.any() and weight * np.linalg.norm(tran) >= opts.weight:
        ni, nt = (ior, 1.0) if back else (1.0, ior)
        t, ok = transmitted_direction(facing, d[None], ni, nt)
        if ok[0]:
            colour = colour + tran * trace_ray(ctx, p[0], t[0], RAY_EPSILON, bounces + 1, weight * np.linalg.norm(tran))
    return colour


@pytest.mark.parametrize(("bounces", "weight"), [(1, 0.01), (6, 0.01), (6, 0.3)])
def test_wavefront_matches_recursive_trace(bounces, weight):
    mats = [PhongMaterial(diffuse_color=(0.1, 0.1, 0.1), specular_color=(1, 1, 1), exponent=30,
                          reflective_color=(0.3, 0.3, 0.3), transparent_color=(0.6, 0.7, 0.5), index_of_refraction=1.6),
            PhongMaterial(diffuse_color=(0.2, 0.2, 0.2), reflective_color=(0.7, 0.5, 0.5)),
            PhongMaterial(diffuse_color=(0.9, 0.9, 0.9)),
            PhongMaterial(diffuse_color=(0.1, 0.3, 0.1), transparent_color=(0.4, 0.9, 0.9), index_of_refraction=2.4)]
    scene = Scene(camera=PerspectiveCamera(center=(0, 2, 6), direction=(0, -0.3, -1), up=(0, 1, 0), angle=50),
                  group=Group([Sphere((0, 0.5, 0), 1, material=0), Sphere((1.6, 0.2, -1), 0.7, material=1),
                               Plane((0, 1, 0), -0.6, material=2),
                               Transform(np.array([[0.6, 0, 0, -1.6], [0, 0.9, 0, 0.4], [0, 0, 0.4, 0.5], [0, 0, 0, 1]]),
                                         Sphere((0, 0, 0), 1, material=3))]),
                  materials=mats, lights=[DirectionalLight((0.4, -1, -0.3), (0.7, 0.7, 0.7)),
                                          PointLight((-2, 3, 2), (0.6, 0.6, 0.6), attenuation=(1, 0.1, 0))],
                  background_color=(0.2, 0.1, 0.5), ambient_light=(0.1, 0.1, 0.1))
    w = h = 9
    r = durer.render(scene, w, h, shadows=True, shade_back=True, bounces=bounces, weight=weight)
    ctx = make_context(scene, RenderOptions(shadows=True, shade_back=True, bounces=bounces, weight=weight))
    from durer.rendering import film
    points, _ = film.sample_points(w, h, ctx.options)
    origins, directions, _ = scene.camera.generate_rays(points, w, h)
    expected = np.array([trace_ray(ctx, o, d, scene.camera.t_min, 0, 1.0) for o, d in zip(origins, directions, strict=True)])
    np.testing.assert_allclose(r.color.reshape(-1, 3), expected, rtol=1e-6, atol=1e-9)
    batch = whitted(ctx, origins, directions, scene.camera.t_min)
    np.testing.assert_allclose(batch.color, expected, rtol=1e-9, atol=1e-12)
