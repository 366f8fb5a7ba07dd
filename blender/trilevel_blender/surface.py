"""Reconstructs the surface of one particle file with the trilevel module, keeps the results in
a per-object cache of frames, and writes a result into a Blender mesh.

Every frame is reconstructed on its own (level_hysteresis 0): the mesh of a frame depends only
on its file and the settings, whatever order the timeline visits the frames in, so a cached
frame is always the one a fresh build would give. It equals the CLI's mesh of that file run
alone (`trilevel reconstruct frame.vtk -o m.ply ...`); the CLI's sequence mode instead holds
levels across frames (--level-hysteresis 0.2) and may differ slightly.
"""
import collections
import os

import numpy as np

from . import module_loader

# Colours of the two levels, as the CLI's --color-levels PLY (sRGB bytes / 255): green = level 2
# (cells of 2r), blue = level 3 (cells of r); grey for anything else.
LEVEL_COLOURS = {2: (0.0, 170 / 255, 0.0, 1.0), 3: (20 / 255, 90 / 255, 1.0, 1.0)}
OTHER_COLOUR = (170 / 255, 170 / 255, 170 / 255, 1.0)

FrameMesh = collections.namedtuple("FrameMesh", "vertices triangles levels normals attributes stats")

_reconstructor = None  # (module, its Reconstructor)
# cache id of an object -> (settings key, OrderedDict{(file path, mtime ns, size): FrameMesh})
_caches = {}


def reconstructor(module):
    """One Reconstructor for the session: it compiles the OpenCL kernels once."""
    global _reconstructor
    if _reconstructor is None or _reconstructor[0] is not module:
        _reconstructor = (module, module.Reconstructor())
    return _reconstructor[1]


def parse_attributes(text):
    """'velocity, density' -> ['velocity', 'density'] (order kept, duplicates dropped)."""
    names = []
    for n in text.replace(";", ",").split(","):
        n = n.strip()
        if n and n not in names:
            names.append(n)
    return names


def settings_key(settings, keywords):
    """What the mesh of a file depends on: a change drops the object's cached frames."""
    return (settings.radius, settings.mode, settings.cell, settings.normals, settings.attributes,
            bool(settings.smooth) if "smooth" in keywords else None,
            settings.smooth_iterations if "smooth_iterations" in keywords else None)


def reconstruct_file(module, path, settings):
    """FrameMesh of one particle file with the object's settings (trilevel.Error on bad input)."""
    names = parse_attributes(settings.attributes)
    if names:
        positions, attributes = module.read_particles(path, names)
    else:
        positions, attributes = module.read_particles(path), None
    keywords = module_loader.reconstruct_keywords(module)
    kwargs = dict(mode=settings.mode.lower(), level_hysteresis=0.0, return_levels=True)
    if settings.mode == 'UNIFORM':
        kwargs["cell"] = settings.cell
    if settings.normals != 'NONE':
        kwargs["normals"] = settings.normals.lower()
    if attributes:
        kwargs["attributes"] = attributes
    if "smooth" in keywords and settings.smooth:
        kwargs["smooth"] = True
        if "smooth_iterations" in keywords:
            kwargs["smooth_iterations"] = settings.smooth_iterations
    rec = reconstructor(module)
    rec.reset_history()  # every frame alone (see the module's docstring)
    out = list(rec.reconstruct(positions, settings.radius, **kwargs))
    vertices, triangles, stats, levels = out[0], out[1], out[2], out[3]
    rest = out[5:]
    normals = rest.pop(0) if "normals" in kwargs else None
    vertex_attributes = rest.pop(0) if attributes else {}
    return FrameMesh(vertices, triangles, levels, normals, vertex_attributes, stats)


def cached_frame(cache_id, key, path, settings, module, limit):
    """The FrameMesh of `path`, reconstructed only when this object has no cached result for
    this file (same path, modification time and size) and settings. Keeps at most `limit`
    frames per object, dropping the least recently shown. Returns (FrameMesh, built)."""
    stamp = os.stat(path)
    file_key = (os.path.abspath(path), stamp.st_mtime_ns, stamp.st_size)
    entry = _caches.get(cache_id)
    if entry is None or entry[0] != key:
        entry = (key, collections.OrderedDict())
        _caches[cache_id] = entry
    frames = entry[1]
    if file_key in frames:
        frames.move_to_end(file_key)
        return frames[file_key], False
    mesh = reconstruct_file(module, path, settings)
    frames[file_key] = mesh
    while len(frames) > max(1, limit):
        frames.popitem(last=False)
    return mesh, True


def cached_count(cache_id):
    entry = _caches.get(cache_id)
    return len(entry[1]) if entry else 0


def clear_cache(cache_id=None):
    if cache_id is None:
        _caches.clear()
    else:
        _caches.pop(cache_id, None)


def fill_mesh(mesh, frame):
    """Replaces the geometry of the Blender mesh `mesh` by `frame` (None: empty): vertices and
    triangles in the library's order, smooth shading, custom normals when computed, the levels
    as a point colour attribute `level`, each vertex attribute as a point attribute of its name
    (FLOAT or FLOAT_VECTOR; `velocity` is the one Blender's motion blur reads)."""
    mesh.clear_geometry()
    if frame is None or len(frame.triangles) == 0:
        mesh.update()
        return
    nv, nt = len(frame.vertices), len(frame.triangles)
    mesh.vertices.add(nv)
    mesh.vertices.foreach_set("co", np.ascontiguousarray(frame.vertices, dtype=np.float32).ravel())
    mesh.loops.add(3 * nt)
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(frame.triangles, dtype=np.int32).ravel())
    mesh.polygons.add(nt)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * nt, 3, dtype=np.int32))
    try:  # Blender < 3.6 needs the loop counts; later versions derive them (read-only there)
        mesh.polygons.foreach_set("loop_total", np.full(nt, 3, dtype=np.int32))
    except (AttributeError, TypeError, RuntimeError):
        pass
    mesh.update(calc_edges=True)
    mesh.polygons.foreach_set("use_smooth", np.ones(nt, dtype=bool))
    if frame.normals is not None:
        if hasattr(mesh, "use_auto_smooth"):  # Blender < 4.1: custom normals need it
            mesh.use_auto_smooth = True
        mesh.normals_split_custom_set_from_vertices(np.asarray(frame.normals, dtype=np.float32).tolist())
    colours = np.empty((nv, 4), dtype=np.float32)
    colours[:] = OTHER_COLOUR
    for level, rgba in LEVEL_COLOURS.items():
        colours[frame.levels == level] = rgba
    level = mesh.color_attributes.new("level", 'FLOAT_COLOR', 'POINT')
    level.data.foreach_set("color", colours.ravel())
    for name, values in frame.attributes.items():
        values = np.ascontiguousarray(values, dtype=np.float32)
        vector = values.ndim == 2
        attribute = mesh.attributes.new(name, 'FLOAT_VECTOR' if vector else 'FLOAT', 'POINT')
        attribute.data.foreach_set("vector" if vector else "value", values.ravel())
    mesh.update()
