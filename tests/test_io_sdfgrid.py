"""io/sdfgrid.py: Mitsuba's sdfgrid read (.vol) and triangulated. The triangles lie on the trilinear interpolant's
zero set, face outwards with outward normals, and rays hit them where Mitsuba 3 hits its sdfgrid."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from conftest import MITSUBA_SCENES

from durer.io.sdfgrid import read_vol, sdf_mesh
from durer.query import RaycastingScene

TORUS = MITSUBA_SCENES / "mitsuba-data/docs/scenes/sdfgrid/torus_sdfgrid.vol"


def _vol(grid: np.ndarray) -> bytes:
    nz, ny, nx = grid.shape
    return b"VOL" + bytes([3]) + struct.pack("<5i", 1, nx, ny, nz, 1) + struct.pack("<6f", 0, 0, 0, 1, 1, 1) + \
        grid.astype("<f4").tobytes()


def _sphere_grid(n: int, r: float) -> np.ndarray:
    x = np.linspace(0, 1, n)
    z, y, x = np.meshgrid(x, x, x, indexing="ij")
    return np.sqrt((x - 0.5) ** 2 + (y - 0.45) ** 2 + (z - 0.55) ** 2) - r


def test_vol_files_round_trip_and_bad_ones_are_refused():
    g = _sphere_grid(9, 0.3).astype(np.float32)
    np.testing.assert_array_equal(read_vol(_vol(g)), g)
    with pytest.raises(ValueError, match="not a Mitsuba volume"):
        read_vol(b"VOL\x02" + _vol(g)[4:])
    with pytest.raises(ValueError, match="truncated"):
        read_vol(_vol(g)[:-4])


def test_sphere_level_set_is_a_closed_outward_mesh_on_the_sphere():
    r = 0.3
    v, f, n = sdf_mesh(_sphere_grid(21, r))
    c = np.array([0.5, 0.45, 0.55])
    # the interpolant of a distance field is within a cell's rounding of it: half a cell width / 20 at most here
    np.testing.assert_allclose(np.linalg.norm(v - c, axis=1), r, atol=0.05 / 20)
    radial = (v - c) / np.linalg.norm(v - c, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", n, radial).min() > 0.99  # smooth normals: the gradient, outward
    tri = v[f]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    real = np.linalg.norm(face_n, axis=1) > 1e-12  # (not the slivers around samples that are exactly 0)
    assert (np.einsum("ij,ij->i", face_n, tri.mean(axis=1) - c)[real] > 0).all()  # faces point outside
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    assert (np.unique(edges, axis=0, return_counts=True)[1] == 2).all()  # closed: every edge in two triangles
    # the divergence theorem gives the enclosed volume: the sphere's, less the trilinear interpolant's shrinking
    # of a convex distance field between samples 0.05 apart (about 1.5% here)
    volume = np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6
    assert volume == pytest.approx(4 / 3 * np.pi * r ** 3, rel=0.02) and volume < 4 / 3 * np.pi * r ** 3


@pytest.mark.skipif(not TORUS.is_file(), reason=f"Mitsuba's sdfgrid example not found at {TORUS}")
def test_rays_hit_the_torus_where_mitsuba_hits_its_sdfgrid():
    mi = pytest.importorskip("mitsuba", reason="Mitsuba 3 gives the reference hits")
    mi.set_variant("scalar_rgb")
    v, f, _ = sdf_mesh(read_vol(TORUS.read_bytes()))
    scene = RaycastingScene()
    scene.add_triangles(v, f)
    theirs = mi.load_dict({"type": "scene", "s": {"type": "sdfgrid", "filename": str(TORUS)}})
    rng = np.random.default_rng(0)
    o = rng.uniform(-0.5, 1.5, (600, 3))
    d = 0.5 - o + rng.normal(size=(600, 3)) * 0.2
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t = np.asarray(scene.cast_rays(np.hstack([o, d]).astype(np.float32))["t_hit"])
    agree, errors = 0, []
    for i in range(len(o)):
        si = theirs.ray_intersect(mi.Ray3f(mi.Point3f(o[i]), mi.Vector3f(d[i])))
        agree += si.is_valid() == np.isfinite(t[i])
        if si.is_valid() and np.isfinite(t[i]):
            errors.append(abs(si.t - t[i]))
    assert agree >= 0.99 * len(o) and len(errors) > 200
    assert np.median(errors) < 1e-3 / 39 * 10 and np.percentile(errors, 95) < 0.1 / 39  # grid cells are 1/39
