"""accel/pages.py: a large tree's arrays copied onto 2 MiB pages: the same values, the layout the kernels need, and
the same hits from every query."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import durer.accel.bvh as bvh
from durer import RaycastingScene
from durer.accel.pages import HUGE_PAGE, huge_pages_available, on_huge_pages, tree_on_huge_pages

needs_thp = pytest.mark.skipif(not huge_pages_available(), reason="no transparent huge pages on this system")

_DTYPES = st.sampled_from([np.float32, np.float64, np.int32, np.int8])
_SHAPES = st.lists(st.integers(0, 300), min_size=1, max_size=2).map(tuple)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(_DTYPES, _SHAPES), min_size=1, max_size=4), st.integers(0, 2**31))
def test_copies_keep_values_and_layout(specs, seed):
    """Every copy equals its array (bits, dtype, shape), is C-contiguous and writable (a read-only array would be
    a type of its own to Numba: a second compiled kernel), the first starts a huge page, the rest 64-byte lines."""
    rng = np.random.default_rng(seed)
    arrays = tuple((rng.standard_normal(shape) * 100).astype(dt) for dt, shape in specs)
    copies = on_huge_pages(arrays)
    assert copies[0].ctypes.data % HUGE_PAGE == 0
    for a, c in zip(arrays, copies, strict=True):
        assert c.dtype == a.dtype and c.shape == a.shape
        assert np.array_equal(c.view(np.uint8), np.ascontiguousarray(a).view(np.uint8))
        assert c.flags.c_contiguous and c.flags.writeable
        assert c.ctypes.data % 64 == 0
        assert not np.shares_memory(c, a)
    spans = sorted((c.ctypes.data, c.ctypes.data + c.nbytes) for c in copies if c.nbytes)
    assert all(nxt[0] >= prev[1] for prev, nxt in zip(spans, spans[1:], strict=False))  # no overlap
    assert [pickle.loads(pickle.dumps(c)).tolist() for c in copies] == [a.tolist() for a in arrays]


def test_small_trees_keep_their_arrays():
    """Below min_bytes (the bunny's 4 MB tree measured no gain) the arrays themselves come back."""
    arrays = (np.zeros(1000, np.float32), np.zeros((10, 4), np.int32))
    assert all(a is b for a, b in zip(tree_on_huge_pages(arrays, min_bytes=10**6), arrays, strict=True))


@needs_thp
def test_the_mapping_gets_huge_pages():
    """/proc/self/smaps shows AnonHugePages in the mapping once the copy has written it (skipped where the kernel
    had no free 2 MiB page: fragmented memory, which on_huge_pages tolerates by design)."""
    (copy,) = tree_on_huge_pages((np.arange(3 * HUGE_PAGE // 8, dtype=np.float64),), min_bytes=0)
    p = copy.ctypes.data
    region = None
    with open("/proc/self/smaps") as smaps:
        for line in smaps:
            head = line.split()[0]
            if "-" in head and not head.endswith(":"):
                lo, hi = (int(x, 16) for x in head.split("-"))
                region = lo <= p < hi
            elif region and head == "AnonHugePages:":
                kb = int(line.split()[1])
                break
    if kb == 0:
        pytest.skip("the kernel gave this mapping no huge page (no free 2 MiB page now)")
    assert kb >= 2048 and kb % 2048 == 0


@pytest.fixture(scope="module")
def mesh():
    return trimesh.creation.icosphere(subdivisions=3, radius=1.0)


@settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**31), through_vertices=st.booleans())
def test_queries_agree_to_the_bit(mesh, seed, through_vertices, monkeypatch):
    """cast_rays and count_intersections on a tree moved onto huge pages (threshold 0) give the same bits as on
    the tree left where the build put it: random rays, and grazing ones aimed at the mesh's vertices."""
    rng = np.random.default_rng(seed)
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    n = 4096
    o = rng.uniform(-3, 3, (n, 3))
    target = v[rng.integers(0, len(v), n)] if through_vertices else rng.uniform(-1, 1, (n, 3))
    rays = np.concatenate([o, target - o], axis=1)
    results = []
    for moved in (False, True):
        monkeypatch.setattr(bvh, "tree_on_huge_pages",
                            (lambda a: tree_on_huge_pages(a, min_bytes=0)) if moved else (lambda a: a))
        scene = RaycastingScene()
        scene.add_triangles(v, f)
        hits = scene.cast_rays(rays)
        results.append((hits["t_hit"], hits["primitive_ids"], hits["primitive_uvs"],
                        scene.count_intersections(rays)))
        if moved and huge_pages_available():
            assert scene._bvh.packed.blas.bounds.ctypes.data % HUGE_PAGE == 0
    for a, b in zip(*results, strict=True):
        assert np.array_equal(a, b)
