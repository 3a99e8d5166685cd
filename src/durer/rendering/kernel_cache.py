"""Which Numba kernels a render needs, whether Numba's on-disk cache already holds them, and the one notice that
says what will compile and for about how long. Each feature is checked on its own, so a path-traced render after
a Whitted one still announces the path tracer's compile, and a cache that holds every feature stays quiet.

A kernel module counts as cached when Numba's cache folder for it holds at least one index (`*.nbi`) written for
the module's source as it is now: Numba stores a stamp of the source file in each index (its modification time and
size, or a hash of it, by Numba version) and recompiles when it differs. The folder and the stamp are those of a
kernel's own cache object (so NUMBA_CACHE_DIR is honoured), read through Numba attributes that are not public API:
if a Numba release renames them, the module counts as cached and the notice stays quiet.
"""

from __future__ import annotations

import os
import pickle
import sys
from dataclasses import dataclass
from types import ModuleType

from ..options import RenderOptions


@dataclass(frozen=True)
class Feature:
    """A group of kernels compiled together the first time a render uses them, and their compile time measured
    with an empty cache on 2 cores (seconds: roughly; the first of several features compiles the shared ones)."""

    name: str
    modules: tuple[str, ...]  # kernel modules (durer.<...>) whose caches the feature fills
    seconds: int


BVH = Feature("the BVH", ("kernels.bvh.build", "kernels.bvh.items", "kernels.bvh.trace", "kernels.bvh.chunks",
                          "kernels.bvh.packet", "kernels.bvh.single"), 15)
# the path tracer builds the BVH but walks it in its own fused kernel (kernels/path/wavefront.py), never through
# bvh.trace: a path-only install that asked for all of BVH announced a compile on every run
BUILD = Feature("the BVH build", ("kernels.bvh.build", "kernels.bvh.items"), 5)
PATH = Feature("the path tracer", ("kernels.path.wavefront", "kernels.path.bsdf", "kernels.path.qmc"), 45)
GRID = Feature("the uniform grid", ("kernels.course.grid",), 10)
BRUTE = Feature("the every-object loop", ("kernels.brute",), 5)
TEXTURES = Feature("the solid textures", ("kernels.course.noise",), 3)
FILM = Feature("the film's filters", ("rendering.film",), 3)


def features(options: RenderOptions, scene=None) -> list[Feature]:
    """The kernel groups a render with these options (and this scene's materials) compiles."""
    from ..scene.textures import Checkerboard

    if options.integrator == "path":
        needed = [BUILD, PATH]
    else:
        needed = [GRID if options.grid is not None else BRUTE if options.accel == "brute" or options.stats else BVH]
    materials = getattr(scene, "materials", None) or []
    if any(type(m).__name__ in ("Noise", "Marble", "Wood") for m in materials if not isinstance(m, Checkerboard)):
        needed.append(TEXTURES)
    if options.samples > 1 or options.filter_reach() > 0.5:
        needed.append(FILM)
    return needed


def _module(name: str) -> ModuleType:
    import importlib

    return importlib.import_module(f"durer.{name}")


def _cache_folder(module: ModuleType) -> tuple[str, object] | None:
    """Numba's cache folder for the module's kernels and the stamp of its source now (None when it has no cached
    kernel or Numba cannot say)."""
    for obj in vars(module).values():
        cache = getattr(obj, "_cache", None)
        path = getattr(cache, "_cache_path", None)
        stamp = getattr(getattr(cache, "_cache_file", None), "_source_stamp", None)
        if path and stamp is not None and getattr(obj, "__module__", None) == module.__name__:
            return path, stamp
    return None


def module_cached(module: ModuleType) -> bool:
    """Does Numba's cache hold kernels compiled from the module's current source (see the module docstring)?"""
    found = _cache_folder(module)
    if found is None:
        return True  # nothing cacheable here (or a Numba that hides it): nothing to announce
    folder, now = found
    try:
        names = os.listdir(folder)
    except OSError:
        return False
    stem = module.__name__.rsplit(".", 1)[-1] + "."
    for name in names:
        if name.startswith(stem) and name.endswith(".nbi"):
            try:
                with open(os.path.join(folder, name), "rb") as f:
                    pickle.load(f)  # Numba's version
                    stamp = pickle.loads(f.read())[0]
            except Exception:  # noqa: BLE001  (a torn or foreign index: Numba will rewrite it)
                continue
            if stamp == now:
                return True
    return False


def _cached(name: str) -> bool:
    try:
        module = _module(name)
    except ImportError:  # a module moved: stay quiet rather than fail the render (tests/test_rendering_kernel_cache.py)
        return True
    return module_cached(module)


def cold_features(options: RenderOptions, scene=None) -> list[Feature]:
    """The features of `features(options, scene)` whose kernels are not all in Numba's cache."""
    return [f for f in features(options, scene) if not all(_cached(m) for m in f.modules)]


def compile_notice(options: RenderOptions, scene=None, stream=None) -> str | None:
    """Print (to stderr) and return the one line saying what this render compiles and for about how long, or
    None when everything it needs is cached."""
    cold = cold_features(options, scene)
    if not cold:
        return None
    names = [f.name for f in cold]
    what = names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]
    seconds = sum(f.seconds for f in cold)
    line = (f"durer: compiling the kernels of {what} (about {seconds} s on 2 cores; once: Numba caches them on "
            f"disk) ...")
    print(line, file=stream or sys.stderr, flush=True)
    return line
