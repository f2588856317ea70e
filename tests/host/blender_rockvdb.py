"""Run by headless Blender: rockvdb's Python inside a host that loaded OpenVDB itself. Every
grid call of host_calls.py, then the written .vdb imported as a volume object and its
'surface' meshed, all in this one Blender process.
usage: blender -b --factory-startup --python blender_rockvdb.py -- PYTHONPATH_DIR OUT_DIR"""
import json
import os
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
sys.path[:0] = [argv[0], os.path.dirname(os.path.abspath(__file__))]
out = argv[1]

import host_calls  # noqa: E402  (needs the paths above)

report = host_calls.run(out)
bpy.ops.object.volume_import(filepath=os.path.join(out, "host.vdb"))
vol = [o for o in bpy.context.scene.objects if o.type == "VOLUME"][0]
vol.data.grids.load()
report["blender_grids"] = sorted(g.name for g in vol.data.grids)
bpy.ops.mesh.primitive_cube_add()
obj = bpy.context.active_object
mod = obj.modifiers.new("v2m", "VOLUME_TO_MESH")
mod.object = vol
mod.grid_name = "surface"
mod.threshold = 0.0
mod.resolution_mode = "GRID"
mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
co = [obj.matrix_world @ v.co for v in mesh.vertices]
report["blender_vertices"] = len(co)
report["blender_min"] = [min(c[a] for c in co) for a in range(3)] if co else None
report["blender_max"] = [max(c[a] for c in co) for a in range(3)] if co else None
with open(os.path.join(out, "host.json"), "w") as f:
    json.dump(report, f)
