"""The first run's compile notice (rendering/kernel_cache.py): per feature, from Numba's own cache indices."""

from __future__ import annotations

import importlib
import os
import pickle

import numba
import pytest

import durer
from durer.options import RenderOptions
from durer.rendering import kernel_cache
from durer.rendering.kernel_cache import BRUTE, BUILD, BVH, FILM, GRID, PATH, TEXTURES, features


def test_every_feature_names_modules_with_cached_kernels():
    for feature in (BVH, BUILD, PATH, GRID, BRUTE, TEXTURES, FILM):
        for name in feature.modules:
            module = importlib.import_module(f"durer.{name}")  # fails when a module moves: update the table
            assert kernel_cache._cache_folder(module) is not None, name


@pytest.mark.parametrize("options, expected", [
    (RenderOptions(), [BVH]),
    (RenderOptions(shadows=True, bounces=3), [BVH]),
    (RenderOptions(integrator="path"), [BUILD, PATH]),  # the path tracer never calls bvh.trace
    (RenderOptions(grid=(4, 4, 4)), [GRID]),
    (RenderOptions(accel="brute", samples=4, sampler="jittered"), [BRUTE, FILM]),
    (RenderOptions(stats=True, filter="gaussian", filter_radius=0.4), [BRUTE, FILM]),
])
def test_features_follow_the_options(options, expected):
    assert features(options) == expected


def test_solid_textures_need_the_noise_kernels():
    scene = durer.Scene(camera=durer.PerspectiveCamera((0, 0, 5), (0, 0, -1), (0, 1, 0), 40),
                        group=durer.Group([durer.Sphere((0, 0, 0), 1, material=2)]),
                        materials=[durer.PhongMaterial(), durer.PhongMaterial(), durer.Marble(0, 1)])
    assert features(RenderOptions(), scene) == [BVH, TEXTURES]
    scene.materials[2] = durer.Checkerboard(0, 1)
    assert features(RenderOptions(), scene) == [BVH]


def _index(folder, name: str, stamp) -> None:
    with open(os.path.join(folder, name), "wb") as f:
        pickle.dump(numba.__version__, f)
        f.write(pickle.dumps((stamp, {})))


def test_a_module_is_cached_when_an_index_matches_its_source(tmp_path, monkeypatch):
    module = importlib.import_module("durer.kernels.course.grid")
    folder, stamp = kernel_cache._cache_folder(module)  # the folder Numba uses, and its stamp of grid.py now
    assert os.path.isabs(folder) and stamp is not None
    monkeypatch.setattr(kernel_cache, "_cache_folder", lambda m: (str(tmp_path), stamp))
    assert not kernel_cache.module_cached(module)                     # empty cache
    _index(tmp_path, "grid.old_kernel-12.py311.nbi", b"an older source")
    _index(tmp_path, "bvh_trace.kernel-12.py311.nbi", stamp)
    (tmp_path / "grid.torn-1.py311.nbi").write_bytes(b"\x80")
    assert not kernel_cache.module_cached(module)                     # stale, another module's, torn
    _index(tmp_path, "grid.walk_cells-275.py311.nbi", stamp)
    assert kernel_cache.module_cached(module)
    monkeypatch.setattr(kernel_cache, "_cache_folder", lambda m: (str(tmp_path / "missing"), stamp))
    assert not kernel_cache.module_cached(module)


def test_the_notice_names_what_compiles_once(monkeypatch, capsys):
    """Issue 25: after a Whitted render the path tracer's first compile got no notice."""
    path_modules = {f"durer.{m}" for m in PATH.modules}
    monkeypatch.setattr(kernel_cache, "module_cached", lambda module: module.__name__ not in path_modules)
    assert kernel_cache.compile_notice(RenderOptions(shadows=True, bounces=3)) is None
    line = kernel_cache.compile_notice(RenderOptions(integrator="path"))
    assert line == ("durer: compiling the kernels of the path tracer (about 45 s on 2 cores; once: Numba caches "
                    "them on disk) ...")
    assert capsys.readouterr().err == line + "\n"
    monkeypatch.setattr(kernel_cache, "module_cached", lambda module: False)
    assert "of the BVH build, the path tracer and the film's filters (about 53 s" in kernel_cache.compile_notice(
        RenderOptions(integrator="path", samples=4))


def test_a_path_only_cache_gives_no_notice_to_a_path_render(monkeypatch):
    """Measured before the fix: after a path-traced render the next one announced the BVH's compile again, since
    the path tracer never compiles bvh.trace, bvh.packet or bvh.single (it walks the tree in its own kernel)."""
    walks = {f"durer.{m}" for m in BVH.modules} - {f"durer.{m}" for m in BUILD.modules}
    monkeypatch.setattr(kernel_cache, "module_cached", lambda module: module.__name__ not in walks)
    assert kernel_cache.compile_notice(RenderOptions(integrator="path")) is None
    assert kernel_cache.cold_features(RenderOptions()) == [BVH]


def test_render_prints_the_notice_only_when_not_quiet(monkeypatch, capsys):
    monkeypatch.setattr(kernel_cache, "module_cached", lambda module: False)
    scene = durer.load(os.path.join(os.path.dirname(__file__), "..", "examples", "spheres.txt"))
    durer.render(scene, 2, 2, quiet=False)
    assert capsys.readouterr().err.startswith("durer: compiling the kernels of the BVH (about 15 s")
    durer.render(scene, 2, 2)
    assert capsys.readouterr().err == ""


def test_the_real_cache_is_warm_after_a_render():
    scene = durer.load(os.path.join(os.path.dirname(__file__), "..", "examples", "spheres.txt"))
    durer.render(scene, 4, 4)
    assert kernel_cache.cold_features(RenderOptions()) == []
