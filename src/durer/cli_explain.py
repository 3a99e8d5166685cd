"""`durer explain SCENE --pixel X Y`: one pixel's ray tree (rendering/explain.py) as text, JSON or a drawing.

cli.py registers the command and hands over its shared render flags (add_render_flags, render_options), so the
tree is that of the pixel `durer render` writes with the same flags.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from .errors import UsageError

# how `durer explain` introduces itself; cli.py builds the parser and adds the shared render flags
PARSER = dict(prog="durer explain",
              usage="durer explain SCENE --pixel X Y [--json] [--draw OUT.png] [render options]",
              description="Print the ray tree of one pixel: every ray cast for it (camera, shadow, "
                          "reflection, refraction), what it hit, the shading terms and its contribution "
                          "to the pixel's colour, which is the sum of the contributions. With the path "
                          "tracer, each sample's path: vertices, light samples, BSDF samples, MIS weights.",
              epilog="The render options are those of `durer render`: the tree is that of the pixel "
                     "`durer render` writes with the same options. Exit status 2 on any user error.")


def add_arguments(p: argparse.ArgumentParser) -> None:
    """The flags of `durer explain` besides the render flags every rendering command shares."""
    p.add_argument("scene", help="scene file")
    p.add_argument("--pixel", nargs=2, type=int, required=True, metavar=("X", "Y"),
                   help="the pixel: X from the left, Y from the top, in the image of --size")
    p.add_argument("--json", action="store_true", help="print the tree as JSON instead of text")
    p.add_argument("--draw", metavar="OUT.png", help="also draw the rays over the rendered image into OUT.png")


def explain_command(a: argparse.Namespace, render_options, scene_size) -> int:
    """Run `durer explain` on parsed arguments; render_options turns them (over the scene's own defaults) into
    RenderOptions, scene_size gives the image size as `durer render` picks it."""
    from .io.images import EIGHT_BIT, check_extension, write_atomic

    render_options(a)  # a bad flag is reported before anything is read
    x, y = a.pixel
    if a.size is not None:
        _check_pixel(x, y, *a.size)
    if a.draw:
        if check_extension(a.draw) not in EIGHT_BIT:
            raise UsageError(f"--draw: '{a.draw}' must be an 8-bit image ({', '.join(EIGHT_BIT)})")
        folder = os.path.dirname(os.path.abspath(a.draw))
        if not os.path.isdir(folder):
            raise UsageError(f"cannot write '{a.draw}': folder '{folder}' does not exist")
    from . import load
    from .rendering.explain import check_integrator, explain

    scene = load(a.scene, mesh_path=a.mesh_path)
    opts = render_options(a, scene.render_defaults)  # a Mitsuba scene's integrator, samples, filter, as render's
    width, height = scene_size(a, scene)
    _check_pixel(x, y, width, height)
    try:
        check_integrator(scene.materials, opts)
    except ValueError as e:
        raise UsageError(str(e).replace("integrator='path'", "--integrator path")) from None
    tree = explain(scene, width, height, x, y, options=opts)
    if a.json:
        print(json.dumps(tree.to_json(), allow_nan=False))
    else:
        print(tree.text())
    if a.draw:
        from .rendering.explain_draw import draw_tree
        from .rendering.renderer import render

        image = draw_tree(tree, render(scene, width, height, options=opts).color, scene.camera)
        fmt = EIGHT_BIT[check_extension(a.draw)]
        write_atomic(a.draw, lambda f: image.save(f, format=fmt))
        print(f"durer: drew the ray tree over the image into {a.draw}", file=sys.stderr)
    return 0


def _check_pixel(x: int, y: int, width: int, height: int) -> None:
    if not (0 <= x < width and 0 <= y < height):
        raise UsageError(f"--pixel {x} {y} is outside the {width}x{height} image "
                         f"(X in 0..{width - 1} from the left, Y in 0..{height - 1} from the top)")
