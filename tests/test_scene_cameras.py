"""Camera rays at the corner and centre pixels, basis construction, non-square images."""

from __future__ import annotations

import numpy as np
import pytest

from durer.scene.cameras import (
    FisheyeCamera,
    OrthographicCamera,
    PanoramaCamera,
    PerspectiveCamera,
    orthonormal_basis,
    pixel_centers,
)


def test_basis_is_orthonormal_from_skewed_up_and_long_direction():
    d, u, h = orthonormal_basis((0, 0, -5), (0, 3, 1))
    np.testing.assert_allclose(d, [0, 0, -1])
    np.testing.assert_allclose(u, [0, 1, 0], atol=1e-15)
    np.testing.assert_allclose(h, np.cross(d, u))
    np.testing.assert_allclose(h, [1, 0, 0], atol=1e-15)


@pytest.mark.parametrize("up", [(0, 0, 1), (0, 0, -2), (0, 0, 0)])
def test_up_parallel_to_direction_is_an_error(up):
    with pytest.raises(ValueError, match="parallel"):
        orthonormal_basis((0, 0, -1), up)


def test_zero_direction_is_an_error():
    with pytest.raises(ValueError, match="zero length"):
        orthonormal_basis((0, 0, 0), (0, 1, 0))


def test_pixel_centres_row_zero_is_the_top():
    p = pixel_centers(4, 2)
    assert p.shape == (2, 4, 2)
    np.testing.assert_allclose(p[0, 0], [0.5, 1.5])  # top-left pixel
    np.testing.assert_allclose(p[1, 3], [3.5, 0.5])  # bottom-right pixel


def test_orthographic_corner_and_centre_rays():
    cam = OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -2), up=(0, 1, 0), size=5)
    # 2x2 image: pixel centres at +-1/4 of the size from the centre
    o, d, valid = cam.generate_rays(pixel_centers(2, 2).reshape(-1, 2), 2, 2)
    assert valid.all()
    np.testing.assert_allclose(d, np.tile([0, 0, -1], (4, 1)))
    np.testing.assert_allclose(o[0], [-1.25, 1.25, 10])   # top-left
    np.testing.assert_allclose(o[3], [1.25, -1.25, 10])   # bottom-right
    # the film corner (0, 0) is center - size*up/2 - size*horizontal/2, as the course specifies
    o, _, _ = cam.generate_rays(np.array([[0.0, 0.0]]), 2, 2)
    np.testing.assert_allclose(o[0], [-2.5, -2.5, 10])
    assert cam.t_min == -np.inf


def test_perspective_centre_and_corner_rays():
    cam = PerspectiveCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), angle=90)
    o, d, _ = cam.generate_rays(np.array([[1.0, 1.0], [2.0, 2.0], [0.0, 1.0]]), 2, 2)
    np.testing.assert_allclose(o, np.tile([0, 0, 10], (3, 1)))
    np.testing.assert_allclose(d[0], [0, 0, -1])                        # image centre
    np.testing.assert_allclose(d[1], np.array([1, 1, -1]) / np.sqrt(3))  # corner: tan(45 deg) = 1 per axis
    np.testing.assert_allclose(d[2], np.array([-1, 0, -1]) / np.sqrt(2))  # left edge: the full half-angle
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    assert cam.t_min == 0.0


def test_non_square_images_keep_square_pixels_and_crop_the_shorter_side():
    cam = OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), size=2)
    o, _, _ = cam.generate_rays(pixel_centers(4, 2).reshape(-1, 2), 4, 2)
    o = o.reshape(2, 4, 3)
    step_x = o[0, 1, 0] - o[0, 0, 0]
    step_y = o[0, 0, 1] - o[1, 0, 1]
    assert step_x == pytest.approx(step_y) == pytest.approx(0.5)  # longer side (4 px) spans size 2
    np.testing.assert_allclose(o[0, 0, :2], [-0.75, 0.25])
    # a tall image: the height spans the size
    o, _, _ = cam.generate_rays(pixel_centers(2, 4).reshape(-1, 2), 2, 4)
    np.testing.assert_allclose(o.reshape(4, 2, 3)[0, 0, :2], [-0.25, 0.75])


