"""Position and UV outputs (rendering/hit_aovs.py, Mitsuba's aov `position` and `uv`): closed forms on a plane and
a sphere seen from a known camera, every integrator; Mitsuba's surface interaction at the same points on every
analytic shape and mesh; Mitsuba's own aov integrator on the same scene; the command line's files."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

import durer

EYE, ANGLE, SIZE = np.array([0.0, 0.0, 4.0]), 50.0, 8
QUAD = durer.TriangleMesh(np.array([[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]),
                          uvs=np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float))  # Mitsuba's rectangle, scaled 2x
CENTRE, RADIUS = np.array([0.0, 0.0, 0.5]), 1.2


def scene(shape) -> durer.Scene:
    cam = durer.PerspectiveCamera(EYE, (0, 0, -1), (0, 1, 0), ANGLE)
    return durer.Scene(camera=cam, group=durer.Group([shape]), materials=[durer.PhongMaterial(diffuse_color=(.5,) * 3)],
                       lights=[durer.DirectionalLight((0, 0, -1), (1, 1, 1))])


def centre_rays() -> np.ndarray:
    """Unit directions (SIZE, SIZE, 3) of the rays through the pixel centres (row 0 at the top)."""
    s = np.tan(np.radians(ANGLE) / 2)
    c = ((np.arange(SIZE) + 0.5) / SIZE * 2 - 1) * s
    x, y = np.meshgrid(c, -c)
    d = np.stack([x, y, -np.ones_like(x)], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def sphere_hits(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest hit t of rays from EYE along unit d with the sphere (inf on a miss), and the hit mask."""
    oc = EYE - CENTRE
    b = d @ oc
    disc = b * b - (oc @ oc - RADIUS ** 2)
    hit = disc >= 0
    return np.where(hit, -b - np.sqrt(np.maximum(disc, 0)), np.inf), hit


def sphere_uv(q: np.ndarray) -> np.ndarray:
    """Mitsuba's sphere parametrisation of object-space points q: (phi / 2 pi, theta / pi), phi in [0, 2 pi)."""
    phi = np.mod(np.arctan2(q[..., 1], q[..., 0]), 2 * np.pi)
    theta = np.arccos(np.clip(q[..., 2] / np.linalg.norm(q, axis=-1), -1, 1))
    return np.stack([phi / (2 * np.pi), theta / np.pi], axis=-1)


INTEGRATORS = [dict(integrator="raycast"), dict(integrator="whitted", bounces=1, shadows=True)]


@pytest.mark.parametrize("kw", INTEGRATORS)
def test_a_plane_and_a_sphere_give_the_closed_forms_at_the_pixel_centres(kw):
    """One sample per pixel at its centre: the quad's hit is EYE + 4 d / |d_z| and its UV Mitsuba's rectangle's
    ((x + 2) / 4, (y + 2) / 4); the sphere's hit solves |p - c| = r and its UV is Mitsuba's formula; misses 0."""
    d = centre_rays()
    r = durer.render(scene(QUAD), SIZE, SIZE, hit_aovs=True, **kw)
    p = EYE + (4 / -d[..., 2:]) * d
    np.testing.assert_allclose(r.position, p, atol=1e-5)
    np.testing.assert_allclose(r.uv, (p[..., :2] + 2) / 4, atol=1e-6)
    np.testing.assert_allclose(r.position, EYE + r.depth[..., None] * d, atol=1e-5)  # the depth's point

    r = durer.render(scene(durer.Sphere(CENTRE, RADIUS)), SIZE, SIZE, hit_aovs=True, **kw)
    t, hit = sphere_hits(d)
    assert 0 < hit.sum() < hit.size
    p = np.where(hit[..., None], EYE + np.where(hit, t, 0)[..., None] * d, 0)
    np.testing.assert_allclose(r.position, p, atol=1e-5)
    np.testing.assert_allclose(r.uv, np.where(hit[..., None], sphere_uv(p - CENTRE), 0), atol=1e-5)


def test_the_path_tracers_centre_sample_lies_on_the_surface_within_the_pixel():
    """The path tracer's film samples are Sobol points, not the centres: each pixel's position is its sample
    nearest the centre, so it lies on the sphere (to float32), projects within half a pixel of the pixel centre,
    and its UV is Mitsuba's formula of it; misses (and only they) are 0."""
    r = durer.render(scene(durer.Sphere(CENTRE, RADIUS)), SIZE, SIZE, integrator="path", samples=4, hit_aovs=True)
    hit = np.isfinite(r.depth)
    assert 0 < hit.sum() < hit.size
    p = r.position[hit].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(p - CENTRE, axis=1), RADIUS, atol=1e-5)
    np.testing.assert_allclose(r.uv[hit], sphere_uv(p - CENTRE), atol=1e-5)
    assert not r.position[~hit].any() and not r.uv[~hit].any()
    v = p - EYE
    film = v[:, :2] / -v[:, 2:] / np.tan(np.radians(ANGLE) / 2) * SIZE / 2  # pixels from the image centre
    pixel = centre_rays()[hit][:, :2] / -centre_rays()[hit][:, 2:] / np.tan(np.radians(ANGLE) / 2) * SIZE / 2
    assert np.abs(film - pixel).max() <= 0.5 + 1e-6


