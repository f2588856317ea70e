"""Run by headless Blender: import a .glb with Blender's own glTF importer and report each
mesh object: triangles, uv range, world z and y range, images and normal-map nodes.
usage: blender -b --factory-startup --python blender_gltf.py -- in.glb report.json
(Shading 'SMOOTH': Blender 3.4's default guess, 'NORMALS', calls np.bool, which Debian 12's
NumPy 1.24 no longer has.)"""
import json
import sys

import bpy

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-2], import_shading="SMOOTH")
out = {}
for o in bpy.context.scene.objects:
    if o.type != "MESH":
        continue
    me = o.data
    me.calc_loop_triangles()
    uv = me.uv_layers.active
    us = [d.uv[0] for d in uv.data]
    vs = [d.uv[1] for d in uv.data]
    co = [o.matrix_world @ v.co for v in me.vertices]
    mat = o.active_material
    imgs = [n.image.name for n in mat.node_tree.nodes if n.type == "TEX_IMAGE" and n.image] if mat else []
    out[o.name] = {"triangles": len(me.loop_triangles), "uv": [min(us), max(us), min(vs), max(vs)],
                   "z": [min(c.z for c in co), max(c.z for c in co)],
                   "y": [min(c.y for c in co), max(c.y for c in co)],
                   "images": imgs,
                   "normal_map_nodes": sum(n.type == "NORMAL_MAP" for n in mat.node_tree.nodes) if mat else 0,
                   "image_size": list(bpy.data.images[imgs[0]].size) if imgs else None}
json.dump(out, open(sys.argv[-1], "w"), indent=1)