def test_fisheye_centre_edge_and_outside():
    cam = FisheyeCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=180)
    _, d, valid = cam.generate_rays(np.array([[5.0, 5.0], [10.0, 5.0], [10.0, 10.0]]), 10, 10)
    np.testing.assert_allclose(d[0], [0, 0, -1])
    np.testing.assert_allclose(d[1], [1, 0, 0], atol=1e-12)  # edge of the circle: 90 degrees off axis
    assert valid.tolist() == [True, True, False]


def test_panorama_covers_the_sphere():
    cam = PanoramaCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0))
    _, d, _ = cam.generate_rays(np.array([[50.0, 25.0], [75.0, 25.0], [50.0, 50.0]]), 100, 50)
    np.testing.assert_allclose(d[0], [0, 0, -1], atol=1e-12)  # image centre looks along direction
    np.testing.assert_allclose(d[1], [1, 0, 0], atol=1e-12)   # a quarter turn right
    np.testing.assert_allclose(d[2], [0, 1, 0], atol=1e-12)   # top edge looks up


@pytest.mark.parametrize("kwargs", [dict(size=0), dict(size=-1)])
def test_orthographic_size_must_be_positive(kwargs):
    with pytest.raises(ValueError, match="size"):
        OrthographicCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), **kwargs)


@pytest.mark.parametrize("angle", [0, 180, -10])
def test_perspective_angle_range(angle):
    with pytest.raises(ValueError, match="angle"):
        PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=angle)


def test_fisheye_outside_the_circle_is_background():
    import durer

    scene = durer.Scene(camera=FisheyeCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=180),
                        group=durer.Group([durer.Sphere((0, 0, 0), 10)]), background_color=(0.2, 0.4, 0.6))
    r = durer.render(scene, 16, 16)
    assert np.allclose(r.color[0, 0], [0.2, 0.4, 0.6])  # a corner: outside the image circle, no ray
    assert np.allclose(r.color[8, 8], [1, 1, 1])         # inside the sphere: its flat white
    assert r.depth[0, 0] == np.inf and r.depth[8, 8] == pytest.approx(10.0)


