# SPDX-License-Identifier: Apache-2.0
"""docs/blender.md's pictures: each rockvdb operator run in headless Blender as an artist would
(the same operators, mostly at their defaults) and its result rendered with Cycles (low
samples), tinted by the add-on's own material.
usage (from the repository root, after ./rockvdb.sh build):
  BLENDER_USER_SCRIPTS=$PWD/build/blender PYTHONPATH=$PWD/build/python \\
      blender -b --factory-startup --python samples/blender/screenshots.py -- OUT_DIR"""
import math
import os
import sys

import addon_utils
import bpy
from mathutils import Vector

OUT = sys.argv[sys.argv.index("--") + 1]
SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "arches_strata.json")
os.makedirs(OUT, exist_ok=True)
addon_utils.enable("rockvdb_blender", default_set=True)

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.samples = 24
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = 480, 300
scene.world = bpy.data.worlds.new("sky")
scene.world.use_nodes = True
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.55, 0.6, 0.68, 1)
scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.35
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 2.5
sun.rotation_euler = (math.radians(40), math.radians(10), math.radians(-35))
scene.collection.objects.link(sun)
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
scene.camera = cam


def none_active():
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None


def shoot(name, obj, azimuth=-40, elevation=28, also=()):
    """Render @a obj alone (with the meshes @a also), framed from its bounds."""
    for o in scene.objects:
        if o.get("rockvdb_stage") or (o.type == "MESH" and o.parent is None):
            o.hide_render = o is not obj and o not in also
    me = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    pts = [obj.matrix_world @ v.co for v in me.vertices]
    lo = Vector([min(p[i] for p in pts) for i in range(3)])
    hi = Vector([max(p[i] for p in pts) for i in range(3)])
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    a, e = math.radians(azimuth), math.radians(elevation)
    d = Vector((math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)))
    cam.location = centre + d * radius * 2.6
    cam.rotation_euler = (-d).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 40
    scene.render.filepath = os.path.join(OUT, f"blender_{name}.png")
    bpy.ops.render.render(write_still=True)
    print("rendered", scene.render.filepath)


none_active()
bpy.ops.rockvdb.fractal_rock(levels=3, seed=3)
rock = bpy.context.active_object
shoot("fractal_rock", rock)

bpy.context.view_layer.objects.active = rock
bpy.ops.rockvdb.detail(warp_amplitude=0.02, gabor_amplitude=0.012, gabor_frequency=12,
                       direction_axis=(0, 0, 1), use_direction_axis=True)
shoot("detail", bpy.context.active_object)

none_active()
bpy.ops.rockvdb.block_tile(tile_size=8, voxel_size=0.08, seed=1)
tile = bpy.context.active_object
shoot("block_tile", tile)

bpy.ops.mesh.primitive_uv_sphere_add(radius=2.0, location=(0, 0, 0))
bpy.ops.rockvdb.rock_pile(tiles_cube_size=1.2)
shoot("rock_pile", bpy.context.active_object)

bpy.ops.mesh.primitive_grid_add(size=12, x_subdivisions=24, y_subdivisions=24, location=(7, 7, 0))
sheet = bpy.context.active_object
for v in sheet.data.vertices:
    v.co.z = 2.5 * math.exp(-((v.co.x - 1) ** 2 + v.co.y ** 2) / 6.0) + 0.1 * math.sin(v.co.x * 2)
bpy.ops.rockvdb.fractal_scatter(count=14, size=(1.6, 1.2, 0.8), voxel_size=0.04, seed=4)
shoot("fractal_scatter", bpy.context.active_object, elevation=35, also=[sheet])

bpy.context.view_layer.objects.active = sheet
bpy.ops.rockvdb.amplify(tiles=tile.name, voxel_size=0.08, max_slope=0.9)
shoot("amplify", bpy.context.active_object, elevation=32)

none_active()
bpy.ops.rockvdb.stacks(scene=SCENE)
shoot("stacks", bpy.context.active_object, elevation=35)

# One contact sheet for docs/blender.md (Pillow, when this Python has it).
try:
    from PIL import Image
except ImportError:
    Image = None
if Image is not None:
    names = ["fractal_rock", "detail", "block_tile", "rock_pile", "fractal_scatter", "amplify",
             "stacks"]
    shots = [Image.open(os.path.join(OUT, f"blender_{n}.png")).convert("RGB") for n in names]
    w, h = shots[0].size
    sheet = Image.new("RGB", (4 * w, 2 * h), (255, 255, 255))
    for i, im in enumerate(shots):
        sheet.paste(im, ((i % 4) * w, (i // 4) * h))
    sheet = sheet.resize((3 * w, 3 * h // 2), Image.LANCZOS)
    sheet.quantize(colors=255, dither=Image.Dither.NONE).save(
        os.path.join(OUT, "blender_operators.png"), optimize=True)
