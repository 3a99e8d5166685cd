"""The course's uniform grid: same hits as brute force, the 3D-DDA walk in closed form, the course's insertion
rules, -visualize_grid and the -stats counters."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from durer import Group, Scene, Sphere, Transform, Triangle
from durer.accel.brute import BruteForce
from durer.accel.compile import CompiledScene, compile_scene
from durer.accel.grid import GridAccelerator
from durer.accel.stats import CountingAccelerator, RayStats
from durer.options import RenderOptions
from durer.rendering.grid_view import COUNT_COLORS
from durer.rendering.renderer import render
from durer.scene import transforms as tf
from durer.scene.cameras import OrthographicCamera
from durer.scene.lights import DirectionalLight

CAM = OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=1)


def compiled(triangles=(), spheres=(), ellipsoids=(), planes=()) -> CompiledScene:
    """A CompiledScene from raw arrays: spheres (centre, radius); ellipsoids (object-to-world 4x4, radius) of
    unit spheres at the origin; planes (unit normal, offset)."""
    tris = np.array(triangles, dtype=np.float64).reshape(-1, 3, 3)
    centers = [c for c, _ in spheres] + [(0.0, 0.0, 0.0)] * len(ellipsoids)
    radii = [r for _, r in spheres] + [r for _, r in ellipsoids]
    w2o = [np.eye(4)[:3] for _ in spheres] + [np.linalg.inv(m)[:3] for m, _ in ellipsoids]
    s = len(radii)
    return CompiledScene(
        triangles=np.ascontiguousarray(tris), triangle_material=np.zeros(len(tris), np.int32),
        sphere_center=np.array(centers, np.float64).reshape(s, 3), sphere_radius=np.array(radii, np.float64),
        sphere_world_to_object=np.ascontiguousarray(np.array(w2o, np.float64).reshape(s, 3, 4)),
        sphere_normal_matrix=np.tile(np.eye(3), (s, 1, 1)), sphere_material=np.zeros(s, np.int32),
        plane_normal=np.array([n for n, _ in planes], np.float64).reshape(-1, 3),
        plane_offset=np.array([d for _, d in planes], np.float64), plane_material=np.zeros(len(planes), np.int32),
    )


def random_scene(rng: np.random.Generator) -> tuple[CompiledScene, np.ndarray]:
    """Loose triangles, a height-field mesh (shared edges and vertices), spheres, rotated and scaled ellipsoids
    and planes; returns the scene and the mesh's vertices (to aim rays exactly at)."""
    loose = rng.uniform(-2, 2, (rng.integers(0, 12), 1, 3)) + rng.normal(0, 0.6, (1, 3, 3))
    n = 4
    xs = np.linspace(-1.5, 1.5, n + 1)
    grid = np.array([[(x, y, rng.uniform(-0.5, 0.5)) for x in xs] for y in xs])
    mesh = []
    for i in range(n):
        for j in range(n):
            a, b, c, d = grid[i, j], grid[i, j + 1], grid[i + 1, j], grid[i + 1, j + 1]
            mesh += [(a, b, d), (a, d, c)]
    tris = np.concatenate([loose.reshape(-1, 3, 3), np.array(mesh)]) if rng.random() < 0.7 else loose
    spheres = [(tuple(rng.uniform(-2, 2, 3)), float(rng.uniform(0.1, 1.0))) for _ in range(rng.integers(0, 4))]
    ellipsoids = []
    for _ in range(rng.integers(0, 3)):
        m = (tf.translate(rng.uniform(-2, 2, 3)) @ tf.rotate(rng.normal(size=3), rng.uniform(0, 360))
             @ tf.scale(rng.uniform(0.3, 1.5, 3)))
        ellipsoids.append((m, float(rng.uniform(0.3, 1.0))))
    planes = []
    for _ in range(rng.integers(0, 3)):
        nrm = rng.normal(size=3)
        planes.append((nrm / np.linalg.norm(nrm), float(rng.uniform(-3, 3))))
    return compiled(tris, spheres, ellipsoids, planes), grid.reshape(-1, 3)


