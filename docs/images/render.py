"""Renders one trilevel mesh with Blender's Cycles on the CPU (headless).

  blender -b --factory-startup --python-exit-code 1 --python docs/images/render.py -- MESH.ply OUT.png [options]

One camera, a sun and a grey sky, a grey floor at height 0, smooth shading. Meshes are in the
project's y-up world units and are turned to Blender's z-up; the camera is given in the mesh's own
coordinates (--target, --azimuth about the y axis, --elevation above the y = const plane,
--distance), so every picture of one scene can share it. Styles:

  water   one light blue material;
  levels  the PLY's vertex colours (`trilevel reconstruct ... --color-levels`: green = level 2,
          blue = level 3) mapped to a softer green and blue.

Cycles runs on the CPU with --samples samples per pixel and no denoiser (Debian's Blender has
none), so keep the resolution modest. docs/images/make_images.sh builds the meshes and calls this.
"""

import argparse
import math
import os
import sys

import bpy
from mathutils import Vector


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="render.py", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mesh", help="PLY mesh (y up)")
    ap.add_argument("out", help="output image (.png or .jpg)")
    ap.add_argument("--style", choices=("water", "levels"), default="water")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--height", type=int, default=400)
    ap.add_argument("--samples", type=int, default=32, help="Cycles samples per pixel")
    ap.add_argument("--threads", type=int, default=0, help="render threads (0 = every core)")
    ap.add_argument("--target", default="0,0.4,0", help="x,y,z the camera looks at (mesh coordinates)")
    ap.add_argument("--azimuth", type=float, default=-30.0, help="degrees about the y axis, 0 = from +z")
    ap.add_argument("--elevation", type=float, default=28.0, help="degrees above the horizontal")
    ap.add_argument("--distance", type=float, default=6.0, help="camera distance from the target")
    ap.add_argument("--lens", type=float, default=35.0, help="focal length in mm (36 mm sensor)")
    ap.add_argument("--floor", type=float, default=0.0, help="floor height y (mesh coordinates)")
    return ap.parse_args(argv)


def to_blender(p):
    """Mesh coordinates (y up) to Blender's (z up): a +90 degree turn about x."""
    x, y, z = p
    return Vector((x, -z, y))


def clear_scene():
    bpy.ops.object.select_all(action="SELECT")
    bpy.ops.object.delete()
    for block in (bpy.data.meshes, bpy.data.materials, bpy.data.lights, bpy.data.cameras):
        for item in list(block):
            block.remove(item)


def water_material():
    mat = bpy.data.materials.new("water")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.10, 0.32, 0.70, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.25
    bsdf.inputs["Specular"].default_value = 0.5
    return mat


def levels_material():
    """Vertex colour green (level 2) / blue (level 3) mapped to two softer tones by the blue channel
    (0 on level-2 vertices, 1 on level-3 ones; trilevel writes (0,170,0) and (20,90,255))."""
    mat = bpy.data.materials.new("levels")
    mat.use_nodes = True
    nt = mat.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 0.4
    bsdf.inputs["Specular"].default_value = 0.3
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "Col"
    sep = nt.nodes.new("ShaderNodeSeparateColor")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.20, 0.60, 0.15, 1.0)  # level 2: green
    ramp.color_ramp.elements[1].color = (0.06, 0.20, 0.85, 1.0)  # level 3: blue
    nt.links.new(attr.outputs["Color"], sep.inputs["Color"])
    nt.links.new(sep.outputs["Blue"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def main():
    args = parse_args()
    if not os.path.isfile(args.mesh):
        sys.exit(f"render.py: error: no mesh at {args.mesh}")
    clear_scene()
    scene = bpy.context.scene

    bpy.ops.import_mesh.ply(filepath=args.mesh)
    obj = bpy.context.selected_objects[0]
    obj.rotation_euler = (math.radians(90.0), 0.0, 0.0)  # y up -> z up
    for poly in obj.data.polygons:
        poly.use_smooth = True
    if args.style == "levels":
        if not obj.data.vertex_colors:
            sys.exit(f"render.py: error: {args.mesh} has no vertex colours (use --color-levels)")
        obj.data.materials.append(levels_material())
    else:
        obj.data.materials.append(water_material())

    # Floor: a large grey plane just under the fluid's lowest height.
    bpy.ops.mesh.primitive_plane_add(size=200.0, location=(0.0, 0.0, args.floor - 1e-3))
    floor = bpy.context.active_object
    fmat = bpy.data.materials.new("floor")
    fmat.use_nodes = True
    fmat.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = (0.55, 0.55, 0.55, 1.0)
    fmat.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.8
    floor.data.materials.append(fmat)

    # Camera on a sphere around the target.
    tx, ty, tz = (float(v) for v in args.target.split(","))
    az, el = math.radians(args.azimuth), math.radians(args.elevation)
    eye = (tx + args.distance * math.cos(el) * math.sin(az), ty + args.distance * math.sin(el),
           tz + args.distance * math.cos(el) * math.cos(az))
    cam_data = bpy.data.cameras.new("camera")
    cam_data.lens = args.lens
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = to_blender(eye)
    cam.rotation_euler = (to_blender((tx, ty, tz)) - cam.location).to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam

    # Light: one sun from the camera's left and above, plus a soft grey-blue sky.
    sun_data = bpy.data.lights.new("sun", type="SUN")
    sun_data.energy = 3.5
    sun_data.angle = math.radians(8.0)
    sun = bpy.data.objects.new("sun", sun_data)
    scene.collection.objects.link(sun)
    sun.rotation_euler = (math.radians(40.0), 0.0, math.radians(args.azimuth - 50.0))
    world = bpy.data.worlds.new("sky") if scene.world is None else scene.world
    scene.world = world
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.75, 0.80, 0.88, 1.0)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.8

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = args.samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 4
    scene.cycles.seed = 1
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.look = "Medium High Contrast"
    if args.threads > 0:
        scene.render.threads_mode = "FIXED"
        scene.render.threads = args.threads
    scene.render.resolution_x = args.width
    scene.render.resolution_y = args.height
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    fmt = scene.render.image_settings
    if args.out.lower().endswith((".jpg", ".jpeg")):
        fmt.file_format = "JPEG"
        fmt.quality = 88
    else:
        fmt.file_format = "PNG"
        fmt.color_mode = "RGB"
        fmt.compression = 100
    scene.render.filepath = args.out
    bpy.ops.render.render(write_still=True)
    print(f"render.py: wrote {args.out} ({args.width}x{args.height}, {args.samples} samples)")


if __name__ == "__main__":
    main()
