"""trilevel: adaptive surface reconstruction of SPH particle sets (3-level grids, OpenCL).

    import trilevel
    vertices, triangles, stats = trilevel.reconstruct(positions, particle_radius=0.025)

The functions and classes are those of the compiled extension `trilevel._trilevel` (typed in
`_trilevel.pyi`); `trilevel.dask` maps the frames of a sequence over a dask.distributed cluster.
"""
from ._trilevel import (
    Error,
    FramePipeline,
    Reconstructor,
    __version__,
    default_curvature_threshold,
    devices,
    generate_scene,
    read_mesh,
    read_particles,
    reconstruct,
    scene_names,
    write_mesh,
    write_particles,
)

__all__ = [
    "Error",
    "FramePipeline",
    "Reconstructor",
    "__version__",
    "default_curvature_threshold",
    "devices",
    "generate_scene",
    "read_mesh",
    "read_particles",
    "reconstruct",
    "scene_names",
    "write_mesh",
    "write_particles",
]

# Shown as trilevel.Error and trilevel.Reconstructor in tracebacks and help(), where users name them.
Error.__module__ = __name__
Reconstructor.__module__ = __name__
