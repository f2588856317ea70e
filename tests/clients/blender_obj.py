# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: import an OBJ with Blender's own importer (default axes: forward
-Z, up Y), report its vertex and face counts, UV layers, custom normals, world bounds, the share of
smooth-shaded faces and the vertex count of Blender's glTF export of it.
usage: blender --background --factory-startup --python blender_obj.py -- in.obj report.json
Also imported by the other OBJ scripts for import_obj()."""
import json
import sys

import bpy


def import_obj(path):
    """An empty scene, then @a path through Blender's own OBJ importer (default axes): the
    imported mesh objects (one per OBJ object)."""
    for o in list(bpy.context.scene.objects):
        bpy.data.objects.remove(o)
    bpy.ops.wm.obj_import(filepath=path)
    return [o for o in bpy.context.scene.objects if o.type == "MESH"]


if __name__ == "__main__" and "--" in sys.argv:
    path, report = sys.argv[sys.argv.index("--") + 1:][:2]
    obj = import_obj(path)[-1]
    me = obj.data
    co = [obj.matrix_world @ v.co for v in me.vertices]
    r = {"vertices": len(me.vertices), "faces": len(me.polygons),
         "uv_layers": [l.name for l in me.uv_layers],
         "custom_normals": bool(me.has_custom_normals),
         "min": [min(c[a] for c in co) for a in range(3)],
         "max": [max(c[a] for c in co) for a in range(3)],
         "smooth": sum(p.use_smooth for p in me.polygons) / max(1, len(me.polygons))}
    # What a game engine gets: Blender's glTF export of it, its vertex count (flat faces
    # would split every vertex per face).
    import struct
    glb = report + ".glb"
    bpy.ops.export_scene.gltf(filepath=glb, export_format="GLB")
    data = open(glb, "rb").read()
    n = struct.unpack("<I", data[12:16])[0]
    gltf = json.loads(data[20:20 + n])
    r["gltf_vertices"] = sum(gltf["accessors"][p["attributes"]["POSITION"]]["count"]
                             for m in gltf["meshes"] for p in m["primitives"])
    with open(report, "w") as f:
        json.dump(r, f)