def random_rays(rng: np.random.Generator, targets: np.ndarray, n: int = 160) -> tuple[np.ndarray, np.ndarray]:
    """Rays from outside and inside the scene: random directions, some axis-aligned (zero components), and
    some aimed exactly at mesh vertices so they meet several triangles at the same t."""
    origins = rng.uniform(-4, 4, (n, 3))
    directions = rng.normal(size=(n, 3))
    k = n // 4
    directions[:k] = np.eye(3)[rng.integers(0, 3, k)] * rng.choice([-1.0, 1.0], (k, 1))
    aim = targets[rng.integers(0, len(targets), k)]
    directions[k:2 * k] = aim - origins[k:2 * k]
    return origins, directions


def assert_same_hits(a, b) -> None:
    """Bit-identical hits; barycentrics only where they mean something (triangle hits)."""
    for field in ("t", "kind", "prim"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    tri = a.kind == 1
    np.testing.assert_array_equal(a.u[tri], b.u[tri], err_msg="u")
    np.testing.assert_array_equal(a.v[tri], b.v[tri], err_msg="v")


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dims=st.tuples(*[st.integers(1, 9)] * 3), exact=st.booleans(),
       t_min=st.sampled_from([0.0, -np.inf, 1.5]), t_max=st.sampled_from([np.inf, 3.0]))
@example(seed=1291, dims=(1, 1, 1), exact=False, t_min=0.0, t_max=np.inf)  # rays meeting the box at a corner
def test_grid_equals_brute_force(seed, dims, exact, t_min, t_max):
    rng = np.random.default_rng(seed)
    cs, vertices = random_scene(rng)
    origins, directions = random_rays(rng, vertices)
    brute = BruteForce(cs)
    grid = GridAccelerator(cs, dims, exact_triangles=exact)
    assert_same_hits(grid.closest_hit(origins, directions, t_min, t_max),
                     brute.closest_hit(origins, directions, t_min, t_max))
    np.testing.assert_array_equal(grid.any_hit(origins, directions, t_min, t_max),
                                  brute.any_hit(origins, directions, t_min, t_max))


def test_grid_equals_brute_force_per_ray_limits():
    """t_min and t_max given per ray (shadow rays stop at their light)."""
    rng = np.random.default_rng(7)
    cs, vertices = random_scene(rng)
    origins, directions = random_rays(rng, vertices, 400)
    t_min = rng.choice([0.0, -np.inf, 0.5], len(origins))
    t_max = rng.choice([np.inf, 1.0, 4.0], len(origins))
    grid, brute = GridAccelerator(cs, (6, 5, 4)), BruteForce(cs)
    assert_same_hits(grid.closest_hit(origins, directions, t_min, t_max),
                     brute.closest_hit(origins, directions, t_min, t_max))
    np.testing.assert_array_equal(grid.any_hit(origins, directions, t_min, t_max),
                                  brute.any_hit(origins, directions, t_min, t_max))


def test_only_planes_and_empty_scene():
    rays = (np.array([[0.0, 0, 5], [0, 0, 5]]), np.array([[0.0, 0, -1], [0, 0, 1]]))
    cs = compiled(planes=[((0.0, 0.0, 1.0), 0.0)])
    h = GridAccelerator(cs, (3, 3, 3)).closest_hit(*rays)
    assert list(h.kind) == [3, 0] and h.t[0] == 5.0
    empty = GridAccelerator(compiled(), (2, 2, 2))
    assert not empty.closest_hit(*rays).hit.any() and not empty.any_hit(*rays).any()


# --- the 3D-DDA walk ---------------------------------------------------------------------------------------
# a sphere of radius 2 at (2, 2, 2): the grid box is [0, 4]^3, 4 x 4 x 4 cells of size 1
BOX4 = GridAccelerator(compiled(spheres=[((2.0, 2.0, 2.0), 2.0)]), (4, 4, 4))


def test_walk_along_x():
    cells, t, axis = BOX4.walk((-1, 0.5, 0.5), (1, 0, 0))
    assert cells.tolist() == [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]
    assert t == pytest.approx([1, 2, 3, 4]) and axis.tolist() == [0, 0, 0, 0]


def test_walk_backwards_with_a_slow_direction():
    cells, t, axis = BOX4.walk((5, 3.5, 1.5), (-0.5, 0, 0))
    assert cells.tolist() == [[3, 3, 1], [2, 3, 1], [1, 3, 1], [0, 3, 1]]
    assert t == pytest.approx([2, 4, 6, 8])


