"""Mitsuba 3 shape plugins -> durer geometry placed by Transforms: mesh files (obj, ply through trimesh; serialized
through io/serialized.py), rectangle and cube (meshes with Mitsuba's texture coordinates), the analytic sphere, disk
and cylinder, sdfgrid (its level set triangulated, io/sdfgrid.py), and shapegroup + instance (a group of shapes
placed several times, which durer stores once and traces two-level). Each shape gets its own material slot (BSDF,
area emission, flipped normals)."""

from __future__ import annotations

import numpy as np

from ..scene import bsdfs as B
from ..scene.graph import Group, Transform
from ..scene.shapes import Cylinder, Disk, Sphere, TriangleMesh
from .files import read_bytes
from .mitsuba_bsdfs import textured
from .mitsuba_tree import Props, call
from .sdfgrid import read_vol, sdf_mesh
from .serialized import read_serialized

SHAPES = ("obj", "ply", "serialized", "rectangle", "cube", "sphere", "disk", "cylinder", "sdfgrid", "shapegroup",
          "instance")
ANALYTIC = (Sphere, Disk, Cylinder)  # texture coordinates computed at the hit (CompiledScene.analytic_uv)


def build_shape(builder, node, depth: int = 0, out: list | None = None) -> None:
    """Add the shape (placed by its to_world) to `out` (the scene's objects by default)."""
    out = builder.objects if out is None else out
    t = node.type
    if t not in SHAPES:
        raise node.error(f"unsupported shape '{t}' (durer reads {', '.join(SHAPES)})")
    if t == "shapegroup":
        raise node.error("a shapegroup needs an id and is placed by instances that refer to it")
    p = Props(node)
    m = p.get("to_world", np.eye(4), "matrix")
    if abs(np.linalg.det(m[:3, :3])) < 1e-300:
        raise node.error("to_world is singular")
    if t == "instance":
        p.done()
        out.append(Transform(m, _group(builder, node, depth)))
        return
    flip = p.get("flip_normals", False, bool)
    if t in ("obj", "ply", "serialized"):
        geometry = _mesh_file(builder, node, p)
    elif t == "rectangle":
        geometry = TriangleMesh([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], [[0, 1, 2], [0, 2, 3]],
                                uvs=[[0, 0], [1, 0], [1, 1], [0, 1]])
    elif t == "cube":
        geometry = _cube()
    elif t == "sdfgrid":
        geometry = _sdfgrid(builder, node, p)
    elif t == "disk":
        geometry = Disk()
    elif t == "cylinder":
        geometry = call(node, Cylinder, p.get("p0", np.zeros(3), "vec"), p.get("p1", np.array([0.0, 0.0, 1.0]), "vec"),
                        p.get("radius", 1.0, float))
    else:  # sphere
        geometry = call(node, Sphere, p.get("center", np.zeros(3), "vec"), p.get("radius", 1.0, float))
    p.done()
    bsdf, radiance = None, None
    for child in node.children:
        child = builder.resolve(child)
        if child.tag == "bsdf":
            if bsdf is not None:
                raise child.error("a shape has one bsdf")
            bsdf = builder.bsdf(child, depth + 1)
        elif child.tag == "emitter":
            if radiance is not None:
                raise child.error("a shape has one emitter")
            radiance = builder.emitter(child, shape=node)
        else:
            raise child.error(f"<{child.tag}> cannot appear in a shape")
    if (textured(bsdf) or textured(radiance)) and not isinstance(geometry, ANALYTIC) and \
            getattr(geometry, "uvs", None) is None:
        what = "bsdf's textures" if textured(bsdf) else "emitter's textured radiance"
        raise node.error(f"shape '{t}' has no texture coordinates for its {what} (its mesh file has none)")
    builder.materials.append(call(node, B.Surface, bsdf if bsdf is not None else B.Diffuse(), radiance, flip))
    geometry.material = len(builder.materials) - 1
    out.append(Transform(m, geometry))


def _group(builder, node, depth: int) -> Group:
    """The Group an instance places: its shapegroup's shapes, built once and shared by every instance."""
    refs = [c for c in node.children if c.tag == "ref"]
    if len(refs) != 1 or len(node.children) != 1:
        raise node.error("an instance refers to exactly one shapegroup (<ref id=\"...\"/>)")
    group = builder.resolve(refs[0])
    if group.tag != "shape" or group.type != "shapegroup":
        raise refs[0].error(f"an instance places a shapegroup, not <{group.tag}> '{group.type}'")
    cached = getattr(group, "_built", None)
    if cached is not None:
        return cached
    builder.enter(group, depth)
    Props(group).done()
    shapes: list = []
    for child in group.children:
        child = builder.resolve(child)
        if child.tag != "shape" or child.type in ("shapegroup", "instance"):
            raise child.error("a shapegroup holds shapes (not groups or instances)")
        if any(builder.resolve(c).tag == "emitter" for c in child.children):
            raise child.error("shapes in a shapegroup cannot emit light (as in Mitsuba)")
        build_shape(builder, child, depth + 1, shapes)
    builder.leave(group)
    group._built = Group(shapes)
    return group._built


