# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: import a .vdb, mesh grid 'surface' at threshold 0, report bounds,
its Euler characteristic and, for each x,y given, how many times the vertical line there crosses the mesh.
usage: blender --background --factory-startup --python blender_mesh.py -- in.vdb report.json [x,y ...]
Also imported by other Blender scripts for mesh_surface()."""
import json
import sys

import bpy


def crossings(mesh, matrix, x, y):
    """Faces of mesh (world: matrix) that the vertical line through (x, y) passes through."""
    n = 0
    for poly in mesh.polygons:
        pts = [matrix @ mesh.vertices[i].co for i in poly.vertices]
        for k in range(1, len(pts) - 1):  # fan triangles
            a, b, c = pts[0], pts[k], pts[k + 1]
            d1 = (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x)
            d2 = (c.x - b.x) * (y - b.y) - (c.y - b.y) * (x - b.x)
            d3 = (a.x - c.x) * (y - c.y) - (a.y - c.y) * (x - c.x)
            if (d1 > 0 and d2 > 0 and d3 > 0) or (d1 < 0 and d2 < 0 and d3 < 0):
                n += 1
    return n


def mesh_surface(path, columns=()):
    """Import path as a volume object and mesh its 'surface' grid (VOLUME_TO_MESH, threshold
    0): {"grids": names, "vertices": count, "min": [x, y, z], "max": [x, y, z]} (world),
    "euler": V - E + F of the mesh (2 for a sphere's topology, 0 for a torus'), and
    "crossings": the mesh's crossings of the vertical line through each (x, y) of columns."""
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
    euler = len(mesh.vertices) - len(mesh.edges) + len(mesh.polygons)
    return {"grids": grids, "vertices": len(co), "min": lo, "max": hi, "euler": euler,
            "crossings": [crossings(mesh, obj.matrix_world, x, y) for x, y in columns]}


if __name__ == "__main__" and "--" in sys.argv:
    args = sys.argv[sys.argv.index("--") + 1:]
    path, report = args[:2]
    columns = [tuple(float(v) for v in c.split(",")) for c in args[2:]]
    with open(report, "w") as f:
        json.dump(mesh_surface(path, columns), f)