def test_walk_from_inside_starts_in_the_origin_cell():
    cells, t, axis = BOX4.walk((1.5, 1.5, 1.5), (0, 0, 1))
    assert cells.tolist() == [[1, 1, 1], [1, 1, 2], [1, 1, 3]]
    assert t.tolist() == [0, 0.5, 1.5] and axis.tolist() == [-1, 2, 2]


def test_walk_with_orthographic_t_min_starts_at_the_box():
    """t_min = -inf (rays from infinity): the walk is clipped to the grid box, behind the origin too."""
    cells, t, axis = BOX4.walk((1.5, 1.5, 1.5), (0, 0, 1), t_min=-np.inf)
    assert cells.tolist() == [[1, 1, 0], [1, 1, 1], [1, 1, 2], [1, 1, 3]]
    assert t == pytest.approx([-1.5, -0.5, 0.5, 1.5]) and axis[0] == 2


def test_walk_stops_at_t_max_and_misses_the_box():
    cells, _, _ = BOX4.walk((-1, 0.5, 0.5), (1, 0, 0), t_max=2.5)
    assert cells.tolist() == [[0, 0, 0], [1, 0, 0]]
    assert len(BOX4.walk((-1, 5, 0.5), (1, 0, 0))[0]) == 0
    assert len(BOX4.walk((-1, 0.5, 0.5), (-1, 0, 0))[0]) == 0


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), dims=st.tuples(*[st.integers(1, 6)] * 3))
def test_walk_visits_the_cells_the_ray_crosses_in_order(seed, dims):
    """Against every cell's own slab test, for rays in general position (some parallel to an axis plane):
    the cells whose box the ray crosses over a positive length, in the order and at the t it enters them."""
    rng = np.random.default_rng(seed)
    g = GridAccelerator(compiled(spheres=[((2.0, 1.0, 3.0), 1.5)]), dims)
    for _ in range(20):
        o = rng.uniform(-1, 6, 3)
        d = rng.normal(size=3)
        if rng.random() < 0.3:
            d[rng.integers(0, 3)] = 0.0
        cells, t, _ = g.walk(o, d)
        expect = []
        for idx in np.ndindex(*dims):
            lo = g.lo + np.array(idx) * g.size
            hi = lo + g.size
            with np.errstate(divide="ignore", invalid="ignore"):
                ta, tb = (lo - o) / d, (hi - o) / d
            inside = (lo <= o) & (o <= hi)
            near = np.where(d != 0, np.minimum(ta, tb), np.where(inside, -np.inf, np.inf))
            far = np.where(d != 0, np.maximum(ta, tb), np.where(inside, np.inf, -np.inf))
            t0, t1 = max(near.max(), 0.0), far.min()
            if t1 > t0:
                expect.append((t0, idx))
        expect.sort()
        assert [tuple(c) for c in cells] == [idx for _, idx in expect]
        np.testing.assert_allclose(t, [t0 for t0, _ in expect], rtol=1e-6, atol=1e-6)  # clip box: +1e-9


# --- insertion as the course does it -----------------------------------------------------------------------
def test_sphere_rasterised_by_cell_centres():
    """5 x 5 x 5 over the unit sphere: a cell counts when its centre is within r + half a diagonal, which
    leaves out exactly the 8 corner cells (centre distance 1.386 > 1 + 0.346)."""
    g = GridAccelerator(compiled(spheres=[((0.0, 0.0, 0.0), 1.0)]), (5, 5, 5))
    counts = g.cell_counts
    assert counts.sum() == 117
    assert counts[0, 0, 0] == counts[4, 4, 4] == counts[0, 4, 0] == 0 and counts[2, 2, 2] == 1


def test_transformed_sphere_fills_its_box():
    """Under a Transform (even the identity) a sphere goes into every cell of its box, like the course's
    Object3D::insertIntoGrid fallback; the same sphere without one leaves the corners out."""
    plain = Scene(camera=CAM, group=Group([Sphere((0, 0, 0), 1.0)]))
    wrapped = Scene(camera=CAM, group=Group([Transform(np.eye(4), Sphere((0, 0, 0), 1.0))]))
    assert compile_scene(wrapped).sphere_transformed.tolist() == [True]
    assert GridAccelerator(compile_scene(plain), (5, 5, 5)).cell_counts.sum() == 117
    assert GridAccelerator(compile_scene(wrapped), (5, 5, 5)).cell_counts.sum() == 125
    ellipsoid = compiled(ellipsoids=[(tf.scale((2.0, 1.0, 1.0)), 1.0)])
    g = GridAccelerator(ellipsoid, (4, 2, 2), sphere_as_box=np.array([False]))  # moved spheres always boxed
    assert np.allclose(g.lo, (-2, -1, -1)) and np.allclose(g.hi, (2, 1, 1)) and g.cell_counts.min() == 1


