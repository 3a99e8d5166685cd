"""The memory layout every BVH kernel shares: node rows, leaf codes, packet shape.

A 4-wide BVH whose nodes hold their children's boxes, float32, structure of arrays, so one node visit tests four
boxes from one 96-byte block (measured fastest of the variants tried, see benchmarks/README.md):

    bounds[node, row, lane]  float32 (N, 6, 4), rows = lo x, lo y, lo z, hi x, hi y, hi z (rounded outwards);
                             the kernels read it flat: row r of lane l at node * NODE_FLOATS + ROW[r] + l
    child[node, lane]        int32   (N, 4):  > 0 inner node, 0 empty slot (its box sits at +inf),
                                              < 0 leaf = leaf_code(start, count)

Node 0 is the root of the first tree, so 0 never names a child. A leaf's items are slots start..start+count of
the leaf arrays, stored in leaf order so a leaf reads one contiguous block:

    leaf_prim[slot]  int32: >= 0 triangle id, < 0 sphere -(s + 1) into the sphere arrays
    leaf_tri[slot]   float32 or float64 (9,): the triangle's vertices (unused for spheres); float32 when the
                     tree is large and every vertex is a float32 value (accel/bvh.narrow_leaves), which halves
                     the leaves' memory traffic and changes no result: kernels widen each coordinate to
                     float64 as they load it (leaf_vertices) and do all arithmetic in float64, as on float64
                     leaves

Boxes are float32 to halve the traversal's memory traffic; the slab test itself runs in float64 against boxes
rounded outwards, with the far distance widened by a few ulps (Ize 2013), so rounding never culls a real hit.
Several trees (one per mesh) can share these arrays; a second, top-level tree over instances then gives the
two-level BVH of accel/bvh.py: a mesh used twice is stored once.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from ..common import JIT

# node layout: floats per node, and the flat offset of each row of bounds within a node (4 lanes a row)
WIDTH = 4
NODE_FLOATS = 6 * WIDTH
LO_X, LO_Y, LO_Z, HI_X, HI_Y, HI_Z = (row * WIDTH for row in range(6))

# leaf codes: child = -(start * 8 + count) - 1, so up to 7 items a leaf
LEAF_COUNT_BITS = 3
LEAF_COUNT_MASK = (1 << LEAF_COUNT_BITS) - 1

MAX_LEAF = 4          # items per leaf (the build may go up to 7 when all centroids coincide)
FAR_WIDEN = 1e-15     # relative widening of the slab test's far distance: covers float64 rounding
RAY_CHUNK = 64        # rays per parallel work item: neighbouring (coherent) rays share a thread's cache
TILE = 4              # an image's rays are traced in TILE x TILE packets
PACKET = TILE * TILE  # rays in a packet
BLOCK = 8             # packets per parallel work item of the one-level kernels (amortises the scratch)
# a packet's rays must also be close: directions within PACKET_CONE (cosine, 20 degrees) of its first ray's and
# origins within PACKET_SPREAD of the tree's extent; else its interval bounds sweep much of the tree and every
# leaf met is tested for all 16 rays (measured: 65k random rays sorted by origin, 175x slower than one by one).
# Camera rays pass (tiles of a 48 x 48 image of 43 degrees, orthographic ones 1/6 of the scene wide).
PACKET_CONE = 0.94
PACKET_SPREAD = 0.25


@nb.njit(**JIT)
def packet_spread_limit(bounds, child):
    """The largest origin spread (max over axes) a coherent packet may have: PACKET_SPREAD times the largest
    side of the box around the root's children (0 for an empty tree, whose packets cost nothing anyway)."""
    if child.shape[0] == 0:
        return 0.0
    side = 0.0
    for axis in range(3):
        lo, hi = np.inf, -np.inf
        for lane in range(WIDTH):
            if child[0, lane] != 0:
                lo = min(lo, np.float64(bounds[LO_X + axis * WIDTH + lane]))
                hi = max(hi, np.float64(bounds[HI_X + axis * WIDTH + lane]))
        if hi > lo:
            side = max(side, hi - lo)
    return side * PACKET_SPREAD


@nb.njit(**JIT, inline="always")
def lane_box(bounds, base):
    """The box of the lane at flat offset `base` (node * NODE_FLOATS + lane): lo x, y, z, hi x, y, z."""
    return (bounds[base + LO_X], bounds[base + LO_Y], bounds[base + LO_Z],
            bounds[base + HI_X], bounds[base + HI_Y], bounds[base + HI_Z])


@nb.njit(**JIT, inline="always")
def leaf_vertices(leaf_tri, o):
    """The 9 coordinates at leaf_tri[o:o+9] (v0 xyz, v1 xyz, v2 xyz) as float64, whatever the leaves' dtype:
    arithmetic between two float32 leaf values would otherwise round in float32."""
    return (np.float64(leaf_tri[o]), np.float64(leaf_tri[o + 1]), np.float64(leaf_tri[o + 2]),
            np.float64(leaf_tri[o + 3]), np.float64(leaf_tri[o + 4]), np.float64(leaf_tri[o + 5]),
            np.float64(leaf_tri[o + 6]), np.float64(leaf_tri[o + 7]), np.float64(leaf_tri[o + 8]))


@nb.njit(**JIT, inline="always")
def leaf_range(code):
    """The slots start..end of the leaf that child code `code` (< 0) names."""
    v = -code - 1
    first = v >> LEAF_COUNT_BITS
    return first, first + (v & LEAF_COUNT_MASK)


@nb.njit(**JIT, inline="always")
def leaf_code(start, count):
    """The child code of a leaf holding slots start..start+count (leaf_range inverts it)."""
    return -((start << LEAF_COUNT_BITS) + count) - 1


def leaf_codes(start: np.ndarray, count: np.ndarray) -> np.ndarray:
    """leaf_code for NumPy arrays (leaf_slots inverts it)."""
    return leaf_code.py_func(np.asarray(start, np.int64), count)


def leaf_slots(codes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(start, count) of the leaves that child codes `codes` (< 0) name: leaf_range for NumPy arrays."""
    v = -np.asarray(codes, np.int64) - 1
    return v >> LEAF_COUNT_BITS, v & LEAF_COUNT_MASK


def stack_size_for(depth: int) -> int:
    """Traversal stack entries a tree of this depth can need: three deferred children per level, plus slack (the
    branch-free pushes write one entry beyond the top; the ordered stack keeps index 0 spare: single.py)."""
    return 3 * int(depth) + 8
