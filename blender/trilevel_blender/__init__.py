"""Trilevel Surface: a Blender add-on that shows the trilevel surface mesh of an SPH particle
file or frame sequence, rebuilt as the timeline moves (docs/blender.md)."""

bl_info = {
    "name": "Trilevel Surface",
    "author": "trilevel developers",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar > Trilevel, and Add > Trilevel Surface",
    "description": "Surface meshes of SPH particle sequences (3-level adaptive grids) that follow the timeline",
    "category": "Import-Export",
}

if "bpy" in locals():  # F8 / script reload: reload the submodules too
    import importlib
    for _name in ("frames", "module_loader", "surface", "ui"):
        if _name in locals():
            importlib.reload(locals()[_name])

import bpy  # noqa: E402,F401

from . import frames, module_loader, surface, ui  # noqa: E402,F401


def register():
    ui.register()


def unregister():
    ui.unregister()