def test_without_hit_aovs_nothing_changes():
    """Off by default: no position or uv; on, the colour, depth and normals are the same bits."""
    s = scene(durer.Sphere(CENTRE, RADIUS))
    a = durer.render(s, SIZE, SIZE, integrator="path", samples=4, seed=2)
    b = durer.render(s, SIZE, SIZE, integrator="path", samples=4, seed=2, hit_aovs=True)
    assert a.position is None and a.uv is None and b.position is not None
    for name in ("color", "depth", "normals"):
        assert hashlib.sha256(getattr(a, name).tobytes()).digest() == hashlib.sha256(getattr(b, name).tobytes()).digest()


MITSUBA_XML = """<scene version="3.0.0">
    <integrator type="aov">
        <string name="aovs" value="pp:position,uv:uv"/>
        <integrator type="path"><integer name="max_depth" value="2"/></integrator>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="stratified"><integer name="sample_count" value="64"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="rectangle"><transform name="to_world"><scale value="3"/></transform></shape>
    <shape type="sphere"><point name="center" x="0.3" y="-0.2" z="0.5"/><float name="radius" value="1"/></shape>
    <emitter type="constant"/>
</scene>
"""


@pytest.mark.slow
def test_position_and_uv_match_mitsubas_aov_integrator(tmp_path: Path):
    """Mitsuba's aov (scalar_rgb, 64 stratified spp, box filter) averages each pixel's samples; durer keeps the
    sample nearest the centre (of 64 Sobol points). Away from silhouettes and the sphere's u seam (pixels whose
    3 x 3 neighbourhood spans another shape or a UV jump above 0.2: 835 of 1024 pixels, 225 on the sphere) they
    agree within 0.2 of a pixel's footprint (0.2 x 2 tan(25 deg) 4 / 32 = 0.023 world units; measured 0.13,
    median 0.056) in position, and 0.01 in UV (measured 0.007)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    path = tmp_path / "aov.xml"
    path.write_text(MITSUBA_XML)
    ref = np.array(mi.render(mi.load_file(str(path)), seed=1))
    ref_p, ref_uv = ref[..., 3:6], ref[..., 6:8]
    s = durer.load(path)
    assert s.render_defaults["aov_outputs"] == ("position", "uv") and s.render_defaults["hit_aovs"]
    r = durer.render(s)
    on_sphere = np.abs(np.linalg.norm(r.position - (0.3, -0.2, 0.5), axis=-1) - 1) < 1e-4
    pad = np.pad(np.dstack([on_sphere, r.uv]), ((1, 1), (1, 1), (0, 0)), mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(pad, (3, 3), axis=(0, 1))  # (32, 32, 3, 3, 3)
    interior = (np.ptp(windows, axis=(-2, -1)) < 0.2).all(axis=-1)
    assert interior.sum() > 0.7 * interior.size and (interior & on_sphere).sum() > 50
    footprint = 2 * np.tan(np.radians(25)) * 4 / 32
    np.testing.assert_allclose(r.position[interior], ref_p[interior], atol=0.2 * footprint)
    np.testing.assert_allclose(r.uv[interior], ref_uv[interior], atol=0.01)


def test_cli_writes_position_and_uv(tmp_path: Path, capsys):
    """`durer render --aov position,uv`: layers position.X/Y/Z and uv.U/V of an EXR, or files beside a PNG
    (raw in .npy); a Mitsuba aov integrator asks for them by itself; an unknown name is a usage error (exit 2)."""
    exr = pytest.importorskip("OpenEXR")
    from durer.cli import main

    path = tmp_path / "aov.xml"
    path.write_text(MITSUBA_XML.replace('value="32"', 'value="8"').replace('value="64"', 'value="4"'))
    r = durer.render(durer.load(path))
    assert main(["render", str(path), "-q", "-o", str(tmp_path / "img.exr")]) == 0  # the scene's own aovs
    with exr.File(str(tmp_path / "img.exr"), separate_channels=True) as f:
        ch = {k: np.asarray(v.pixels) for k, v in f.channels().items()}
    assert set(ch) == {"R", "G", "B", "position.X", "position.Y", "position.Z", "uv.U", "uv.V"}
    np.testing.assert_array_equal(np.stack([ch[f"position.{c}"] for c in "XYZ"], axis=-1), r.position)
    np.testing.assert_array_equal(np.stack([ch[f"uv.{c}"] for c in "UV"], axis=-1), r.uv)
    assert main(["render", str(path), "-q", "-o", str(tmp_path / "img.npy"), "--aov", "uv,depth"]) == 0
    np.testing.assert_array_equal(np.load(tmp_path / "img.uv.npy"), r.uv)
    assert not (tmp_path / "img.position.npy").exists()
    assert main(["render", str(path), "-q", "-o", str(tmp_path / "img.png"), "--aov", "position,uv"]) == 0
    from PIL import Image

    uv = np.asarray(Image.open(tmp_path / "img.uv.png"))
    np.testing.assert_array_equal(uv[..., 2], 0)
    assert np.abs(uv[..., :2] / 255.0 - np.clip(r.uv, 0, 1)).max() <= 1 / 255 + 1e-6  # red u, green v, linear
    assert np.asarray(Image.open(tmp_path / "img.position.png")).shape == (8, 8, 3)
    capsys.readouterr()
    assert main(["render", str(path), "-q", "-o", str(tmp_path / "x.png"), "--aov", "position,bogus"]) == 2
    assert "--aov: unknown output bogus" in capsys.readouterr().err.strip().splitlines()[-1]


CENTRES = np.array([[-1.6, 1.2], [1.6, 1.2], [-1.6, -1.5], [1.6, -1.2], [0, 0]])  # where each shape is, in x, y


def test_uv_is_mitsubas_at_the_same_point_on_every_shape():
    """Each pixel's position and UV against Mitsuba's own surface interaction (scalar_rgb ray_intersect) for the
    ray from the camera through durer's position: the same point and UV (to 1e-4; u compared modulo 1 for the
    seams at phi = 0) on a sphere, disk, cylinder, rectangle and cube (mesh UVs), so every parametrisation is
    Mitsuba's whatever sample durer kept."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    from durer.io.mitsuba import load_dict

    T = mi.ScalarTransform4f
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": 2},
         "sensor": {"type": "perspective", "fov": 60, "to_world": T().look_at(origin=[0, 0, 6], target=[0, 0, 0],
                                                                                up=[0, 1, 0]),
                    "film": {"type": "hdrfilm", "width": 24, "height": 24},
                    "sampler": {"type": "independent", "sample_count": 2}},
         "sphere": {"type": "sphere", "center": [-1.6, 1.2, 0], "radius": 0.9},
         "disk": {"type": "disk", "to_world": T().translate([1.6, 1.2, 0]) @ T().rotate([1, 0, 0], 20) @ T().scale(0.9)},
         "cylinder": {"type": "cylinder", "to_world": T().translate([-1.6, -1.8, 0]) @ T().rotate([1, 0, 0], -60)
                      @ T().scale([0.7, 0.7, 1.4])},
         "cube": {"type": "cube", "to_world": T().translate([1.6, -1.2, 0]) @ T().rotate([0, 1, 0], 30)
                  @ T().rotate([1, 0, 0], 25) @ T().scale(0.6)},
         "rectangle": {"type": "rectangle", "to_world": T().translate([0, 0, -1]) @ T().scale(0.8)}}
    r = durer.render(load_dict(d), hit_aovs=True)
    ref = mi.load_dict(d)
    hit = np.isfinite(r.depth)
    assert hit.sum() > 120
    eye = np.array([0.0, 0.0, 6.0])
    close, shapes = 0, set()
    for p, uv in zip(r.position[hit].astype(np.float64), r.uv[hit].astype(np.float64), strict=True):
        ray = mi.Ray3f(mi.ScalarPoint3f(*eye), mi.ScalarVector3f(*((p - eye) / np.linalg.norm(p - eye))))
        si = ref.ray_intersect(ray)
        if not si.is_valid() or np.abs(np.array(si.p) - p).max() > 1e-4:
            continue  # a grazing ray at a silhouette, where float32 positions may miss
        close += 1
        diff = np.abs(np.array(si.uv) - uv)
        diff[0] = min(diff[0], 1 - diff[0])
        assert diff.max() < 1e-4, (p, uv, np.array(si.uv))
        shapes.add(int(np.argmin([np.linalg.norm(p[:2] - c) for c in CENTRES])))
    assert close > 0.95 * hit.sum() and shapes == set(range(5))  # every shape seen
