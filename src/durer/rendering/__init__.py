"""From rays to pixels: the render driver, the integrators and the film.

`renderer` drives a render (film samples -> camera rays -> an integrator -> the film); `raycaster` is the
lecture's ray caster and `whitted` the Whitted ray tracer, both shading with `shading` and `texturing`;
`grid_view` draws the course's grid; `film` places samples and reconstructs pixels; `film_images` draws the
course's sample and filter images.
"""
