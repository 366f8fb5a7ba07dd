"""Blender side of the add-on: preferences, the per-object settings, the operators, the 3D-view
sidebar panel and the frame-change handler that shows scene frame N as file N - offset."""
import sys
import uuid

import bpy
from bpy.app.handlers import persistent

from . import frames, module_loader, surface


def preferences(context=None):
    addons = (context or bpy.context).preferences.addons
    entry = addons.get(__package__)
    return entry.preferences if entry else None


def load_module(context=None):
    prefs = preferences(context)
    return module_loader.load(prefs.python_path if prefs else "")


def supported_keywords():
    """Keywords of the loaded module's reconstruct (empty before it loads or when it cannot)."""
    try:
        return module_loader.reconstruct_keywords(load_module())
    except ImportError:
        return set()


def cache_key(obj):
    """The object's entry in the mesh cache: its cache id (kept in the .blend) and its name, so
    that a duplicate (same id, new name) gets a cache of its own."""
    return f"{obj.trilevel.cache_id}/{obj.name}"


def _settings_changed(self, context):
    """A setting of a surface changed: show the current frame with it (cached if it was before)."""
    obj = self.id_data
    if obj is not None and self.enabled and obj.name in context.scene.objects:
        update_object(context.scene, obj)


class TrilevelPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    python_path: bpy.props.StringProperty(
        name="Module directory", subtype='DIR_PATH',
        description="Directory holding the trilevel Python module (trilevel*.so), e.g. the CMake build's "
                    "python/ directory; empty: Blender's own Python (pip install) or $TRILEVEL_PYTHON_PATH")
    cache_frames: bpy.props.IntProperty(
        name="Cached frames per object", default=100, min=1, max=100000,
        description="Meshes kept in memory per surface object; the least recently shown go first")

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "python_path")
        layout.prop(self, "cache_frames")
        module = module_loader.loaded()
        if module is not None:
            layout.label(text=f"Loaded trilevel {getattr(module, '__version__', '?')} from {module.__file__}", icon='CHECKMARK')
        else:
            try:
                load_module(context)
                layout.label(text=f"trilevel found: {module_loader.loaded().__file__}", icon='CHECKMARK')
            except ImportError as e:
                layout.label(text=str(e), icon='ERROR')


class TrilevelSettings(bpy.types.PropertyGroup):
    enabled: bpy.props.BoolProperty(name="Trilevel surface", default=False)
    cache_id: bpy.props.StringProperty(name="Cache id", default="")
    filepath: bpy.props.StringProperty(
        name="Particles", subtype='FILE_PATH', update=_settings_changed,
        description="Particle file (.vtk, .vtu, .bgeo, .ply, .xyz), or a sequence with {} for the frame number "
                    "(drop_{}.vtk: drop_7.vtk or drop_0007.vtk)")
    radius: bpy.props.FloatProperty(
        name="Radius", default=0.025, min=1e-6, precision=4, step=0.1, update=_settings_changed,
        description="Particle radius r, half the rest spacing of the particles (world units)")
    mode: bpy.props.EnumProperty(
        name="Mode", default='ADAPTIVE', update=_settings_changed,
        items=[('ADAPTIVE', "Adaptive", "Cells of 2r on flat water, r on curved and splashing water"),
               ('UNIFORM', "Uniform", "Cells of the given size everywhere")])
    cell: bpy.props.FloatProperty(
        name="Cell", default=1.0, min=0.25, max=4.0, update=_settings_changed,
        description="Uniform mode: marching-cubes cell size in multiples of r (4/n for an even n up to 64: 2, 1, 0.5, 0.25, ...)")
    normals: bpy.props.EnumProperty(
        name="Normals", default='GRADIENT', update=_settings_changed,
        items=[('NONE', "Faces", "Blender's own normals of the triangles"),
               ('GRADIENT', "Field gradient", "Normal of the smooth surface the mesh approximates (custom normals)"),
               ('AREA', "Area weighted", "Area-weighted triangle normals (custom normals)")])
    attributes: bpy.props.StringProperty(
        name="Attributes", default="", update=_settings_changed,
        description="Particle attributes to interpolate at the vertices, comma separated (e.g. velocity, density); "
                    "each becomes a point attribute of its name; Cycles motion-blurs by `velocity` (units per second)")
    smooth: bpy.props.BoolProperty(
        name="Smooth", default=False, update=_settings_changed,
        description="Smooth the mesh for rendering (needs a trilevel module with the smooth option)")
    smooth_iterations: bpy.props.IntProperty(
        name="Iterations", default=0, min=0, max=1000, update=_settings_changed,
        description="Smoothing iterations; 0 picks the library's default")
    frame_offset: bpy.props.IntProperty(
        name="Frame offset", default=0, update=_settings_changed,
        description="Subtracted from the scene frame to give the file number: frame N shows file N - offset")
    last_error: bpy.props.StringProperty(name="Error", default="")
    shown_file: bpy.props.StringProperty(name="Shown file", default="")


