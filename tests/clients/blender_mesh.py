"""Run by headless Blender: import a .vdb, mesh grid 'surface' at threshold 0, report bounds.
usage: blender --background --factory-startup --python blender_mesh.py -- in.vdb report.json
Also imported by other Blender scripts for mesh_surface()."""
import json
import sys

import bpy


def mesh_surface(path):
    """Import path as a volume object and mesh its 'surface' grid (VOLUME_TO_MESH, threshold
    0): {"grids": names, "vertices": count, "min": [x, y, z], "max": [x, y, z]} (world)."""
    bpy.ops.object.volume_import(filepath=path)
    vol = [o for o in bpy.context.scene.objects if o.type == "VOLUME"][-1]
    vol.data.grids.load()
    grids = [g.name for g in vol.data.grids]
    bpy.ops.mesh.primitive_cube_add()
    obj = bpy.context.active_object
    mod = obj.modifiers.new("v2m", "VOLUME_TO_MESH")
    mod.object = vol
    mod.grid_name = "surface"
    mod.threshold = 0.0
    mod.resolution_mode = "GRID"
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    co = [obj.matrix_world @ v.co for v in mesh.vertices]
    lo = [min(c[a] for c in co) for a in range(3)] if co else [0, 0, 0]
    hi = [max(c[a] for c in co) for a in range(3)] if co else [0, 0, 0]
    return {"grids": grids, "vertices": len(co), "min": lo, "max": hi}


if __name__ == "__main__" and "--" in sys.argv:
    path, report = sys.argv[sys.argv.index("--") + 1:][:2]
    with open(report, "w") as f:
        json.dump(mesh_surface(path), f)
