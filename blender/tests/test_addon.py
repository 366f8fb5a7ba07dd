"""Headless test of the Blender add-on in a real Blender, against the trilevel CLI.

Two ways to run it (both exit non-zero on failure):
  blender -b --factory-startup --python-exit-code 1 --python blender/tests/test_addon.py -- \\
      --cli build/bin/trilevel --module-dir build/python --work /tmp/addon_test
  python3.11 blender/tests/test_addon.py --cli ... --module-dir ... --work ...   # the `bpy` wheel

It enables the add-on from the repository's blender/ directory, writes a 6-frame falling-drop
sequence with the CLI (PLY particles with a velocity attribute), adds a surface for it with
bpy.ops.trilevel.add_surface, steps the scene frames and checks each frame's mesh against the
CLI's mesh of that file alone (`trilevel reconstruct d_000N.ply ...`: the add-on reconstructs
every frame on its own, see trilevel_blender/surface.py): the same triangles and vertices bit
for bit, closed and consistently oriented, the `level` colour and `velocity` point attributes of
the vertex count; then the cache (no rebuild when frames come back), the frame offset, and
errors (a bad path and a bad file give reports, not crashes; a handler keeps going).
"""
import argparse
import os
import shutil
import subprocess
import sys
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
R = 0.025
FRAMES = 6


def arguments():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    p = argparse.ArgumentParser()
    p.add_argument("--cli", required=True, help="the trilevel binary")
    p.add_argument("--module-dir", default="", help="directory of the trilevel module, set as the add-on's "
                                                      "preference (else TRILEVEL_PYTHON_PATH or Blender's Python)")
    p.add_argument("--work", required=True, help="scratch directory (emptied)")
    return p.parse_args(argv)


def check(condition, message):
    if not condition:
        raise AssertionError(message)


def run(*command):
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)


def write_ply_with_velocity(path, positions, velocity):
    import numpy as np
    n = len(positions)
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n"
            "property float z\nproperty float velocity_x\nproperty float velocity_y\nproperty float velocity_z\n"
            "end_header\n")
    body = np.hstack([positions, velocity]).astype("<f4")
    with open(path, "wb") as f:
        f.write(head.encode())
        f.write(body.tobytes())


def blender_mesh(obj):
    """(vertices (m, 3) float32, triangles (k, 3) int32) of the object's mesh, as stored."""
    import numpy as np
    mesh = obj.data
    v = np.empty(3 * len(mesh.vertices), dtype=np.float32)
    mesh.vertices.foreach_get("co", v)
    totals = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", totals)
    check(bool((totals == 3).all()), "a polygon is not a triangle")
    starts = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_start", starts)
    loops = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", loops)
    t = loops[(starts[:, None] + np.arange(3)[None, :]).ravel()].reshape(-1, 3)
    return v.reshape(-1, 3), t


def check_closed(vertices, triangles, what):
    """Every directed edge once, and its reverse once (closed, consistently oriented)."""
    import numpy as np
    n = np.int64(len(vertices))
    t = triangles.astype(np.int64)
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    edges, reverse = a * n + b, b * n + a
    check(len(np.unique(edges)) == len(edges), f"{what}: a directed edge is used twice")
    check(np.array_equal(np.sort(edges), np.sort(reverse)), f"{what}: an edge has no opposite edge")


def attribute_values(mesh, name, kind):
    import numpy as np
    a = mesh.attributes.get(name) if kind != "color" else mesh.color_attributes.get(name)
    check(a is not None, f"no attribute '{name}'")
    width = {"value": 1, "vector": 3, "color": 4}[kind]
    out = np.empty(width * len(a.data), dtype=np.float32)
    a.data.foreach_get(kind, out)
    return a, out.reshape(len(a.data), width) if width > 1 else out