def _report_later(message):
    """Puts `message` into Blender's report area (status bar and Info editor). A handler has no
    operator to report through: a timer runs the report operator once the handler returns."""
    print(f"trilevel: error: {message}", file=sys.stderr)
    if bpy.app.background:
        return

    def report():
        try:
            bpy.ops.trilevel.report('EXEC_DEFAULT', message=message)
        except Exception:  # e.g. no window yet; the panel still shows it
            pass
        return None

    bpy.app.timers.register(report, first_interval=0.0)


def update_object(scene, obj, frame=None):
    """Shows in `obj` the file of the scene frame (`frame`, default the current one). Returns
    the error message, or "" on success; never raises, so a handler keeps running."""
    settings = obj.trilevel
    if not settings.enabled or obj.type != 'MESH':
        return ""
    frame = scene.frame_current if frame is None else frame
    number = frame - settings.frame_offset
    try:
        module = load_module()
        pattern = bpy.path.abspath(settings.filepath)
        if not settings.filepath:
            raise ValueError("no particle file set")
        path = frames.file_for_frame(pattern, number)
        if path is None:  # outside the sequence: an empty mesh, not an error
            surface.fill_mesh(obj.data, None)
            settings.shown_file = ""
            settings.last_error = ""
            return ""
        key = surface.settings_key(settings, module_loader.reconstruct_keywords(module))
        prefs = preferences()
        mesh, _ = surface.cached_frame(cache_key(obj), key, path, settings, module,
                                       prefs.cache_frames if prefs else 100)
        surface.fill_mesh(obj.data, mesh)
        settings.shown_file = path
        settings.last_error = ""
        return ""
    except Exception as e:  # trilevel.Error, OSError, ValueError, ImportError, ...
        message = f"{obj.name}, frame {frame}: {e}"
        if settings.last_error != message:
            _report_later(message)
        settings.last_error = message
        settings.shown_file = ""
        try:
            surface.fill_mesh(obj.data, None)
        except Exception:
            pass
        return message


@persistent
def on_frame_change(scene, depsgraph=None):
    for obj in scene.objects:
        if obj.type == 'MESH' and obj.trilevel.enabled:
            update_object(scene, obj)


