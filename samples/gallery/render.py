# SPDX-License-Identifier: Apache-2.0
"""The gallery's renders (docs/gallery.md, issue 38 item 5): each listed .vdb imported in
headless Blender through the add-on's own result builder (its 'surface' meshed by a Volume to
Mesh modifier, tinted by its id grid), lit by a sun and a Nishita sky, rendered with Cycles at
low samples.
usage (from the repository root, after ./rockvdb.sh build):
  BLENDER_USER_SCRIPTS=$PWD/build/blender PYTHONPATH=$PWD/build/python \\
      blender -b --factory-startup --python samples/gallery/render.py -- LIST.json OUT_DIR \\
      [WIDTH HEIGHT SAMPLES]
LIST.json: [{"name": ..., "vdb": path, "azimuth": degrees, "elevation": degrees,
"zoom": z}, ...]; writes OUT_DIR/gallery_<name>.png for each."""
import json
import math
import os
import sys

import addon_utils
import bpy
from mathutils import Vector

args = sys.argv[sys.argv.index("--") + 1:]
LIST, OUT = args[0], args[1]
WIDTH, HEIGHT, SAMPLES = (int(a) for a in (args[2:5] if len(args) >= 5 else (640, 360, 16)))
os.makedirs(OUT, exist_ok=True)
addon_utils.enable("rockvdb_blender", default_set=True)

import pyopenvdb  # noqa: E402  (Debian's Blender runs the system Python, which has it)
from rockvdb_blender import results  # noqa: E402

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = SAMPLES
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
scene.render.resolution_percentage = 100
scene.view_settings.view_transform = "Filmic"
# A sun and the sky it lights (Nishita: the sky's colour follows the sun's elevation).
scene.world = bpy.data.worlds.new("sky")
scene.world.use_nodes = True
nodes, links = scene.world.node_tree.nodes, scene.world.node_tree.links
sky = nodes.new("ShaderNodeTexSky")
sky.sky_type = "NISHITA"
sky.sun_elevation = math.radians(35)
sky.sun_rotation = math.radians(-40)
sky.sun_disc = False
links.new(sky.outputs["Color"], nodes["Background"].inputs["Color"])
nodes["Background"].inputs["Strength"].default_value = 0.08
# The camera sees a plain pale backdrop (the Nishita sky's lower half is black ground); every
# other ray sees the sky.
backdrop = nodes.new("ShaderNodeBackground")
backdrop.inputs["Color"].default_value = (0.62, 0.68, 0.76, 1.0)
backdrop.inputs["Strength"].default_value = 1.0
path = nodes.new("ShaderNodeLightPath")
mix = nodes.new("ShaderNodeMixShader")
links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
links.new(nodes["Background"].outputs["Background"], mix.inputs[1])
links.new(backdrop.outputs["Background"], mix.inputs[2])
links.new(mix.outputs["Shader"], nodes["World Output"].inputs["Surface"])
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 1.6
sun.data.angle = math.radians(2)
sun.rotation_euler = (math.radians(55), 0, math.radians(-40 + 90))
scene.collection.objects.link(sun)
cam = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(cam)
scene.camera = cam


def palette_material(name, attribute, palette):
    """Rock grey with a colour per id ({"id": "#rrggbb"}, ids 0..62): a constant colour ramp."""
    mat = bpy.data.materials.new(name + " palette")
    mat.use_nodes = True
    N, L = mat.node_tree.nodes, mat.node_tree.links
    bsdf = N.get("Principled BSDF")
    bsdf.inputs["Roughness"].default_value = 0.85
    attr = N.new("ShaderNodeAttribute")
    attr.attribute_name = attribute
    scale = N.new("ShaderNodeMath")  # (id + 1) / 64: id 0 clear of the ramp's start
    scale.operation = "MULTIPLY_ADD"
    scale.inputs[1].default_value = 1.0 / 64.0
    scale.inputs[2].default_value = 1.0 / 64.0
    ramp = N.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "CONSTANT"
    els = ramp.color_ramp.elements
    els[0].position, els[0].color = 0.0, (0.30, 0.28, 0.26, 1.0)
    els[1].position, els[1].color = 1.0, (0.30, 0.28, 0.26, 1.0)

    def linear(c):  # sRGB hex to linear
        c = int(c, 16) / 255.0
        return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4
    for key, hexa in palette.items():
        e = els.new((int(key) + 0.5) / 64.0)
        e.color = (linear(hexa[1:3]), linear(hexa[3:5]), linear(hexa[5:7]), 1.0)
        after = els.new((int(key) + 1.5) / 64.0)
        after.color = (0.30, 0.28, 0.26, 1.0)
    L.new(attr.outputs["Fac"], scale.inputs[0])
    L.new(scale.outputs[0], ramp.inputs["Fac"])
    L.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def render(entry):
    """Import entry's .vdb as the add-on does, frame it from its bounds and render it."""
    for o in list(bpy.data.objects):
        if o.get("rockvdb_stage") or o.name.endswith((" grids", " ids")):
            bpy.data.objects.remove(o)
    grids = pyopenvdb.readAll(entry["vdb"])[0]
    path = os.path.join(OUT, f".gallery_{entry['name']}.vdb")
    prepared = results.prepare(grids, path, results.mesh_adaptivity("FINAL"))
    obj = results.build(bpy.context, "gallery", entry["name"], prepared, {})
    if entry.get("palette") and obj.get("rockvdb_ids"):
        obj.data.materials[0] = palette_material(entry["name"], obj["rockvdb_ids"][0], entry["palette"])
    me = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    if len(me.vertices) == 0:
        raise SystemExit(f"gallery: {entry['vdb']} meshed to nothing")
    pts = [obj.matrix_world @ v.co for v in me.vertices]
    lo = Vector([min(p[i] for p in pts) for i in range(3)])
    hi = Vector([max(p[i] for p in pts) for i in range(3)])
    centre, radius = (lo + hi) / 2, (hi - lo).length / 2
    a, e = math.radians(entry.get("azimuth", -40)), math.radians(entry.get("elevation", 28))
    d = Vector((math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)))
    cam.location = centre + d * radius * 2.4 / entry.get("zoom", 1.0)
    cam.rotation_euler = (-d).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 40
    cam.data.clip_end = radius * 10
    scene.render.filepath = os.path.join(OUT, f"gallery_{entry['name']}.png")
    bpy.ops.render.render(write_still=True)
    os.remove(path)
    print("rendered", scene.render.filepath, len(me.vertices), "vertices")


for entry in json.load(open(LIST)):
    render(entry)
