# SPDX-License-Identifier: Apache-2.0
"""Writes the fuzz targets' seed corpora (corpus/<target>/), checked in beside this script;
run it again to rebuild them. Small valid inputs of every format each target reads, so the
fuzzer starts from the parsers' deep paths instead of their first check.
usage: PYTHONPATH=build/python /usr/bin/python3 tests/fuzz/make_corpus.py"""
import glob
import json
import os
import struct
import sys
import zlib

import numpy as np

import rockvdb

here = os.path.dirname(os.path.abspath(__file__))
samples = os.path.join(here, "..", "..", "samples", "data")


def put(target, name, data):
    d = os.path.join(here, "corpus", target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


# --- vdb: small level sets as the tools write them (provenance, ids, several grids) ---------
tmp = os.path.join(here, "corpus", "_tmp.vdb")
sphere = rockvdb.sphere(0.6).bake(voxel_size=0.5, half_width=1)
rockvdb.write(tmp, [sphere])
put("vdb", "sphere.vdb", open(tmp, "rb").read())
scene = (rockvdb.sphere(0.6).tag(3) | rockvdb.box((0.8, 0.8, 0.8), (0.6, 0, 0)).tag(4)).bake(voxel_size=0.5, half_width=1)
rockvdb.write(tmp, list(scene) if isinstance(scene, (tuple, list)) else [scene])
put("vdb", "tagged.vdb", open(tmp, "rb").read())
os.remove(tmp)


# --- image: 8- and 16-bit grey PNGs, a grey-alpha and an RGB PNG, a float EXR ---------------
def png(w, h, color_type, depth, rows):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    raw = b"".join(b"\0" + r for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, color_type, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


put("image", "gray8.png", png(4, 3, 0, 8, [bytes([10 * x + 40 * y for x in range(4)]) for y in range(3)]))
put("image", "gray16.png", png(3, 3, 0, 16, [b"".join(struct.pack(">H", 9000 * x + 300 * y) for x in range(3)) for y in range(3)]))
put("image", "graya8.png", png(2, 2, 4, 8, [bytes([50, 255, 60, 255]), bytes([70, 255, 80, 255])]))
put("image", "rgb8.png", png(2, 2, 2, 8, [bytes([1, 2, 3, 4, 5, 6]), bytes([7, 8, 9, 10, 11, 12])]))
tmp = os.path.join(here, "corpus", "_tmp.exr")
rockvdb.write_heightfield(tmp, (np.arange(12, dtype=np.float32).reshape(3, 4) * 0.5))
put("image", "height.exr", open(tmp, "rb").read())
os.remove(tmp)

# --- mesh: the first byte picks the format (0 obj, 1 stl, 2 ply), the rest is the file ------
cube_v = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)]
cube_q = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
cube_t = [t for q in cube_q for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]
obj = "".join("v %g %g %g\n" % v for v in cube_v) + "".join(
    "f %d/1/1 %d/1/1 %d/1/1 %d/1/1\n" % tuple(i + 1 for i in q) for q in cube_q)
put("mesh", "cube_obj", b"\0" + ("# cube\no cube\nvt 0 0\nvn 0 0 1\n" + obj).encode())
stl = "solid cube\n" + "".join(
    "facet normal 0 0 0\n outer loop\n" + "".join("  vertex %g %g %g\n" % cube_v[i] for i in t)
    + " endloop\nendfacet\n" for t in cube_t) + "endsolid cube\n"
put("mesh", "cube_ascii_stl", b"\1" + stl.encode())
binstl = b"\0" * 80 + struct.pack("<I", len(cube_t)) + b"".join(
    struct.pack("<3f", 0, 0, 0) + b"".join(struct.pack("<3f", *cube_v[i]) for i in t) + b"\0\0"
    for t in cube_t)
put("mesh", "cube_binary_stl", b"\1" + binstl)
ply = ("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 6\nproperty list uchar int vertex_indices\nend_header\n"
       + "".join("%g %g %g\n" % v for v in cube_v) + "".join("4 %d %d %d %d\n" % q for q in cube_q))
