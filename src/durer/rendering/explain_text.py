"""The ray tree of explain.py as indented text, for the terminal: one ray per line, its shading terms below."""

from __future__ import annotations


def _v(a, digits: int = 4) -> str:
    return "(" + ", ".join(f"{x + 0.0:.{digits}g}" for x in a) + ")"  # + 0.0: no "-0"


def _g(x: float | None) -> str:
    return "inf" if x is None else f"{x:.4g}"


def _path_lines(node: dict) -> list[str]:
    """A path tracer's node (explain_path.py): its ray and vertex, then the emission found, the light sample
    (for a shadow node) or the BSDF sample that continues the path."""
    kind, hit = node["kind"], node["hit"]
    head = f"{kind} o={_v(node['origin'])} d={_v(node['direction'])}"
    tail = f"  contribution {_v(node['contribution'])}"
    if kind == "shadow":
        s = node["light_sample"]
        state = "BLOCKED" if node["blocked"] else "reaches it"
        light_pdf = "delta light" if s["pdf"] is None else f"pdf {s['pdf']:.4g}"
        return [f"{head} -> light sample: {state}{tail}",
                f"    emitter weight {_v(s['emitter_weight'])} {light_pdf}, BSDF {_v(s['bsdf'])} "
                f"pdf {_g(s['bsdf_pdf'])}, MIS weight {s['mis_weight']:.4g}"]
    if hit is None:
        lines = [f"{head} miss  throughput {_v(node['throughput'])}{tail}"]
    else:
        lines = [f"{head} hit {hit['object']} {hit['primitive']} at t={node['t']:.6g}, point {_v(hit['point'])}, "
                 f"normal {_v(hit['normal'])}, material {hit['material']} ({hit['material_type']})  "
                 f"throughput {_v(node['throughput'])}{tail}"]
    if node.get("emission"):
        e = node["emission"]
        if e.get("counted", True):
            lines.append(f"    emission {_v(e['radiance'])} x MIS weight {e['mis_weight']:.4g}")
        else:
            lines.append(f"    emission {_v(e['radiance'])} not counted (the emitter's back side, or hidden)")
    nxt = node.get("next")
    if "path_ends" in node:
        lines.append(f"    path ends: {node['path_ends']}")
    elif nxt is not None:
        lobe = "delta lobe" if nxt["delta"] else f"pdf {_g(nxt['pdf'])}"
        lines.append(f"    BSDF sample ({lobe}): throughput becomes {_v(nxt['throughput'])}")
    return lines


def _ray_line(node: dict) -> str:
    kind = node["kind"]
    head = f"{kind} o={_v(node['origin'])} d={_v(node['direction'])}"
    hit = node["hit"]
    if kind == "shadow":
        target = f"light {node['light']}"
        if hit is not None:
            return (f"{head} -> {target}: BLOCKED by {hit['object']} {hit['primitive']} at t={node['t']:.4g}"
                    f"  contribution {_v(node['contribution'])}")
        return f"{head} -> {target}: reaches it  contribution {_v(node['contribution'])}"
    if node.get("no_ray"):
        return f"{kind}: no ray (outside the camera's image)  contribution {_v(node['contribution'])}"
    if hit is None:
        return f"{head} miss (background)  weight {node['weight']:.4g}  contribution {_v(node['contribution'])}"
    back = ", back face" if hit.get("back_face") else ""
    return (f"{head} hit {hit['object']} {hit['primitive']} at t={node['t']:.6g}, point {_v(hit['point'])}, "
            f"normal {_v(hit['normal'])}, material {hit['material']} ({hit['material_type']}{back})  "
            f"weight {node['weight']:.4g}  contribution {_v(node['contribution'])}")


def _shading_lines(node: dict) -> list[str]:
    hit = node["hit"]
    if hit is None or node["kind"] == "shadow" or "shading" not in hit:
        return []
    shading = hit["shading"]
    if "flat" in shading:
        return [f"flat colour {_v(shading['flat'])}"]
    lines = []
    if "leaves" in hit:
        lines.append("texture blends " + ", ".join(f"material {x['material']} x {x['weight']:.4g}"
                                                   for x in hit["leaves"]))
    lines.append(f"ambient {_v(shading['ambient'])}")
    for term in shading["lights"]:
        state = {None: "", True: "  [in shadow]", False: "  [lit]"}[term["shadowed"]]
        if term.get("faces_away"):
            state = "  [faces away: no shadow ray]"
        lines.append(f"light {term['light']} ({term['type']}): diffuse {_v(term['diffuse'])} "
                     f"specular {_v(term['specular'])}{state}")
    if node.get("total_internal_reflection"):
        lines.append("total internal reflection: no refracted ray")
    return lines


def _node_lines(node: dict, depth: int) -> list[str]:
    pad = "  " * depth
    if "depth" in node or "light_sample" in node:  # a path tracer's node
        lines = [pad + line for line in _path_lines(node)]
    else:
        lines = [pad + _ray_line(node)]
        lines += [pad + "    " + line for line in _shading_lines(node)]
    for child in node["children"]:
        lines += _node_lines(child, depth + 1)
    return lines


def tree_text(tree) -> str:
    """`durer explain`'s text output of an explain.PixelTree (not imported: explain.py imports this module)."""
    from ..io.images import encode_srgb

    x, y = tree.pixel
    w, h = tree.size
    color = tree.color
    lines = [f"pixel ({x}, {y}) of {w}x{h}: linear colour {_v(color, 6)}, 8-bit sRGB "
             f"{tuple(int(c) for c in encode_srgb(color))}; {len(tree.rays)} sample(s), the sum of every "
             "ray's contribution"]
    for i, node in enumerate(tree.rays):
        s = node["sample"]
        index = f" (sample index {s['index']})" if "index" in s else ""
        lines.append(f"sample {i + 1}/{len(tree.rays)}{index} at film ({s['film'][0]:.4f}, {s['film'][1]:.4f}) "
                     f"of pixel ({s['pixel'][0]}, {s['pixel'][1]}), filter weight {s['filter_weight']:.4g}")
        lines += _node_lines(node, 1)
    return "\n".join(lines)
