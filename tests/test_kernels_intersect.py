"""Per-primitive tests: the watertight ray-triangle test (Woop, Benthin & Wald 2013), the unit disk and the open
unit cylinder (closed forms)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from durer.kernels.common import CYLINDER_CODE, DISK_CODE
from durer.kernels.intersect import intersect_cylinder, intersect_disk, intersect_triangle, sphere_hit_in_object_space
from durer.query import RaycastingScene

TRI = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def test_hit_gives_t_and_barycentrics_of_vertex1_and_vertex2():
    t, u, v = intersect_triangle(0.2, 0.3, 2.0, 0.0, 0.0, -1.0, TRI, 0.0, np.inf)
    assert t == pytest.approx(2.0)
    assert (u, v) == pytest.approx((0.2, 0.3))


def test_both_sides_count_and_t_interval_is_open():
    t, _, _ = intersect_triangle(0.2, 0.3, -2.0, 0.0, 0.0, 1.0, TRI, 0.0, np.inf)
    assert t == pytest.approx(2.0)
    assert intersect_triangle(0.2, 0.3, 2.0, 0.0, 0.0, -1.0, TRI, 0.0, 2.0)[0] == np.inf
    assert intersect_triangle(0.2, 0.3, 2.0, 0.0, 0.0, -1.0, TRI, 2.0, 5.0)[0] == np.inf
    assert intersect_triangle(0.2, 0.3, 2.0, 0.0, 0.0, -1.0, TRI, -np.inf, 2.5)[0] == pytest.approx(2.0)


def test_misses_outside_edge_on_and_degenerate():
    assert intersect_triangle(0.8, 0.8, 2.0, 0.0, 0.0, -1.0, TRI, 0.0, np.inf)[0] == np.inf
    assert intersect_triangle(-0.1, 0.3, 2.0, 0.0, 0.0, -1.0, TRI, 0.0, np.inf)[0] == np.inf
    assert intersect_triangle(-1.0, 0.3, 0.0, 1.0, 0.0, 0.0, TRI, 0.0, np.inf)[0] == np.inf  # edge-on
    flat = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.0]])
    assert intersect_triangle(0.5, 0.5, 1.0, 0.0, 0.0, -1.0, flat, 0.0, np.inf)[0] == np.inf


@pytest.mark.parametrize("flip", [False, True])
@pytest.mark.parametrize("below", [False, True])
def test_ray_through_shared_edge_hits_exactly_one_triangle(flip, below):
    """A quad split along its diagonal, either winding, rays from either side: a ray on the diagonal (exactly, in
    the test's sheared frame, or after rounding) hits exactly one half, never both and never neither. (The
    diagonal's end points are on the quad's border: a ray there may miss both, as it may pass beside an open
    mesh.)"""
    rng = np.random.default_rng(1)
    a, b, c, d = np.array([0.0, 0, 0]), np.array([1.0, 0, 0]), np.array([1.0, 1, 0]), np.array([0.0, 1, 0])
    t1, t2 = (np.array([a, c, b]), np.array([a, d, c])) if flip else (np.array([a, b, c]), np.array([a, c, d]))
    origin = np.array([0.3, -0.7, -1.3 if below else 1.3])
    points = [a + s * (c - a) for s in rng.random(2000)] + [(a + c) / 2]
    for p in points:
        dx, dy, dz = p - origin
        h1 = intersect_triangle(*origin, dx, dy, dz, t1, 0.0, np.inf)[0] < np.inf
        h2 = intersect_triangle(*origin, dx, dy, dz, t2, 0.0, np.inf)[0] < np.inf
        assert h1 != h2, p
    # axis-aligned rays exactly on the diagonal (every edge function computed exactly, so the tie-break decides)
    for x in np.linspace(0.0, 1.0, 17)[1:-1]:
        z = 1.0 if below else -1.0
        hits = [intersect_triangle(x, x, -z, 0.0, 0.0, z, tri, 0.0, np.inf)[0] < np.inf for tri in (t1, t2)]
        assert sum(hits) == 1, x


def test_open3d_box_counts_each_crossing_once():
    """Open3D's own box test: rays through the middle of faces (the diagonal shared by a face's two triangles)
    count [2, 1, 0] crossings and list three hits."""
    box = trimesh.creation.box(extents=(1, 1, 1))
    box.apply_translation([0.5, 0.5, 0.5])
    s = RaycastingScene()
    s.add_triangles(box.vertices, box.faces)
    rays = np.array([[0.5, 0.5, -1, 0, 0, 1], [0.5, 0.5, 0.5, 0, 0, 1], [10, 10, 10, 1, 0, 0]], np.float32)
    assert s.count_intersections(rays).tolist() == [2, 1, 0]
    listed = s.list_intersections(rays)
    assert listed["ray_splits"].tolist() == [0, 2, 3, 3]
    np.testing.assert_allclose(listed["t_hit"], [1.0, 2.0, 0.5])


@pytest.mark.parametrize("subdivisions", [1, 2, 3])
def test_rays_through_vertices_and_edges_of_a_closed_mesh_count_true_crossings(subdivisions):
    """Rays from outside through an icosphere's centre and a vertex (and its antipode) or an edge's midpoint cross
    it twice, rays from the centre once, whatever the mesh's fans look like (5 or 6 triangles a vertex); the
    packet kernels and the one-ray walk name the same triangle on these ties."""
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions)
    s = RaycastingScene()
    s.add_triangles(mesh.vertices, mesh.faces)
    mids = mesh.vertices[mesh.edges_unique].mean(axis=1)
    for targets in (mesh.vertices, mids):
        assert (s.count_intersections(-3 * targets, 4 * targets) == 2).all()
        assert (s.count_intersections(np.zeros_like(targets), targets) == 1).all()
        listed = s.list_intersections(np.zeros_like(targets), targets)
        assert len(listed["t_hit"]) == len(targets)
    edges = mesh.edges_unique
    u = np.linspace(0.0, 1.0, 16)[None, :, None]
    along = ((1 - u) * mesh.vertices[edges[:, 0]][:, None] + u * mesh.vertices[edges[:, 1]][:, None]).reshape(-1, 3)
    packets = s.cast_rays(np.zeros_like(along), along)
    perm = np.random.default_rng(0).permutation(len(along))
    single = s.cast_rays(np.zeros_like(along)[perm], along[perm])
    np.testing.assert_array_equal(packets["primitive_ids"][perm], single["primitive_ids"])
    np.testing.assert_array_equal(packets["t_hit"][perm], single["t_hit"])


def test_watertight_million_rays_from_inside_closed_icosphere():
    """Issue 3: a million rays from inside a closed mesh all hit it, including rays aimed exactly at vertices
    and at points on edges, where a non-watertight test lets rays slip through."""
    mesh = trimesh.creation.icosphere(subdivisions=3)
    scene = RaycastingScene()
    scene.add_triangles(mesh.vertices, mesh.faces)
    rng = np.random.default_rng(7)
    n = 1_000_000
    origins = rng.uniform(-0.5, 0.5, (n, 3))
    targets = np.empty((n, 3))
    q = n // 4
    targets[:q] = mesh.vertices[rng.integers(0, len(mesh.vertices), q)]
    edges = mesh.edges_unique[rng.integers(0, len(mesh.edges_unique), n - 2 * q)]
    s = rng.random((len(edges), 1))
    targets[q:n - q] = (1 - s) * mesh.vertices[edges[:, 0]] + s * mesh.vertices[edges[:, 1]]
    targets[n - q:] = rng.normal(size=(q, 3))
    origins[:q // 2] = 0.0  # from the centre straight at vertices too
    hit = scene.test_occlusions(origins, targets - origins)
    assert hit.all(), f"{(~hit).sum()} rays escaped"
    t = scene.cast_rays(origins[:100_000], targets[:100_000] - origins[:100_000])["t_hit"]
    assert np.isfinite(t).all()


@settings(max_examples=200, deadline=None)
@given(vertices=st.lists(st.integers(0, 16), min_size=9, max_size=9), at=st.tuples(*[st.integers(-8, 8)] * 2),
       towards=st.integers(0, 2))
def test_rays_in_the_triangles_plane_miss(vertices, at, towards):
    """A ray in a triangle's plane misses it, through the one-ray test and a scene's walks: vertices on a quarter
    grid, the origin a quarter-step combination of the edges (exactly in the plane), aimed at a vertex. Their edge
    functions are rounding leftovers that share a sign for ~9% of such rays, which the test took for hits at
    arbitrary t before intersect.edge_on bounded the determinant's rounding (as ray 328 of
    test_closest_walk_equals_brute_force_on_grazing_rays's seed 64684: t = 0.5, off the triangle)."""
    tri = np.array(vertices, float).reshape(3, 3) / 4
    e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
    o = tri[0] + at[0] / 4 * e1 + at[1] / 4 * e2
    d = tri[towards] - o
    if not np.cross(e1, e2).any() or not d.any():
        return
    assert intersect_triangle(*o, *d, tri, 0.0, np.inf)[0] == np.inf
    scene = RaycastingScene()
    scene.add_triangles(tri, np.array([[0, 1, 2]]))
    rays = np.tile(np.concatenate([o, d]), (16, 1))  # 16 equal rays: one coherent packet too
    assert np.isinf(scene.cast_rays(rays)["t_hit"]).all()
    assert (scene.count_intersections(rays) == 0).all()
    assert not scene.test_occlusions(rays).any()


