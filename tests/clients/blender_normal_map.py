# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: import an OBJ (default axes), read an object-space and a
tangent-space normal map of it, and report how they agree, at every triangle's centre (uv,
loop normals and Blender's own MikkTSpace tangents averaged over its corners, as a shader
interpolates them):
  object: mean of n_object · N (the map's normals against the mesh's smooth normals),
  tangent: mean of n_tangent · N, with n_tangent = normalize(x T + y B + z N),
  same: mean of n_tangent · n_object (the two maps hold the same normals).
usage: blender --background --factory-startup --python blender_normal_map.py -- in.obj
       object.exr tangent.exr report.json"""
import json
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_obj import import_obj  # noqa: E402


def sampler(path):
    img = bpy.data.images.load(path)
    w, h = img.size
    px = list(img.pixels)  # RGBA floats, rows from the bottom (v up)

    def at(u, v):
        x = min(w - 1, max(0, int(u * w)))
        y = min(h - 1, max(0, int(v * h)))
        k = (y * w + x) * 4
        return [px[k + c] * 2 - 1 for c in range(3)]
    return at


def unit(v):
    n = sum(c * c for c in v) ** 0.5
    return [c / n for c in v] if n > 0 else v


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


if "--" in sys.argv:
    path, obj_map, tan_map, report = sys.argv[sys.argv.index("--") + 1:][:4]
    me = import_obj(path)[-1].data
    me.calc_tangents(uvmap=me.uv_layers.active.name)
    # (After calc_tangents: it reallocates the mesh's layers, and a reference taken before
    # reads stale memory.)
    uvs = me.uv_layers.active.data
    obj_at, tan_at = sampler(obj_map), sampler(tan_map)
    sums = {"object": 0.0, "tangent": 0.0, "same": 0.0}
    count = 0
    for poly in me.polygons:
        loops = [me.loops[i] for i in poly.loop_indices]
        u = sum(uvs[i].uv[0] for i in poly.loop_indices) / len(loops)
        v = sum(uvs[i].uv[1] for i in poly.loop_indices) / len(loops)
        N = [sum(l.normal[c] for l in loops) / len(loops) for c in range(3)]
        T = [sum(l.tangent[c] for l in loops) / len(loops) for c in range(3)]
        B = [sum(l.bitangent[c] for l in loops) / len(loops) for c in range(3)]
        n_obj = unit(obj_at(u, v))
        x, y, z = tan_at(u, v)
        n_tan = unit([x * T[c] + y * B[c] + z * N[c] for c in range(3)])
        sums["object"] += dot(n_obj, unit(N))
        sums["tangent"] += dot(n_tan, unit(N))
        sums["same"] += dot(n_tan, n_obj)
        count += 1
    with open(report, "w") as f:
        json.dump({k: s / count for k, s in sums.items()} | {"triangles": count}, f)
