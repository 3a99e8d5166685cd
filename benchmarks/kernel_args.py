"""Named-tuple kernel arguments against positional arrays in Numba: compile time and run time (issue 8, item 3).

Runs a one-ray loop over durer's blas_closest on the Stanford bunny two ways: the tree's arrays positional (as durer
passes them), and bundled into a namedtuple Tree(bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius,
sph_w2o). Give the variants in the order to compile them; blas_closest itself compiles with the first, so compare
the second one's compile time across runs with the order swapped, each in a fresh cache:

    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/kernel_args.py positional bundled
    NUMBA_CACHE_DIR=$(mktemp -d) python benchmarks/kernel_args.py bundled positional

Mesh: the Stanford bunny (Stanford Computer Graphics Laboratory), from ../shared/meshes.
"""

from __future__ import annotations

import sys
import time
from collections import namedtuple
from pathlib import Path

import numba as nb
import numpy as np
import trimesh

from durer.accel.bvh import build_tree
from durer.kernels.bvh.single import blas_closest

MESH = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "bun_zipper.ply"
Tree = namedtuple("Tree", "bounds child leaf_prim leaf_tri sph_center sph_radius sph_w2o")

def positional(o, d, bounds, child, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o, stack, out):
    stack_node, stack_t = np.empty(stack, np.int32), np.empty(stack)
    for i in range(o.shape[0]):
        t, k, p, u, v = blas_closest(bounds, child, 0, leaf_prim, leaf_tri, sph_center, sph_radius, sph_w2o,
                                     o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1], d[i, 2], 0.0, np.inf,
                                     stack_node, stack_t)
        out[i] = t

def bundled(o, d, tree, stack, out):
    stack_node, stack_t = np.empty(stack, np.int32), np.empty(stack)
    for i in range(o.shape[0]):
        t, k, p, u, v = blas_closest(tree.bounds, tree.child, 0, tree.leaf_prim, tree.leaf_tri, tree.sph_center,
                                     tree.sph_radius, tree.sph_w2o, o[i, 0], o[i, 1], o[i, 2], d[i, 0], d[i, 1],
                                     d[i, 2], 0.0, np.inf, stack_node, stack_t)
        out[i] = t

mesh = trimesh.load(str(MESH), force="mesh", process=False)
tr = build_tree(mesh.vertices[mesh.faces], np.zeros((0, 3)), np.zeros((0, 3)))
args = (tr.bounds.reshape(-1), tr.child, tr.leaf_prim, tr.leaf_tri.reshape(-1), np.zeros((0, 3)), np.zeros(0),
        np.zeros((0, 3, 4)))
rng = np.random.default_rng(1)
n = 300_000
o = np.tile([0.0, 0.1, 0.5], (n, 1)) + rng.normal(scale=0.01, size=(n, 3))
d = np.column_stack([rng.uniform(-0.2, 0.2, n), rng.uniform(-0.2, 0.2, n) - 0.1, -np.ones(n)])
out = np.empty(n)
for name in sys.argv[1:]:
    f = nb.njit(error_model="numpy", nogil=True)(positional if name == "positional" else bundled)
    small = (o[:10], d[:10])
    t0 = time.perf_counter()
    if name == "positional":
        f(*small, *args, tr.stack_size, out[:10])
    else:
        f(*small, Tree(*args), tr.stack_size, out[:10])
    compile_s = time.perf_counter() - t0
    runs = []
    for _ in range(5):
        t0 = time.perf_counter()
        if name == "positional":
            f(o, d, *args, tr.stack_size, out)
        else:
            f(o, d, Tree(*args), tr.stack_size, out)
        runs.append(time.perf_counter() - t0)
    print(f"{name}: compile {compile_s:.2f} s, run median {np.median(runs)*1e3:.1f} ms (min {min(runs)*1e3:.1f})")
