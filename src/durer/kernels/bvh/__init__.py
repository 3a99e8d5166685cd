"""The bounding volume hierarchy: how a ray walks the tree.

This docstring is the one map of the BVH's kernels; each module says the rest about its own part.

**The tree** (layout.py). A 4-wide tree: each node holds its four children's boxes (float32, rounded outwards,
rows LO_X .. HI_Z of NODE_FLOATS floats) and their codes: > 0 an inner node, 0 an empty lane, < 0 a leaf
(`leaf_code(start, count)` makes one, `leaf_range(code)` gives its slots). A leaf's slots index `leaf_prim`
(triangle id, or -(sphere + 1)) and `leaf_tri` (the triangle's nine coordinates, float32 or float64, always widened
to float64 before arithmetic).
build.py makes it: a binned-SAH binary tree collapsed to 4 wide, subtrees on threads (items.py: its triangle
inputs and leaf-ordered outputs).

**One ray** (single.py, simd.py). `ray_setup` computes the reciprocal direction and the watertight test's shear
(intersect.ray_shear). From the root, `next_leaf`/`descend` test a node's four boxes at once
(`simd.entry4`: the slab test as <4 x double> vector code), push the entered children nearest first on a small
stack (`push_nearest_first`) and return the next leaf; the leaf's items are tested by `slot_hit` (watertight
triangle test, or the sphere in its object space); `pop_closer` drops stacked nodes farther than the best hit.
A node's four child codes are read as one 16-byte row (`child_codes`, `simd.row4`) while its children are
prefetched, and the nearest one is picked from them by selects; the ordered stack's pointer is unsigned, entry k at
index k + 1 (no wraparound code on a push or pop).
`blas_closest`, `blas_any` and `blas_all` are the three walks (closest hit, any hit, every hit; `blas_any` and
`blas_all` written out with branch-free pushes, `blas_all` with leaf prefetch too, since an all-hits walk opens
every box in the ray's range);
`planes_closest` adds the unbounded planes, which live beside the tree.

**Packets** (chunks.py, packet.py). Sixteen coherent rays (a 4 x 4 image tile, or 16 consecutive rays) that share
direction signs and shear axes walk together: `chunks.packet_setup` checks they are coherent and fills the packet's
rows (each ray's constants, the packet's extremes); `packet_traverse` pops a node (`packet_pop`), prefetches its
children (`single.prefetch_children`), tests each child box once for the packet with interval bounds no single ray
can beat (`packet_node`; in packet_traverse its 4-wide vector form `packet_node4`), tests a leaf's triangles
against all live rays in a vectorised loop with each ray's own arithmetic (`_edges`), so every ray gets the one-ray
answer to the bit, and pushes the inner children (`push_inner`).

**Batches** (trace.py). `closest_hit_bvh` / `any_hit_bvh` take rays in chunks of PACKET (`chunks.chunk_rays`):
coherent chunks as packets, the rest one ray at a time; threads.run_blocks spreads blocks of chunks over threads.

**Two levels** (instances.py, instance_packets.py). A mesh placed more than once is stored once: a top-level
tree over instances (same layout; leaf slots name instances) and, at an instance leaf, the ray moved into object
space (`to_object`, direction left unnormalised so t stays the world t) and walked through that mesh's tree, as
a packet where the moved rays stay coherent (`chunks.object_packet`). A packet walks the top tree with the packet
walk's pieces (`packet_instances`); one ray walks it nearest first for the closest hit (`descend`/`pop_closer`) or
unordered for any or every hit (`next_instance`).

**Every hit of a packet** (packet_all.py). count_intersections and list_intersections take coherent chunks as
packets too: the packet walk's node test with no culling but the rays' t_max, unordered, over the top tree and each
instance's tree (`packet_all_instances`), each triangle tested against the 16 rays with the one-ray arithmetic and
tie-break, each ray's hits counted and, for lists, kept in a buffer of HIT_CAP a ray.

**Counting one ray's hits** (queued.py, leaf4.py). count_intersections' rays that are not in packets walk
`queued.blas_count`: the pending nodes in a ring queue, first in first out, so a child's prefetch lands before its
visit; where the scene has no spheres a leaf's triangles go 4 at a time through `leaf4.triangles4`, the watertight
test's arithmetic on <4 x double> lanes (the scalar answers to the bit; a ray on an edge or vertex to the scalar test).

**The query API's bands** (bands.py, queries.py). The user's rays are read as given (float32 or float64, any
strides) one cache-sized band at a time into float64 scratch, checked, traced by the walks above, and every
output is written from the scratch while it is in cache.
"""