class TRILEVEL_OT_add_surface(bpy.types.Operator):
    """Add a mesh object showing the surface of a particle file or {} sequence at the scene frame"""
    bl_idname = "trilevel.add_surface"
    bl_label = "Add Trilevel Surface"
    bl_options = {'REGISTER', 'UNDO'}

    filepath: bpy.props.StringProperty(name="Particles", subtype='FILE_PATH',
                                       description="Particle file, or a sequence with {} for the frame number")
    radius: bpy.props.FloatProperty(name="Radius", default=0.025, min=1e-6, precision=4,
                                    description="Particle radius r (world units)")
    mode: bpy.props.EnumProperty(name="Mode", default='ADAPTIVE',
                                 items=[('ADAPTIVE', "Adaptive", ""), ('UNIFORM', "Uniform", "")])
    normals: bpy.props.EnumProperty(name="Normals", default='GRADIENT',
                                    items=[('NONE', "Faces", ""), ('GRADIENT', "Field gradient", ""),
                                           ('AREA', "Area weighted", "")])
    attributes: bpy.props.StringProperty(name="Attributes", default="",
                                         description="Particle attributes to interpolate, comma separated")
    frame_offset: bpy.props.IntProperty(name="Frame offset", default=0,
                                        description="Frame N shows file N - offset")
    name: bpy.props.StringProperty(name="Name", default="Trilevel Surface")
    sequence: bpy.props.BoolProperty(
        name="Sequence", default=False,
        description="Take the picked file as one frame of a sequence: its last number becomes {}")
    filter_glob: bpy.props.StringProperty(default="*.vtk;*.vtu;*.bgeo;*.ply;*.xyz", options={'HIDDEN'})

    def invoke(self, context, event):
        self.sequence = True  # from the menu: pick one file of the sequence
        context.window_manager.fileselect_add(self)
        return {'RUNNING_MODAL'}

    def execute(self, context):
        if self.sequence:
            self.filepath = frames.sequence_pattern(self.filepath)
        try:
            load_module(context)
        except ImportError as e:
            self.report({'ERROR'}, str(e))
            return {'CANCELLED'}
        pattern = bpy.path.abspath(self.filepath)
        try:
            if not self.filepath:
                raise ValueError("no particle file given (filepath)")
            if frames.is_sequence(pattern):
                if not frames.list_frames(pattern):
                    raise ValueError(f"{pattern}: no frame files match")
            else:
                frames.file_for_frame(pattern, 0)
        except ValueError as e:
            self.report({'ERROR'}, str(e))
            return {'CANCELLED'}
        mesh = bpy.data.meshes.new(self.name)
        obj = bpy.data.objects.new(self.name, mesh)
        settings = obj.trilevel
        settings.cache_id = uuid.uuid4().hex
        settings.filepath = self.filepath
        settings.radius = self.radius
        settings.mode = self.mode
        settings.normals = self.normals
        settings.attributes = self.attributes
        settings.frame_offset = self.frame_offset
        settings.enabled = True
        context.collection.objects.link(obj)
        error = update_object(context.scene, obj)
        if error:
            bpy.data.objects.remove(obj)
            bpy.data.meshes.remove(mesh)
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        for other in context.view_layer.objects:
            other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        return {'FINISHED'}


class _OnActiveSurface:
    """Operators on the active object's surface: available when it is a trilevel surface."""
    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.trilevel.enabled


class TRILEVEL_OT_build_frames(_OnActiveSurface, bpy.types.Operator):
    """Build the meshes of every frame of the scene range into the cache (only the frames not cached)"""
    bl_idname = "trilevel.build_frames"
    bl_label = "Build All Frames"

    def execute(self, context):
        scene, obj = context.scene, context.object
        wm = context.window_manager
        wm.progress_begin(scene.frame_start, scene.frame_end)
        failed = ""
        try:
            for f in range(scene.frame_start, scene.frame_end + 1):
                wm.progress_update(f)
                failed = update_object(scene, obj, f) or failed
        finally:
            wm.progress_end()
        update_object(scene, obj)
        if failed:
            self.report({'ERROR'}, failed)
            return {'CANCELLED'}
        self.report({'INFO'}, f"{surface.cached_count(cache_key(obj))} frames cached")
        return {'FINISHED'}


class TRILEVEL_OT_clear_cache(_OnActiveSurface, bpy.types.Operator):
    """Forget the cached meshes of the active surface and rebuild the shown frame"""
    bl_idname = "trilevel.clear_cache"
    bl_label = "Rebuild"

    def execute(self, context):
        surface.clear_cache(cache_key(context.object))
        error = update_object(context.scene, context.object)
        if error:
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        return {'FINISHED'}