def test_sphere_transformed_follows_compile_order():
    scene = Scene(camera=CAM, group=Group([
        Sphere((0, 0, 0), 1.0), Transform(tf.translate((1, 0, 0)), Group([Sphere((0, 0, 0), 1.0)])),
        Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0)), Sphere((3, 0, 0), 1.0)]))
    cs = compile_scene(scene)  # one walk of the tree gives the spheres and which of them are transformed
    assert cs.sphere_transformed.tolist() == [False, True, False] and len(cs.sphere_radius) == 3


def test_triangle_on_a_cell_boundary_goes_into_both_cells():
    """Boxes are closed: a triangle in the plane z = 0, between two layers of cells, is in both."""
    cs = compiled(triangles=[[(-0.5, -0.5, 0.0), (0.5, -0.5, 0.0), (0.0, 0.5, 0.0)]],
                  spheres=[((0.0, 0.0, 0.0), 1.0)])
    g = GridAccelerator(cs, (2, 2, 2))
    holding = [(i, j, k) for i in range(2) for j in range(2) for k in range(2) if (1, 0) in g.cell_items(i, j, k)]
    assert len(holding) == 8


def test_exact_triangles_leave_out_cells_the_triangle_misses():
    tri = [[(0.0, 0.0, 0.0), (4.0, 0.0, 0.0), (0.0, 4.0, 4.0)]]
    box = GridAccelerator(compiled(triangles=tri), (4, 4, 4))
    tight = GridAccelerator(compiled(triangles=tri), (4, 4, 4), exact_triangles=True)
    assert box.cell_counts.sum() == 64
    assert 0 < tight.cell_counts.sum() < 64
    assert tight.cell_counts[0, 0, 0] == 1 and tight.cell_counts[3, 0, 3] == 0  # far corner is off the plane


def test_flat_scene_gets_a_grid():
    g = GridAccelerator(compiled(triangles=[[(0.0, 0, 0), (1, 0, 0), (0, 1, 0)]]), (2, 2, 2))
    assert np.all(g.size > 0)
    h = g.closest_hit(np.array([[0.2, 0.2, 1.0]]), np.array([[0.0, 0, -1]]))
    assert h.kind[0] == 1 and h.t[0] == 1.0


# --- -visualize_grid ---------------------------------------------------------------------------------------
# two small spheres in opposite corners of [0, 4]^3: each holds its own cell and the three face neighbours
CORNERS = GridAccelerator(compiled(spheres=[((0.5, 0.5, 0.5), 0.5), ((3.5, 3.5, 3.5), 0.5)]), (4, 4, 4))


def test_corner_spheres_occupy_four_cells_each():
    assert CORNERS.cell_counts.sum() == 8


def test_first_occupied_cell():
    origins = np.array([[-1, 1.5, 0.5], [2.5, 2.5, -1], [2.5, 3.5, -1], [1.5, 0.5, 0.5]], float)
    directions = np.array([[1, 0, 0], [0, 0, 1], [0, 0, 1], [1, 0, 0]], float)
    t, axis, count = CORNERS.first_occupied(origins, directions, np.array([0.0, 0, 0, -np.inf]))
    assert t.tolist() == [1, np.inf, 4, -1.5]
    assert axis.tolist()[:3] == [0, -1, 2] and axis[3] == 0 and count.tolist() == [1, 0, 1, 1]


