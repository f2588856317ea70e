# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: import a .glb with Blender's own glTF importer and report each
mesh object: triangles, uv range, world z and y range, images, normal-map nodes, whether its
material's occlusion reaches Blender (the importer keeps glTF occlusion in a 'glTF Settings'
group or 'glTF Material Output' node) and its custom properties (glTF extras).
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
    us = [d.uv[0] for d in uv.data] if uv else [0.0]
    vs = [d.uv[1] for d in uv.data] if uv else [0.0]
    co = [o.matrix_world @ v.co for v in me.vertices]
    mat = o.active_material
    nodes = mat.node_tree.nodes if mat and mat.node_tree else []
    imgs = sorted(n.image.name for n in nodes if n.type == "TEX_IMAGE" and n.image)
    occlusion_sockets = [s for n in nodes if n.type == "GROUP" for s in n.inputs
                         if s.name == "Occlusion" and s.is_linked]
    out[o.name] = {"triangles": len(me.loop_triangles), "vertices": len(me.vertices),
                   "uv_layers": len(me.uv_layers),
                   "uv": [min(us), max(us), min(vs), max(vs)],
                   "z": [min(c.z for c in co), max(c.z for c in co)],
                   "y": [min(c.y for c in co), max(c.y for c in co)],
                   "images": imgs,
                   "image_sizes": {i: list(bpy.data.images[i].size) for i in imgs},
                   "normal_map_nodes": sum(n.type == "NORMAL_MAP" for n in nodes),
                   "occlusion_linked": len(occlusion_sockets),
                   "material": mat.name if mat else None,
                   "custom": {k: str(o[k]) for k in o.keys() if not k.startswith("_")}}
json.dump(out, open(sys.argv[-1], "w"), indent=1)