@pytest.mark.parametrize("tilt", [1e-3, 1e-6, 1e-9, 1e-12])
def test_grazing_rays_just_off_the_plane_hit(tilt):
    """Rays leaving the plane at a sine down to 1e-12 still hit where they cross it: only a ray in the plane up to
    rounding (edge_on's bound, ~1e-15 of the triangle's scale) is missed."""
    o = np.array([-1.0, 0.3, tilt])
    d = np.array([1.2, 0.0, -tilt])  # crosses z = 0 at t = 1, at (0.2, 0.3), inside
    t, u, v = intersect_triangle(*o, *d, TRI, 0.0, np.inf)
    assert t == pytest.approx(1.0, rel=1e-9)
    assert (u, v) == pytest.approx((0.2, 0.3), rel=1e-6)


def test_watertight_packets_aimed_along_edges_and_at_vertices():
    """The same for coherent rays, which take the packet traversal: 16 rays from the centre to 16 points along
    one edge (its two vertices included) make one packet; every ray of every packet hits."""
    mesh = trimesh.creation.icosphere(subdivisions=4)
    scene = RaycastingScene()
    scene.add_triangles(mesh.vertices, mesh.faces)
    edges = mesh.edges_unique
    s = np.linspace(0.0, 1.0, 16)[None, :, None]
    targets = (1 - s) * mesh.vertices[edges[:, 0]][:, None] + s * mesh.vertices[edges[:, 1]][:, None]
    directions = targets.reshape(-1, 3)
    origins = np.zeros_like(directions)
    assert scene.test_occlusions(origins, directions).all()
    t = scene.cast_rays(origins, directions)["t_hit"]
    assert np.isfinite(t).all()
    np.testing.assert_allclose(t, 1.0, atol=0.02)  # the targets lie on the mesh, at t = 1


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_axis_rays_from_inside_an_integer_hull_cross_once(seed):
    """Random convex hulls of integer points (consistently wound), rays along the 6 axis directions from integer
    points strictly inside: the rays run along the hull's integer grid, so many pass exactly through its edges
    and vertices (edge functions of exactly 0), and each must cross the closed surface exactly once; the same
    lines from outside, through the inside point, cross exactly twice."""
    rng = np.random.default_rng(seed)
    hull = trimesh.convex.convex_hull(rng.integers(-6, 7, (12, 3)).astype(float))
    if hull.volume < 1.0:
        return
    s = RaycastingScene()
    s.add_triangles(hull.vertices, hull.faces)
    grid = np.stack(np.meshgrid(*[np.arange(-6.0, 7.0)] * 3), -1).reshape(-1, 3)
    inside = grid[np.abs(s.compute_winding_number(grid)) > 0.999]
    inside = inside[s.compute_distance(inside) > 1e-9]
    axes = np.concatenate([np.eye(3), -np.eye(3)])
    o = np.repeat(inside, 6, axis=0)
    d = np.tile(axes, (len(inside), 1))
    assert (s.count_intersections(o, d) == 1).all()
    assert np.isfinite(s.cast_rays(o, d)["t_hit"]).all()
    assert (s.count_intersections(o - 20 * d, d) == 2).all()


