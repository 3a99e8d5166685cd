"""The unit of work (rendering/units.py): (tile, sample range) -> Accumulators, added up into durer.render's
image to the bit whatever the tiles, batches and threads; and the memory check that counts what it allocates."""

from __future__ import annotations

import dataclasses
import pickle
from pathlib import Path

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import durer
from durer.options import RenderOptions
from durer.rendering import integrators as I
from durer.rendering import units as U
from durer.rendering.renderer import BYTES_PER_PIXEL, check_size, make_options, memory_needed

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
W, H = 22, 18  # not multiples of the tile sides below: edge tiles are cut

CASES = {  # integrator -> scene and options (every filter with a support radius > 0 somewhere)
    "raycast": ("spheres.txt", dict(samples=4, sampler="jittered", seed=5)),
    "whitted": ("spheres.txt", dict(shadows=True, bounces=3, samples=3, sampler="random")),
    "path": ("cornell_box.xml", dict(samples=3, max_depth=4)),
}
FILTERS = [("box", 0.5), ("tent", 1.5), ("gaussian", 0.5), ("mitchell", 2.0)]


@settings(deadline=None)
@given(st.integers(1, 400), st.integers(1, 400), st.integers(1, 300))
def test_tiles_cover_the_image_in_the_fewest_even_pieces(width, height, side):
    """Every pixel in exactly one tile, no tile over side, the fewest tiles per axis that allows, and tiles that
    differ by less than a 4-pixel step (but at the last one): the units threads share are of equal work."""
    tiles = U.tiles(width, height, side)
    cover = np.zeros((height, width), int)
    for t in tiles:
        assert 0 < t.rows <= side and 0 < t.cols <= side
        cover[t.row:t.row + t.rows, t.col:t.col + t.cols] += 1
    assert (cover == 1).all()
    for extent, size in ((height, {t.row: t.rows for t in tiles}), (width, {t.col: t.cols for t in tiles})):
        assert len(size) == -(-extent // side)
        inner = [size[k] for k in sorted(size)][:-1]
        assert not inner or (max(inner) == min(inner) and max(inner) - size[max(size)] < len(size) * 4)


def test_a_row_just_over_the_tile_side_is_cut_in_halves():
    """128 columns at the radius-1 filter's 124-pixel side: two 64-column tiles, not 124 and 4."""
    assert [(t.col, t.cols) for t in U.tiles(128, 96, 124)] == [(0, 64), (64, 64)]


def _job(name: str, filt: tuple[str, float]) -> U.Job:
    scene, kw = CASES[name]
    options = make_options(**kw, integrator=name, filter=filt[0], filter_radius=filt[1])
    return U.prepare(durer.load(EXAMPLES / scene), W, H, options)


def _image(job: U.Job) -> np.ndarray:
    r = U.finish(job, U.run(job))
    return np.concatenate([r.color, r.depth[..., None], r.normals], axis=-1)


@pytest.mark.parametrize("filt", FILTERS, ids=lambda f: f[0])
@pytest.mark.parametrize("name", list(CASES))
def test_same_image_whatever_the_tiles_batches_and_threads(name, filt):
    """Tiles of 4, 8 and 12 pixels (halos crossing tile borders), batches of 5 rays, one thread or all, two
    workers: the same image to the bit, and the same as durer.render's."""
    job = _job(name, filt)
    scene, kw = CASES[name]
    reference = durer.render(durer.load(EXAMPLES / scene), W, H, integrator=name, filter=filt[0],
                             filter_radius=filt[1], **kw)
    want = np.concatenate([reference.color, reference.depth[..., None], reference.normals], axis=-1)
    assert np.isfinite(want[..., :3]).all() and want[..., :3].max() > 0
    threads = numba.get_num_threads()
    try:
        for side in (4, 8, 12):
            np.testing.assert_array_equal(_image(dataclasses.replace(job, tile_side=side)), want)
        small = dataclasses.replace(job, tile_side=8, integrator=dataclasses.replace(job.integrator, batch=5, workers=2))
        np.testing.assert_array_equal(_image(small), want)
        numba.set_num_threads(1)
        np.testing.assert_array_equal(_image(dataclasses.replace(job, tile_side=12)), want)
    finally:
        numba.set_num_threads(threads)


def test_units_run_anywhere_and_add_up_to_the_render():
    """A pickled job (as a Dask worker gets it) renders units whose Accumulators, merged in a shuffled tile order,
    finish into durer.render's image; a tile's sample ranges add up too (up to the sums' rounding)."""
    job = _job("whitted", ("tent", 1.0))
    remote = pickle.loads(pickle.dumps(job))
    units = [(t, range(job.options.samples)) for t in U.tiles(W, H, 8)]
    parts = [U.render_unit(remote, t, s) for t, s in units]
    order = np.random.default_rng(1).permutation(len(parts))
    merged = U.merge(parts[i] for i in order)
    got = U.finish(job, merged)
    scene, kw = CASES["whitted"]
    want = durer.render(durer.load(EXAMPLES / scene), W, H, integrator="whitted", filter="tent", filter_radius=1.0,
                        **kw)
    np.testing.assert_array_equal(got.color, want.color)
    np.testing.assert_array_equal(got.depth, want.depth)
    # the same tiles in two sample ranges: the sums add up to the one-range image up to rounding
    passes = U.Accumulators.empty(job)
    for samples in (range(0, 1), range(1, 3)):
        for tile in U.tiles(W, H, 8):
            passes.add(U.render_unit(job, tile, samples))
    two = U.finish(job, passes)
    np.testing.assert_allclose(two.color, want.color, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(two.depth, want.depth)


def test_unit_sums_are_the_filter_weighted_samples():
    """One 1 x 1 tile with a tent of radius 1: its sums are the weighted colours of the 3 x 3 neighbourhood's
    samples, weights from film.filter_weight, and its depth that of its own sample nearest the centre."""
    job = _job("raycast", ("tent", 1.0))
    tile = U.Tile(5, 7, 1, 1)
    acc = U.render_unit(job, tile, range(4))
    from durer.rendering import film

    halo = tile.grown(1, W, H)
    assert halo == U.Tile(4, 6, 3, 3)
    rows, cols = range(4, 7), range(6, 9)
    pts = film.tile_points(job.options, W, H, rows, cols, range(4))
    o, d, _ = job.camera.generate_rays(pts, W, H)
    res = I.RAYCAST.trace(job.ctx, o, d, job.camera.t_min)
    w = film.filter_weight(job.options, pts[:, 0] - 7.5, pts[:, 1] - (H - 5 - 0.5))
    np.testing.assert_allclose(acc.weight[0, 0], w.sum(), rtol=1e-14)
    np.testing.assert_allclose(acc.channel("color")[0, 0], (w[:, None] * res.color).sum(0), rtol=1e-12)
    own = slice(4 * 4, 5 * 4)  # the centre pixel of the 3 x 3 halo, its 4 samples
    d2 = (pts[own, 0] - 7.5) ** 2 + (pts[own, 1] - (H - 5.5)) ** 2
    assert acc.depth[0, 0] == res.t[own][np.argmin(d2)]


def test_unit_rejects_samples_outside_the_pixel_count():
    job = _job("raycast", ("box", 0.5))
    with pytest.raises(ValueError, match="sample range"):
        U.render_unit(job, U.Tile(0, 0, 4, 4), range(3, 9))


def test_aovs_are_filtered_with_the_colour_weights(monkeypatch):
    """An integrator that reports another (N,k) per-sample field gets it filtered like colour: a field equal to
    the colour comes out as the colour image, and RenderResult.albedo exposes one named albedo."""

    from durer.rendering.raycaster import SampleResult, raycast

    @dataclasses.dataclass
    class Extra(SampleResult):
        albedo: np.ndarray | None = None

    def traced(ctx, o, d, t_min, pixel=None, sample=None):
        r = raycast(ctx, o, d, t_min)
        return Extra(r.color, r.t, r.normal, albedo=r.color.copy())

    job = _job("raycast", ("gaussian", 0.5))
    job = dataclasses.replace(job, integrator=dataclasses.replace(job.integrator, trace=traced))
    r = U.finish(job, U.run(job))
    assert r.albedo is not None and r.albedo.shape == (H, W, 3)
    np.testing.assert_array_equal(r.albedo, r.color)


def test_memory_is_flat_in_samples_and_grows_with_pixels():
    """The check counts the image's sums and a bounded unit: 256 samples per pixel need what 16 need (to within
    one unit), a 1024 x 768 x 256 path render about a quarter of a gigabyte, and a 4K Whitted render at 64 spp
    fits; an image too large for any machine is refused."""
    path = RenderOptions(integrator="path", samples=256)
    need = memory_needed(1024, 768, 256, path)
    assert need < 1.0e9
    assert abs(memory_needed(1024, 768, 16, path) - need) < 0.1e9
    assert memory_needed(3840, 2160, 64, RenderOptions(shadows=True, bounces=5, samples=64)) < 3e9
    assert memory_needed(2048, 2048, 1) - memory_needed(1024, 1024, 1) == 3 * 1024 * 1024 * BYTES_PER_PIXEL
    check_size(1024, 768, 256, path)
    with pytest.raises(ValueError, match="would need about"):
        check_size(10**6, 10**6, 1)


@pytest.mark.parametrize("samples,radius,side,per_pass", [
    (1, 1, 256, 1), (16, 1, 124, 16), (226, 1, 32, 226), (256, 1, 40, 128), (100000, 1, 32, 226),
    (64, 2, 84, 32), (16, 0, 128, 16), (256, 0, 32, 256), (5000, 0, 8, 2500)])
def test_plan_bounds_a_unit_and_its_halo(samples, radius, side, per_pass):
    """Tiles hold UNIT_SAMPLES samples of a pass with their halo, stay 32 radii wide (at most 13% more rays),
    and passes split the samples evenly."""
    got, n = U.plan(samples, radius)
    assert (got, n) == (side, per_pass) and got % 4 == 0
    assert n * (got + 2 * radius) ** 2 <= U.UNIT_SAMPLES
    assert not radius or got >= 32 * radius


@pytest.mark.slow
def test_peak_allocation_is_flat_in_samples_and_within_the_check():
    """Measured with tracemalloc (NumPy reports its buffers to it): 64 samples per pixel allocate at their peak
    what 16 do (the units are at their size bound either way), far below the 64 x 200 bytes a pixel the whole
    film of samples used to take, and within what memory_needed counts besides the interpreter."""
    import tracemalloc

    from durer.rendering.memory import BASE_BYTES

    scene = durer.load(EXAMPLES / "spheres.txt")
    durer.render(scene, 16, 16, samples=4)  # compile and warm up outside the measurement
    peaks = {}
    for n in (16, 64):
        tracemalloc.start()
        durer.render(scene, 256, 256, samples=n)
        peaks[n] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    assert peaks[64] < 1.2 * peaks[16]
    assert peaks[64] < 0.25 * 256 * 256 * 64 * 200
    assert peaks[64] < memory_needed(256, 256, 64, make_options(samples=64)) - BASE_BYTES


def test_a_path_job_pickles_with_its_tables():
    """prepare gathers the path tracer's inputs once (ctx.prepared, from the bundle); a pickled job carries them,
    and its units give the local units' sums to the bit."""
    job = _job("path", ("gaussian", 0.5))
    assert "path" in job.ctx.prepared
    remote = pickle.loads(pickle.dumps(job))
    assert "path" in remote.ctx.prepared
    tile = U.Tile(4, 8, 8, 8)
    a, b = U.render_unit(job, tile, range(1, 3)), U.render_unit(remote, tile, range(1, 3))
    np.testing.assert_array_equal(a.sums, b.sums)
    np.testing.assert_array_equal(a.depth, b.depth)


def test_progressive_passes_double_and_end_in_the_image():
    """refinement(): passes of 1, 1, 2, 4, ... samples over every tile; the sums after each pass finish into an
    image, and after the last into durer.render's up to the sums' rounding."""
    options = make_options(samples=9, sampler="jittered", filter="tent", filter_radius=1.0)
    job = U.prepare(durer.load(EXAMPLES / "spheres.txt"), W, H, options)
    passes = job.refinement()
    assert [(p[0][1].start, p[0][1].stop) for p in passes] == [(0, 1), (1, 2), (2, 4), (4, 8), (8, 9)]
    acc = U.Accumulators.empty(job)
    first = None
    for units in passes:
        for tile, samples in units:
            acc.add(U.render_unit(job, tile, samples))
        image = U.finish(job, acc).color
        first = image if first is None else first
    want = U.finish(job, U.run(job)).color
    np.testing.assert_allclose(image, want, rtol=1e-6, atol=1e-7)
    assert not np.array_equal(first, want)


@pytest.mark.parametrize("samples", [2, 3, 8])
@pytest.mark.parametrize("name", list(CASES))
def test_any_sample_count_renders_with_every_integrator(name, samples):
    scene, kw = CASES[name]
    kw = {**kw, "samples": samples}
    r = durer.render(durer.load(EXAMPLES / scene), 10, 8, integrator=name, **kw)
    one = durer.render(durer.load(EXAMPLES / scene), 10, 8, integrator=name, **{**kw, "samples": 1})
    assert np.isfinite(r.color).all() and r.color.max() > 0
    assert not np.array_equal(r.color, one.color)  # more samples: another (antialiased) image


def test_stats_count_each_ray_once_with_a_wide_filter():
    """-stats with a tent filter: one tile, so no halo sample is traced (and counted) twice."""
    scene = durer.load(EXAMPLES / "spheres.txt")
    r = durer.render(scene, 20, 16, samples=4, filter="tent", filter_radius=1.5, stats=True)
    assert r.stats.nonshadow_rays == 20 * 16 * 4
    counted = make_options(samples=16, filter="tent", filter_radius=1.5, stats=True)
    assert U.plan(16, 2)[0] < 300 and U.prepare(scene, 300, 200, counted).tile_side == 300


def test_finish_and_merge_refuse_what_is_not_an_image():
    job = _job("raycast", ("box", 0.5))
    with pytest.raises(ValueError, match="at least one unit"):
        U.finish(job, U.Accumulators.empty(job))
    with pytest.raises(ValueError, match="whole image"):
        U.finish(job, U.render_unit(job, U.Tile(0, 0, 4, 4), range(2)))
    with pytest.raises(ValueError, match="at least one"):
        U.merge([])
    with pytest.raises(ValueError, match="does not lie inside"):
        U.render_unit(job, U.Tile(0, 0, 4, 4), range(2)).add(U.render_unit(job, U.Tile(2, 2, 4, 4), range(2)))


def test_units_without_an_aov_add_to_units_with_it():
    """A unit none of whose rays reached the integrator reports colour only; adding it to sums that carry an AOV
    (and the other way round) keeps every channel, zero where no sample had it."""
    tile_a, tile_b = U.Tile(0, 0, 2, 2), U.Tile(0, 2, 2, 2)
    plain = U.Accumulators.zeros(tile_b)
    plain.sums[:] = 1.0
    rich = U.Accumulators.zeros(tile_a, (("color", 3), ("albedo", 3)))
    rich.sums[:] = 2.0
    for first, second in ((plain, rich), (rich, plain)):
        acc = U.merge([first, second])
        assert acc.channels == (("color", 3), ("albedo", 3))
        np.testing.assert_array_equal(acc.channel("color")[:, 2:], 1.0)
        np.testing.assert_array_equal(acc.channel("albedo")[:, 2:], 0.0)
        np.testing.assert_array_equal(acc.channel("albedo")[:, :2], 2.0)


def test_fisheye_tiles_with_rays_outside_the_circle():
    """Film points outside a fisheye's image circle have no ray (background, no hit): tiles of every size, some
    wholly outside the circle, give durer.render's image."""
    scene = durer.load(EXAMPLES / "fisheye.txt")
    options = make_options(samples=4, sampler="random", filter="tent", filter_radius=1.0, shadows=True)
    job = U.prepare(scene, 24, 16, options)
    want = durer.render(scene, 24, 16, options=make_options(samples=4, sampler="random", filter="tent",
                                                            filter_radius=1.0, shadows=True))
    assert np.isinf(want.depth).any() and np.isfinite(want.depth).any()
    for side in (4, 12):
        got = U.finish(job, U.run(dataclasses.replace(job, tile_side=side)))
        np.testing.assert_array_equal(got.color, want.color)
        np.testing.assert_array_equal(got.depth, want.depth)


def test_a_small_box_filtered_image_is_cut_for_every_thread():
    """A 128 x 128 box-filtered render (one tile by the memory plan) is cut into UNITS_PER_THREAD tiles per
    thread, none under MIN_SHARED_SIDE; a haloed filter keeps the planned side (its halo would cost rays)."""
    scene = durer.load(EXAMPLES / "cornell_box.xml")
    box = U.prepare(scene, 128, 128, make_options(samples=16, integrator="path", filter="box", filter_radius=0.5))
    assert U.plan(16, 0)[0] >= 128 and box.tile_side >= U.MIN_SHARED_SIDE
    assert len(box.tiles()) >= min(U.UNITS_PER_THREAD * numba.get_num_threads(), (128 // U.MIN_SHARED_SIDE) ** 2)
    tent = U.prepare(scene, 128, 128, make_options(samples=16, integrator="path", filter="tent", filter_radius=1.5))
    assert tent.tile_side == U.plan(16, 1)[0]