def _mesh_file(builder, node, p: Props) -> TriangleMesh:
    filename = p.get("filename", None, str)
    face_normals = p.get("face_normals", False, bool)
    flip_uv = p.get("flip_tex_coords", True, bool)
    index = p.get("shape_index", 0, int) if node.type == "serialized" else 0
    if not filename:
        raise node.error(f"shape '{node.type}' needs a filename")
    path = builder.file(node, filename, p.where("filename"), "mesh file")
    if node.type == "serialized":
        try:
            mesh = read_serialized(read_bytes(path, "mesh file"), index)
        except ValueError as e:
            raise node.error(f"cannot read mesh {filename}: {e}", p.where("filename")) from None
        vertices, faces, normals, uvs = mesh.vertices, mesh.faces, mesh.normals, mesh.uvs
        face_normals = face_normals or mesh.face_normals
    else:
        import trimesh

        try:
            # one mesh keeps the file's vertex normals; force="mesh" (files of several objects) recomputes them
            mesh = trimesh.load(path, file_type=node.type, process=False)
            if not isinstance(mesh, trimesh.Trimesh):
                mesh = trimesh.load(path, file_type=node.type, force="mesh", process=False)
        except Exception as e:  # trimesh raises many types on malformed files
            raise node.error(f"cannot read mesh {filename}: {e}") from None
        vertices, faces = np.asarray(getattr(mesh, "vertices", ())), np.asarray(getattr(mesh, "faces", ()))
        uvs = getattr(getattr(mesh, "visual", None), "uv", None)
        uvs = None if uvs is None or len(uvs) != len(vertices) else np.array(uvs, dtype=np.float64)
        if uvs is not None and flip_uv and node.type == "obj":  # Mitsuba's obj reader: v -> 1 - v by default
            uvs[:, 1] = 1.0 - uvs[:, 1]
        # the file's vertex normals, else computed (angle-weighted) as Mitsuba does for files without them
        normals = None if face_normals else np.asarray(mesh.vertex_normals, dtype=np.float64)
    if not len(faces):
        raise node.error(f"mesh {filename} has no triangles")
    return call(node, TriangleMesh, vertices, faces, source=path, uvs=uvs,
                normals=None if face_normals else normals)


def _sdfgrid(builder, node, p: Props) -> TriangleMesh:
    """Mitsuba's sdfgrid (a .vol file or a `grid` array, [z, y, x] or [z, y, x, 1]) as the triangles of its zero
    level set in the unit cube (io/sdfgrid.py)."""
    filename, grid = p.get("filename", None, str), p.get("grid", None)
    normals = p.get("normals", "smooth", str)
    if normals not in ("smooth", "analytic"):
        raise node.error(f"sdfgrid normals must be 'smooth' or 'analytic', got {normals!r}", p.where("normals"))
    if (filename is None) == (grid is None):
        raise node.error("sdfgrid needs a filename or a grid (one of them)")
    path = None if filename is None else builder.file(node, filename, p.where("filename"), "volume file")
    try:
        if path is not None:
            grid = read_vol(read_bytes(path, "volume file"))
        grid = np.asarray(grid, dtype=np.float64)
        grid = grid[..., 0] if grid.ndim == 4 and grid.shape[3] == 1 else grid
        if grid.ndim != 3 or min(grid.shape) < 2 or not np.isfinite(grid).all():
            raise ValueError(f"a grid is a finite [z, y, x] array at least 2 a side, got shape {grid.shape}")
    except (TypeError, ValueError) as e:
        raise node.error(f"sdfgrid: {e}", p.where("filename" if filename is not None else "grid")) from None
    vertices, faces, vertex_normals = sdf_mesh(grid)
    if not len(faces):
        raise node.error("sdfgrid: the grid has no surface (no sign change)")
    # Mitsuba's sdfgrid has texture coordinates (0, 0) everywhere (measured): a texture shows its value there
    return call(node, TriangleMesh, vertices, faces, source=path, normals=vertex_normals,
                uvs=np.zeros((len(vertices), 2)))


def _cube() -> TriangleMesh:
    """Mitsuba's cube: [-1, 1]^3 as 12 outward-facing triangles over 24 vertices (four a face), with its texture
    coordinates (each face [0, 1]^2), the arrays of Mitsuba's cube.cpp."""
    v = np.array([[1, -1, -1], [1, -1, 1], [-1, -1, 1], [-1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, 1, 1], [1, 1, 1],
                  [1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1], [-1, -1, 1],
                  [-1, -1, 1], [-1, 1, 1], [-1, 1, -1], [-1, -1, -1], [1, 1, -1], [1, -1, -1], [-1, -1, -1],
                  [-1, 1, -1]], dtype=np.float64)
    uv = np.tile([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]], (6, 1))
    faces = np.array([tri for q in range(0, 24, 4) for tri in ([q, q + 1, q + 2], [q + 3, q, q + 2])])
    return TriangleMesh(v, faces, uvs=uv)
