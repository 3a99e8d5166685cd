"""From a Scene to hits: compile the object tree to flat arrays, then answer closest-hit and any-hit queries.

`compile` flattens the scene; `hits` defines the hit records and the Accelerator protocol every accelerator meets;
`brute` is the lecture's loop over every object, `bvh` the bounding volume hierarchy every render and query uses by
default (one- and two-level), `grid` the course's uniform grid, `stats` the course's counters.
"""