put("mesh", "cube_ascii_ply", b"\2" + ply.encode())
binply = ("ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
          "property float z\nelement face 12\nproperty list uchar int vertex_indices\nend_header\n").encode()
binply += b"".join(struct.pack("<3f", *v) for v in cube_v)
binply += b"".join(struct.pack("<B3i", 3, *t) for t in cube_t)
put("mesh", "cube_binary_ply", b"\2" + binply)

# --- json: the first byte picks the consumer (FuzzJson.cc), the rest is the text ------------
def js(consumer, name, value):
    put("json", name, bytes([consumer]) + (value if isinstance(value, str) else json.dumps(value)).encode())


js(0, "tile_params", {"seed": 3})
js(1, "blocks_params", {"seed": 2, "fractures": json.load(open(os.path.join(samples, "fractures.json")))})
js(2, "amplify_params", {"strata": json.load(open(os.path.join(samples, "strata.json")))})
js(3, "detail_params", {"blend": json.load(open(os.path.join(samples, "blend.json")))})
js(3, "detail_skeleton", {"direction-skeleton": json.load(open(os.path.join(samples, "skeleton.json")))})
js(4, "rock_tiles_params", {"n": 3, "seed": 1})
js(5, "pile_params", {"seed": 1})
js(6, "fractal_params", {"seed": 4})
for f in sorted(glob.glob(os.path.join(samples, "arches_*.json"))):
    js(7, os.path.basename(f)[:-5], open(f).read())
js(8, "expr_union", {"type": "union", "smooth": 0.2, "children": [
    {"type": "sphere", "center": [0, 0, 0], "radius": 1, "id": 2},
    {"type": "transform", "translate": [1, 0, 0], "rotate": [0, 30, 0], "scale": 0.5,
     "child": {"type": "box", "center": [0, 0, 0], "size": [1, 2, 1], "rounding": 0.1}}]})
js(8, "expr_warp", {"type": "warp", "amplitude": 0.2, "frequency": 1.5, "octaves": 3, "seed": 7,
                    "child": {"type": "polytope", "planes": [[1, 0, 0, 1], [-1, 0, 0, 1], [0, 1, 0, 1],
                                                              [0, -1, 0, 1], [0, 0, 1, 1], [0, 0, -1, 1]]}})
js(8, "expr_difference", {"type": "difference", "children": [
    {"type": "capsule", "a": [0, 0, 0], "b": [0, 0, 2], "radius": 0.5},
    {"type": "plane", "point": [0, 0, 1], "normal": [0, 0, 1]}]})
js(8, "expr_terrain", {"type": "noise_terrain", "samples": [9, 9], "cell_size": 1, "amplitude": 2,
                       "frequency": 0.1, "octaves": 2, "seed": 3, "base_depth": 2})
js(8, "expr_cliff", {"type": "sea_cliff", "samples": [9, 9], "cell_size": 1, "height": 5})
js(9, "strata", open(os.path.join(samples, "strata.json")).read())
js(10, "fractures", open(os.path.join(samples, "fractures.json")).read())
js(11, "authored", open(os.path.join(samples, "authored.json")).read())
js(11, "authored_expression", open(os.path.join(samples, "boulder.json")).read())
tile = rockvdb.block_tile(bake=False, tile_size=4, point_radius=0.5)
tmp = os.path.join(here, "corpus", "_tile.json")
tile.save(tmp)
js(12, "block_tile", open(tmp).read())
tile = rockvdb.block_tile(bake=False, tile_size=4, point_radius=0.5,
                          authored=[{"type": "sphere", "center": [2, 2, 2], "radius": 0.8}])
tile.save(tmp)
js(12, "block_tile_expression", open(tmp).read())
os.remove(tmp)
js(13, "skeleton", open(os.path.join(samples, "skeleton.json")).read())
js(14, "edits", open(os.path.join(samples, "arches_edits.json")).read())
js(15, "provenance", {"op": "primitive", "params": {"radius": 1.0, "seed": 0}, "sources": [{"a": 1}]})
print("corpus written under", os.path.join(here, "corpus"))