def main():
    args = arguments()
    sys.path.insert(0, os.path.dirname(HERE))  # the repository's blender/: the add-on package
    import bpy  # first: the bpy wheel puts Blender's own modules (addon_utils) on sys.path
    import addon_utils
    import numpy as np

    print(f"Blender {bpy.app.version_string}, Python {sys.version.split()[0]}, numpy {np.__version__}")
    mod = addon_utils.enable("trilevel_blender", default_set=True, handle_error=None)
    check(mod is not None, "the add-on did not enable")
    from trilevel_blender import module_loader, surface, ui
    if args.module_dir:  # the add-on preference a user sets (else TRILEVEL_PYTHON_PATH, Blender's Python)
        bpy.context.preferences.addons["trilevel_blender"].preferences.python_path = os.path.abspath(args.module_dir)
    trilevel = ui.load_module()  # as the add-on finds it
    print(f"trilevel {trilevel.__version__} from {trilevel.__file__}")

    work = os.path.abspath(args.work)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    run(args.cli, "generate", "falling-drop", "-o", os.path.join(work, "d_{}.xyz"), "--radius", str(R),
        "--frames", str(FRAMES))
    positions = [trilevel.read_particles(os.path.join(work, f"d_{f:04d}.xyz")) for f in range(FRAMES)]
    fps = 24.0
    for f in range(FRAMES):  # velocity by finite differences (the generator writes positions only)
        g = min(f + 1, FRAMES - 1)
        h = g - 1
        write_ply_with_velocity(os.path.join(work, f"d_{f:04d}.ply"), positions[f], (positions[g] - positions[h]) * fps)
    expected = []
    for f in range(FRAMES):
        out = os.path.join(work, f"cli_{f:04d}.ply")
        run(args.cli, "reconstruct", os.path.join(work, f"d_{f:04d}.ply"), "-o", out, "--radius", str(R),
            "--normals", "gradient", "--attribute", "velocity", "-q")
        expected.append(trilevel.read_mesh(out, return_normals=True, return_attributes=True))
    # For the record: the CLI's sequence mode holds levels across frames (--level-hysteresis 0.2).
    run(args.cli, "reconstruct", os.path.join(work, "d_{}.ply"), "-o", os.path.join(work, "seq_{}.ply"),
        "--radius", str(R), "-q")
    seq = [len(trilevel.read_mesh(os.path.join(work, f"seq_{f:04d}.ply"))[1]) for f in range(FRAMES)]
    print("CLI triangles per frame, each file alone:", [len(e[1]) for e in expected])
    print("CLI triangles per frame, as a sequence (hysteresis 0.2):", seq)

    builds = []
    original = surface.reconstruct_file

    def counting(module, path, settings):
        builds.append(os.path.basename(path))
        return original(module, path, settings)

    surface.reconstruct_file = counting

    scene = bpy.context.scene
    scene.frame_set(0)
    objects_before = len(bpy.data.objects)
    result = bpy.ops.trilevel.add_surface(filepath=os.path.join(work, "d_{}.ply"), radius=R, attributes="velocity")
    check(result == {'FINISHED'}, f"add_surface returned {result}")
    check(len(bpy.data.objects) == objects_before + 1, "add_surface did not add one object")
    obj = bpy.context.view_layer.objects.active
    check(obj is not None and obj.trilevel.enabled, "the new surface is not the active object")

    for f in range(FRAMES):
        scene.frame_set(f)
        ev, et, en, ea = expected[f]
        v, t = blender_mesh(obj)
        what = f"frame {f}"
        check(obj.trilevel.last_error == "", f"{what}: {obj.trilevel.last_error}")
        check(len(t) == len(et), f"{what}: {len(t)} triangles, the CLI has {len(et)}")
        check(np.array_equal(v.view(np.uint32), ev.view(np.uint32)), f"{what}: vertices differ from the CLI's")
        check(np.array_equal(t, et.astype(np.int32)), f"{what}: triangles differ from the CLI's")
        check_closed(v, t, what)
        check(len(obj.data.edges) * 2 == 3 * len(t), f"{what}: {len(obj.data.edges)} edges for {len(t)} triangles")
        level, colours = attribute_values(obj.data, "level", "color")
        check((level.domain, len(colours)) == ('POINT', len(v)), f"{what}: level colours {level.domain} {len(colours)}")
        check(bool(np.isin(colours[:, 2], [0.0, 1.0]).all()), f"{what}: level colours are not those of levels 2 and 3")
        velocity, values = attribute_values(obj.data, "velocity", "vector")
        check((velocity.domain, velocity.data_type, len(values)) == ('POINT', 'FLOAT_VECTOR', len(v)),
              f"{what}: velocity attribute {velocity.domain} {velocity.data_type} {len(values)}")
        check(np.array_equal(values, ea["velocity"]), f"{what}: velocity differs from the CLI's")
        print(f"{what}: {len(t)} triangles, {len(v)} vertices, closed, level colours and velocity match the CLI")
    check(builds == [f"d_{f:04d}.ply" for f in range(FRAMES)], f"builds {builds}")

    # Back through the timeline: every frame comes from the cache.
    for f in reversed(range(FRAMES)):
        scene.frame_set(f)
        check(len(blender_mesh(obj)[1]) == len(expected[f][1]), f"cached frame {f}: wrong mesh")
    check(len(builds) == FRAMES, f"cached frames were rebuilt: {builds[FRAMES:]}")
    check(surface.cached_count(ui.cache_key(obj)) == FRAMES, "cache size")
    print(f"cache: {FRAMES} frames built once, revisited without rebuilding")
    # Rebuild drops the cache and builds the shown frame; Build All Frames fills the scene range.
    check(bpy.ops.trilevel.clear_cache() == {'FINISHED'}, "clear_cache")
    check(surface.cached_count(ui.cache_key(obj)) == 1 and len(builds) == FRAMES + 1, "Rebuild did not rebuild")
    scene.frame_start, scene.frame_end = 0, FRAMES + 2  # two frames past the files: empty meshes
    check(bpy.ops.trilevel.build_frames() == {'FINISHED'}, "build_frames")
    check(surface.cached_count(ui.cache_key(obj)) == FRAMES and len(builds) == 2 * FRAMES,
          f"Build All Frames: {surface.cached_count(ui.cache_key(obj))} cached, {len(builds)} builds")
    del builds[FRAMES:]

    # Frame offset: scene frame N shows file N - offset; frames outside the files give an empty mesh.
    obj.trilevel.frame_offset = 10
    scene.frame_set(13)
    check(np.array_equal(blender_mesh(obj)[1], expected[3][1].astype(np.int32)), "offset 10, frame 13: not file 3")
    scene.frame_set(2)
    check(len(obj.data.polygons) == 0 and obj.trilevel.last_error == "", "frame before the first file: not empty")
    check(len(builds) == FRAMES, "the offset rebuilt cached files")
    obj.trilevel.frame_offset = 0
    # A setting that changes the mesh drops the cache.
    obj.trilevel.normals = 'AREA'  # rebuilds the shown frame (2) at once
    check(builds[FRAMES:] == ["d_0002.ply"], f"a changed setting did not rebuild the shown frame: {builds[FRAMES:]}")
    print("frame offset and settings: ok")

    # Errors: a report, no object, no crash.
    objects_before = len(bpy.data.objects)
    for pattern, words in [(os.path.join(work, "missing", "x_{}.ply"), "does not exist"),
                           (os.path.join(work, "none_{}.ply"), "no frame files match"),
                           (os.path.join(work, "missing.ply"), "no such file")]:
        try:
            bpy.ops.trilevel.add_surface(filepath=pattern, radius=R)
            raise AssertionError(f"{pattern}: add_surface did not fail")
        except RuntimeError as e:  # how bpy.ops hands an operator's ERROR report to Python
            check(words in str(e), f"{pattern}: report '{e}' does not say '{words}'")
            print(f"reported: {str(e).strip()}")
    with open(os.path.join(work, "bad_0000.ply"), "wb") as f:
        f.write(b"ply\nformat binary_little_endian 1.0\nelement vertex 5\nproperty float x\nend_header\n")
    scene.frame_set(0)  # the frame of the broken file: add_surface builds the shown frame
    try:
        bpy.ops.trilevel.add_surface(filepath=os.path.join(work, "bad_{}.ply"), radius=R)
        raise AssertionError("a broken particle file did not fail")
    except RuntimeError as e:
        check("bad_0000.ply" in str(e), f"the report does not name the file: {e}")
        print(f"reported: {str(e).strip()}")
    check(len(bpy.data.objects) == objects_before, "a failed add_surface left an object")
    # One file picked as a sequence (as the menu's file browser does): its number becomes {}.
    scene.frame_set(5)
    check(bpy.ops.trilevel.add_surface(filepath=os.path.join(work, "d_0002.ply"), radius=R, sequence=True,
                                       name="Picked") == {'FINISHED'}, "add_surface of a picked frame")
    picked = bpy.data.objects["Picked"]
    check(picked.trilevel.filepath == os.path.join(work, "d_{}.ply"), f"picked pattern {picked.trilevel.filepath}")
    check(len(picked.data.polygons) == len(expected[5][1]), "the picked sequence does not show frame 5")
    bpy.data.objects.remove(picked)
    objects_before = len(bpy.data.objects)
    # In the handler: the error is kept on the object, the mesh emptied, the next good frame shown.
    obj.trilevel.filepath = os.path.join(work, "bad_{}.ply")
    scene.frame_set(0)
    check("bad_0000.ply" in obj.trilevel.last_error and len(obj.data.polygons) == 0,
          f"handler error not recorded: '{obj.trilevel.last_error}'")
    obj.trilevel.filepath = os.path.join(work, "d_{}.ply")
    scene.frame_set(4)
    check(obj.trilevel.last_error == "" and len(obj.data.polygons) == len(expected[4][1]), "no recovery after an error")
    print("errors: reported, no object left, the handler recovers")

    # Smoothing reaches reconstruct only where the module's signature has it.
    keywords = module_loader.reconstruct_keywords(trilevel)
    print("smoothing in this module:", "smooth" in keywords)
    obj.trilevel.smooth = True
    obj.trilevel.smooth_iterations = 7
    if "smooth" not in keywords:
        check(obj.trilevel.last_error == "", f"smooth without module support: {obj.trilevel.last_error}")

    class FakeReconstructor:
        calls = []

        def reconstruct(self, positions, particle_radius, **kwargs):
            FakeReconstructor.calls.append(kwargs)
            return trilevel.Reconstructor().reconstruct(positions, particle_radius, **{
                k: v for k, v in kwargs.items() if k not in ("smooth", "smooth_iterations")})

        def reset_history(self):
            pass

    FakeReconstructor.reconstruct.__doc__ = (
        "reconstruct(self: trilevel.Reconstructor, positions: numpy.ndarray[numpy.float32], particle_radius: float, "
        "*, mode: str = 'adaptive', normals: Optional[str] = None, attributes: Optional[dict] = None, "
        "smooth: bool = False, smooth_iterations: int = 0, return_levels: bool = False) -> tuple\n\nDoc.")

    class FakeModule:
        Reconstructor = FakeReconstructor
        read_particles = staticmethod(trilevel.read_particles)

    surface.reconstruct_file(FakeModule, os.path.join(work, "d_0001.ply"), obj.trilevel)
    call = FakeReconstructor.calls[-1]
    check((call.get("smooth"), call.get("smooth_iterations")) == (True, 7), f"smoothing not passed: {call}")
    obj.trilevel.smooth = False
    surface.reconstruct_file(FakeModule, os.path.join(work, "d_0001.ply"), obj.trilevel)
    check("smooth" not in FakeReconstructor.calls[-1], "smoothing passed while off")
    print("smoothing: passed on (smooth=True, smooth_iterations=7) to a module whose signature has it")
    addon_utils.disable("trilevel_blender", default_set=True)
    print("PASSED")


if __name__ == "__main__":
    try:
        main()
    except BaseException:
        traceback.print_exc()
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(1)  # Blender would otherwise return 0 after a failing --python script