@pytest.mark.parametrize("shape", [(30, 20), (20, 30), (25, 25)])
def test_frame_sphere_sees_the_whole_sphere_from_above_and_aside(shape):
    from durer.scene.cameras import frame_sphere, pixel_centers

    center, radius = np.array([3.0, -1.0, 2.0]), 1.5
    cam = frame_sphere(center, radius, *shape)
    to_center = center - cam.center
    assert np.allclose(cam.direction, to_center / np.linalg.norm(to_center))
    assert cam.direction[1] < 0 and cam.direction[0] < 0 and cam.direction[2] < 0  # from above, right, front
    # every border pixel's ray misses the sphere; the centre ray hits it
    _, d, _ = cam.generate_rays(pixel_centers(*shape), *shape)
    along = (to_center[None, None] * d).sum(-1)
    miss = np.linalg.norm(to_center[None, None] - along[..., None] * d, axis=-1)
    border = np.concatenate([miss[0], miss[-1], miss[:, 0], miss[:, -1]])
    assert (border > radius).all() and miss[shape[1] // 2, shape[0] // 2] < radius
    assert (miss < radius).mean() > 0.4  # the sphere fills a good part of the image


@pytest.mark.parametrize("camera", [
    OrthographicCamera(center=(1, 2, 3), direction=(0.2, -0.1, -1), up=(0, 1, 0.3), size=4),
    PerspectiveCamera(center=(1, 2, 3), direction=(0.2, -0.1, -1), up=(0, 1, 0.3), angle=50),
    FisheyeCamera(center=(1, 2, 3), direction=(0.2, -0.1, -1), up=(0, 1, 0.3), angle=220),
    PanoramaCamera(center=(1, 2, 3), direction=(0.2, -0.1, -1), up=(0, 1, 0.3)),
], ids=lambda c: type(c).__name__)
def test_project_inverts_generate_rays(camera):
    """project(o + t d) gives back the film point each ray came from, for any t in front (and any t at all for
    the orthographic camera, whose rays come from infinity)."""
    w, h = 40, 20
    rng = np.random.default_rng(1)
    film = rng.random((200, 2)) * (w, h)
    o, d, valid = camera.generate_rays(film, w, h)
    t = rng.uniform(0.1, 30.0, 200) * (np.where(rng.random(200) < 0.5, -1, 1) if camera.t_min < 0 else 1)
    back, seen = camera.project(o + t[:, None] * d, w, h)
    assert seen[valid].all()
    np.testing.assert_allclose(back[valid], film[valid], atol=1e-9)


def test_perspective_project_marks_points_behind_the_camera():
    cam = PerspectiveCamera(center=(0, 0, 0), direction=(0, 0, -1), up=(0, 1, 0), angle=90)
    film, seen = cam.project(np.array([[0, 0, -1], [0, 0, 1], [1, 0, -1]]), 100, 100)
    assert seen.tolist() == [True, False, True]
    np.testing.assert_allclose(film[0], [50, 50])
    np.testing.assert_allclose(film[2], [100, 50])  # 45 degrees right: the image's right edge (fov 90)


def test_thin_lens_rays_leave_the_aperture_and_meet_on_the_focus_plane():
    """Mitsuba's thinlens: every ray through one film point crosses the pinhole ray on the plane focus_distance
    ahead, and leaves a point of the aperture disk, which the lens samples cover uniformly."""
    from durer.scene.cameras import concentric_disk

    cam = PerspectiveCamera((1, 2, 3), (0, 0, -1), (0, 1, 0), 50, aperture_radius=0.2, focus_distance=4.0)
    pinhole = PerspectiveCamera((1, 2, 3), (0, 0, -1), (0, 1, 0), 50)
    rng = np.random.default_rng(3)
    points = np.repeat(rng.uniform(0, 20, (5, 2)), 400, axis=0)
    lens = rng.random((len(points), 2))
    o, d, valid = cam.generate_rays(points, 20, 16, lens)
    po, pd, _ = pinhole.generate_rays(points, 20, 16)
    assert valid.all()
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0)
    np.testing.assert_allclose(o[:, 2], 3.0)  # the aperture is perpendicular to the view direction
    assert np.hypot(o[:, 0] - 1, o[:, 1] - 2).max() <= 0.2 + 1e-12
    on_focus = o + d * ((3.0 - 4.0 - o[:, 2]) / d[:, 2])[:, None]
    np.testing.assert_allclose(on_focus, po + pd * (-4.0 / pd[:, 2])[:, None], atol=1e-9)
    x, y = concentric_disk(rng.random((200000, 2)))
    assert np.hypot(x, y).max() <= 1 and (np.hypot(x, y) < 0.5).mean() == pytest.approx(0.25, abs=0.005)
    o0, d0, _ = cam.generate_rays(points, 20, 16)  # no lens samples: the pinhole's rays
    np.testing.assert_allclose(d0, pd) and np.testing.assert_allclose(o0, po)


def test_thin_lens_blur_matches_mitsuba():
    """A lit plane's edge 3 away seen through a thin lens focused at 1.5: the blurred edge's profile and the
    image mean as Mitsuba 3 renders them at equal samples."""
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 renders the reference")
    mi.set_variant("scalar_rgb")
    import durer

    edge = np.array([[1.0, 0, 0, 1.1], [0, 10, 0, 0], [0, 0, 1, 3.0], [0, 0, 0, 1]])
    scene = {"type": "scene", "integrator": {"type": "path", "max_depth": 1},
             "sensor": {"type": "thinlens", "fov": 30, "aperture_radius": 0.08, "focus_distance": 1.5,
                        "film": {"type": "hdrfilm", "width": 32, "height": 4, "rfilter": {"type": "box"}}},
             "light": {"type": "rectangle", "flip_normals": True, "to_world": edge,
                       "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}}}
    ours = np.asarray(durer.render(durer.load_dict(scene), samples=256).color)[..., 0].mean(axis=0)
    convert = {**scene, "light": {**scene["light"], "to_world": mi.ScalarTransform4f(edge)}}
    ref = np.array(mi.render(mi.load_dict(convert), spp=256, seed=4))[..., 0].mean(axis=0)
    blurred = (ref > 0.02) & (ref < 0.98)
    assert blurred.sum() >= 4  # the edge spreads over several pixels
    assert ours.mean() == pytest.approx(ref.mean(), abs=0.01)
    np.testing.assert_allclose(ours, ref, atol=0.04)
