"""From rays to pixels: the render driver, the integrators and the film.

`renderer` is durer.render(): `arguments` resolves its arguments, `memory` checks the size, `units` prepares a
Job and runs its units of work (tile x sample range -> per-pixel sums; `progress` shows them), `result` holds
the arrays. `context` is what every integrator reads (RenderContext) and returns (SampleResult); `integrators`
puts `raycaster` (the lecture's ray caster), `whitted` (the Whitted ray tracer), `grid_view` (the course's grid)
and `path` (the path tracer, with `bsdfs`, `emitters`, `envmap`, `sampling`) behind one interface; `shading` and
`texturing` shade Phong materials; `film` places samples and filters them; `film_images` draws the course's
sample and filter images; `explain*` replay one pixel.
"""