class TRILEVEL_OT_use_sequence(bpy.types.Operator):
    """Show the sequence the particle file belongs to: its last number becomes {}"""
    bl_idname = "trilevel.use_sequence"
    bl_label = "Use Sequence"

    @classmethod
    def poll(cls, context):
        obj = context.object
        return obj is not None and obj.trilevel.enabled and not frames.is_sequence(obj.trilevel.filepath)

    def execute(self, context):
        s = context.object.trilevel
        pattern = frames.sequence_pattern(s.filepath)
        if pattern == s.filepath:
            self.report({'ERROR'}, f"{s.filepath}: no frame number in the file name")
            return {'CANCELLED'}
        s.filepath = pattern
        return {'FINISHED'}


class TRILEVEL_OT_report(bpy.types.Operator):
    """Show a trilevel error in the report area"""
    bl_idname = "trilevel.report"
    bl_label = "Trilevel Report"
    bl_options = {'INTERNAL'}

    message: bpy.props.StringProperty()

    def execute(self, context):
        self.report({'ERROR'}, self.message)
        return {'FINISHED'}


class TRILEVEL_PT_surface(bpy.types.Panel):
    bl_label = "Trilevel Surface"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "Trilevel"

    def draw(self, context):
        layout = self.layout
        obj = context.object
        if obj is None or not obj.trilevel.enabled:
            layout.operator(TRILEVEL_OT_add_surface.bl_idname, icon='MOD_FLUIDSIM')
            layout.label(text="Select a surface to edit its settings")
            return
        s = obj.trilevel
        row = layout.row(align=True)
        row.prop(s, "filepath")
        if not frames.is_sequence(s.filepath):
            row.operator(TRILEVEL_OT_use_sequence.bl_idname, text="", icon='SEQUENCE')
        layout.prop(s, "radius")
        layout.prop(s, "mode")
        if s.mode == 'UNIFORM':
            layout.prop(s, "cell")
        layout.prop(s, "normals")
        layout.prop(s, "attributes")
        keywords = supported_keywords()
        box = layout.column(heading="Smoothing")
        if "smooth" in keywords:
            box.prop(s, "smooth")
            row = box.row()
            row.enabled = s.smooth and "smooth_iterations" in keywords
            row.prop(s, "smooth_iterations")
        else:
            box.label(text="Smoothing: not in this trilevel module")
        layout.prop(s, "frame_offset")
        row = layout.row()
        row.operator(TRILEVEL_OT_build_frames.bl_idname)
        row.operator(TRILEVEL_OT_clear_cache.bl_idname)
        layout.label(text=f"{surface.cached_count(cache_key(obj))} frames cached")
        if s.last_error:
            col = layout.column()
            col.alert = True
            col.label(text=s.last_error, icon='ERROR')
        elif s.shown_file:
            layout.label(text=bpy.path.basename(s.shown_file), icon='FILE')


def menu_add(self, context):
    self.layout.operator(TRILEVEL_OT_add_surface.bl_idname, icon='MOD_FLUIDSIM')


classes = (TrilevelPreferences, TrilevelSettings, TRILEVEL_OT_add_surface, TRILEVEL_OT_build_frames,
           TRILEVEL_OT_clear_cache, TRILEVEL_OT_use_sequence, TRILEVEL_OT_report, TRILEVEL_PT_surface)


def register():
    for c in classes:
        bpy.utils.register_class(c)
    bpy.types.Object.trilevel = bpy.props.PointerProperty(type=TrilevelSettings)
    bpy.types.VIEW3D_MT_add.append(menu_add)
    if on_frame_change not in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.append(on_frame_change)


def unregister():
    if on_frame_change in bpy.app.handlers.frame_change_post:
        bpy.app.handlers.frame_change_post.remove(on_frame_change)
    bpy.types.VIEW3D_MT_add.remove(menu_add)
    del bpy.types.Object.trilevel
    for c in reversed(classes):
        bpy.utils.unregister_class(c)
    surface.clear_cache()