_coord = st.floats(-3.0, 3.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(x=st.floats(-1.5, 1.5), y=st.floats(-1.5, 1.5), h=st.floats(0.1, 5.0), dx=_coord, dy=_coord,
       dz=st.floats(0.05, 2.0))
def test_disk_hit_is_where_the_ray_crosses_z0_inside_the_unit_circle(x, y, h, dx, dy, dz):
    """A ray from above aimed at (x, y, 0): t = h / dz exactly when x^2 + y^2 <= 1, from either side."""
    o = (x - dx * h / dz, y - dy * h / dz, h)
    t = intersect_disk(*o, dx, dy, -dz, 0.0, np.inf)
    inside = (o[0] + h / dz * dx) ** 2 + (o[1] + h / dz * dy) ** 2 <= 1.0
    if abs(x * x + y * y - 1.0) > 1e-9:
        assert (t < np.inf) == inside
    if t < np.inf:
        assert t == pytest.approx(h / dz, rel=1e-12)
        assert intersect_disk(o[0], o[1], -h, dx, dy, dz, 0.0, np.inf) == pytest.approx(t, rel=1e-12)  # below
    assert intersect_disk(*o, dx, dy, -dz, h / dz * 1.0001, np.inf) == np.inf  # past t_min
    assert intersect_disk(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, np.inf) == np.inf  # parallel


@settings(max_examples=300, deadline=None)
@given(phi=st.floats(0.0, 2 * np.pi), z=st.floats(-0.5, 1.5), dist=st.floats(1.5, 6.0),
       tilt=st.floats(-0.5, 0.5))
def test_cylinder_hit_at_the_closed_form_root_between_its_ends(phi, z, dist, tilt):
    """A ray from outside at distance dist from the axis, aimed at the axis point (0, 0, z): it meets the wall
    at t = (dist - 1) / dist of the way (radial part), where its height must lie in [0, 1]; else it meets the far
    wall (inside the tube) or nothing."""
    c, s = np.cos(phi), np.sin(phi)
    o = (dist * c, dist * s, z - tilt * dist)
    d = (-dist * c, -dist * s, tilt * dist)  # reaches the axis at t = 1
    t = intersect_cylinder(*o, *d, 0.0, np.inf)
    near, far = (dist - 1.0) / dist, (dist + 1.0) / dist
    h_near, h_far = o[2] + near * d[2], o[2] + far * d[2]
    if 1e-9 < h_near < 1 - 1e-9:
        assert t == pytest.approx(near, rel=1e-12)
        p = np.array(o) + t * np.array(d)
        assert np.hypot(p[0], p[1]) == pytest.approx(1.0, rel=1e-12)
    elif 1e-9 < h_far < 1 - 1e-9 and not -1e-9 < h_near < 1 + 1e-9:
        assert t == pytest.approx(far, rel=1e-12)  # through an open end onto the inner wall
    elif not (-1e-9 < h_far < 1 + 1e-9 or -1e-9 < h_near < 1 + 1e-9):
        assert t == np.inf
    # along the axis the ray never meets the wall; from inside it meets it once
    assert intersect_cylinder(0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, np.inf) == np.inf
    assert intersect_cylinder(0.0, 0.0, 0.5, c, s, 0.0, 0.0, np.inf) == pytest.approx(1.0)


def test_shape_codes_pick_the_disk_and_the_cylinder_through_the_object_matrix():
    """sphere_hit_in_object_space reads a radius code as the unit disk or cylinder seen through w2o; t stays in
    world units (a disk scaled by 2 and moved to z = 3 is met at t = 7 - 3 from z = 7)."""
    w2o = np.array([[0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1.0, -3.0]])
    c = np.zeros(3)
    assert sphere_hit_in_object_space((1.9, 0, 7.0), (0, 0, -1.0), c, DISK_CODE, w2o, 0.0, np.inf) == 4.0
    assert sphere_hit_in_object_space((2.1, 0, 7.0), (0, 0, -1.0), c, DISK_CODE, w2o, 0.0, np.inf) == np.inf
    assert sphere_hit_in_object_space((5.0, 0, 3.5), (-1.0, 0, 0), c, CYLINDER_CODE, w2o, 0.0, np.inf) == 3.0
    assert sphere_hit_in_object_space((5.0, 0, 4.5), (-1.0, 0, 0), c, CYLINDER_CODE, w2o, 0.0, np.inf) == np.inf
    assert sphere_hit_in_object_space((5.0, 0, 3.0), (-1.0, 0, 0), c, 1.0, w2o, 0.0, np.inf) == 3.0  # a sphere
