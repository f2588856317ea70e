"""Run by headless Blender: import a .vdb, mesh grid 'surface' at threshold 0, report bounds.
usage: blender --background --factory-startup --python blender_mesh.py -- in.vdb report.json"""
import json
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
path, report = argv[0], argv[1]
bpy.ops.object.volume_import(filepath=path)
vol = [o for o in bpy.context.scene.objects if o.type == "VOLUME"][0]
vol.data.grids.load()
grids = [g.name for g in vol.data.grids]
bpy.ops.mesh.primitive_cube_add()
obj = bpy.context.active_object
mod = obj.modifiers.new("v2m", "VOLUME_TO_MESH")
mod.object = vol
mod.grid_name = "surface"
mod.threshold = 0.0
mod.resolution_mode = "GRID"
deps = bpy.context.evaluated_depsgraph_get()
mesh = obj.evaluated_get(deps).to_mesh()
mw = obj.matrix_world
co = [mw @ v.co for v in mesh.vertices]
lo = [min(c[a] for c in co) for a in range(3)] if co else [0, 0, 0]
hi = [max(c[a] for c in co) for a in range(3)] if co else [0, 0, 0]
with open(report, "w") as f:
    json.dump({"grids": grids, "vertices": len(co), "min": lo, "max": hi}, f)