def test_visualize_grid_shades_the_entered_face():
    """A unit sphere in a 1 x 1 x 1 grid seen along -z: the box's front face, white (one primitive),
    ambient 0.1 + a light along the view of 0.5, at the box's depth; outside it the background."""
    scene = Scene(camera=OrthographicCamera(center=(0, 0, 10), direction=(0, 0, -1), up=(0, 1, 0), size=4),
                  group=Group([Sphere((0, 0, 0), 1.0)]), lights=[DirectionalLight((0, 0, -1), (0.5, 0.5, 0.5))],
                  background_color=(0.2, 0.0, 0.6), ambient_light=(0.1, 0.1, 0.1))
    r = render(scene, 8, 8, options=RenderOptions(grid=(1, 1, 1), visualize_grid=True))
    inside, outside = (4, 4), (0, 0)
    assert np.allclose(r.color[inside], 0.6) and np.allclose(r.color[outside], (0.2, 0.0, 0.6))
    assert r.depth[inside] == pytest.approx(9.0) and np.allclose(r.normals[inside], (0, 0, 1))


def test_count_colours_run_from_white_to_red():
    assert COUNT_COLORS[0].tolist() == [1, 1, 1] and COUNT_COLORS[1].tolist() == [1, 0, 1]
    assert COUNT_COLORS[-1].tolist() == [1, 0, 0] and len(COUNT_COLORS) == 17


# --- -stats ------------------------------------------------------------------------------------------------
def test_grid_counts_rays_tests_and_cells():
    rng = np.random.default_rng(3)
    cs, vertices = random_scene(rng)
    origins, directions = random_rays(rng, vertices)
    stats = RayStats()
    counted = GridAccelerator(cs, (5, 5, 5), stats=stats)
    quiet = GridAccelerator(cs, (5, 5, 5))
    assert_same_hits(counted.closest_hit(origins, directions), quiet.closest_hit(origins, directions))
    counted.any_hit(origins, directions, 0.0, 2.0)
    n = len(origins)
    assert stats.nonshadow_rays == n and stats.shadow_rays == n
    assert 0 < stats.cells <= 2 * n * (5 + 5 + 5) and stats.intersections > 0
    assert stats.grid == (5, 5, 5) and np.allclose(stats.bounds[0], counted.lo)


def test_counting_wrapper():
    """Brute force tests every primitive for every ray, as the course's RayCast loop; an accelerator that does
    not count its own tests has them reported as unknown."""
    rng = np.random.default_rng(5)
    cs, vertices = random_scene(rng)
    origins, directions = random_rays(rng, vertices, 50)
    stats = RayStats()
    brute = CountingAccelerator(BruteForce(cs), stats, sum(cs.counts))
    assert_same_hits(brute.closest_hit(origins, directions), BruteForce(cs).closest_hit(origins, directions))
    brute.any_hit(origins, directions, 0.0, 1.0)
    assert stats.nonshadow_rays == 50 and stats.shadow_rays == 50 and stats.intersections == 100 * sum(cs.counts)
    unknown = RayStats()
    CountingAccelerator(BruteForce(cs), unknown, None).closest_hit(origins, directions)
    assert unknown.nonshadow_rays == 50 and unknown.intersections is None
    assert "n/a" in unknown.report(10, 5, 1.0)


def test_render_returns_stats_only_when_asked():
    scene = Scene(camera=CAM, group=Group([Sphere((0, 0, 0), 0.3), Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0))]),
                  lights=[DirectionalLight((0, 0, -1))])
    r = render(scene, 10, 10, options=RenderOptions(stats=True, grid=(2, 2, 2)))
    assert r.stats.nonshadow_rays == 100 and r.stats.shadow_rays == 0 and r.stats.cells > 0
    assert render(scene, 10, 10, options=RenderOptions(stats=True)).stats.nonshadow_rays == 100
    assert render(scene, 10, 10).stats is None


def test_report_has_the_course_lines():
    stats = RayStats(nonshadow_rays=40000, intersections=13000, cells=25000, grid=(10, 10, 10),
                     bounds=(np.full(3, -1.0), np.ones(3)))
    text = stats.report(200, 200, 2.0)
    for line in ("RAY TRACING STATISTICS", "num pixels                 40000 (200x200)",
                 "scene bounds               (-1.00 -1.00 -1.00) -> (1.00 1.00 1.00)",
                 "num grid cells             1000 (10x10x10)", "num non-shadow rays        40000",
                 "total intersections        13000", "total cells traversed      25000",
                 "rays per second            20000.0", "intersections per ray      0.3",
                 "cells traversed per ray    0.6"):
        assert line in text
