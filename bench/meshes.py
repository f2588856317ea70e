#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Issue 41: block meshes (vdb_blocks --meshes) beside Blender's Cell Fracture, in one run.

Generates one 20 m equidimensional block tile (seed 7, 5 cm voxels: vdb_blocks' defaults),
then meshes its blocks from that tile (--from-tile, so every row meshes the same blocks) at
each --mesh-adaptivity, reading the meshes phase from --stats and the vertex count from the
PLY's header. Reference, in this run: Blender's Cell Fracture add-on splitting a 20 m cube
into 150 cells (150 particles in its volume, seed 7), headless; its time is the operator's
alone. Cell Fracture's pieces are flat convex cells with no relief and no fracture gaps, so
the comparison is of cost per delivered piece, not of the same shapes. Each is the best of
RUNS runs (the 2-core VMs are noisy).

usage: /usr/bin/python3 bench/meshes.py [ADAPTIVITY ...] [--runs N]
"""
import json
import os
import re
import subprocess
import sys
import tempfile

from machine import cpu, runs_option  # (bench/ is on sys.path: scripts run from there)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
BUILD = os.environ.get("ROCKVDB_BUILD", os.path.join(ROOT, "build"))
BLOCKS = os.path.join(BUILD, "vdbtools", "vdb_blocks")

CELL_FRACTURE = """
import bpy, addon_utils, json, time
addon_utils.enable("object_fracture_cell", default_set=True)
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
bpy.ops.mesh.primitive_cube_add(size=20.0)
cube = bpy.context.active_object
ps = cube.modifiers.new("ps", "PARTICLE_SYSTEM").particle_system
ps.settings.count = 150
ps.settings.emit_from = "VOLUME"
ps.settings.frame_end = 1
ps.seed = 7
bpy.context.scene.frame_set(2)
t0 = time.perf_counter()
bpy.ops.object.add_fracture_cell_objects(source={"PARTICLE_OWN"}, source_limit=150)
seconds = time.perf_counter() - t0
pieces = [o for o in bpy.data.objects if o.type == "MESH" and o != cube]
print("CELL_FRACTURE", json.dumps({"pieces": len(pieces), "seconds": seconds,
      "vertices": sum(len(o.data.vertices) for o in pieces)}))
"""


def ply_vertices(path):
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"element vertex"):
                return int(line.split()[2])
            if line.startswith(b"end_header"):
                break
    raise ValueError(f"{path}: no vertex count")


def block_meshes(tile, adaptivity, tmp):
    """(meshes phase seconds, vertices, file MB, blocks) of one --meshes run."""
    ply, stats = os.path.join(tmp, "m.ply"), os.path.join(tmp, "s.json")
    p = subprocess.run([BLOCKS, "--from-tile", tile, "--meshes", ply, "--mesh-adaptivity",
                        str(adaptivity), "--stats", stats, "-o", os.path.join(tmp, "t.vdb")],
                       capture_output=True, text=True, check=True)
    phases = {ph["name"]: ph["seconds"] for ph in json.load(open(stats))["phases"]}
    blocks = int(re.search(r"meshed (\d+) blocks", p.stderr)[1])
    return phases["meshes"], ply_vertices(ply), os.path.getsize(ply) / 1e6, blocks


def cell_fracture():
    p = subprocess.run(["blender", "--background", "--factory-startup", "--python-expr",
                        CELL_FRACTURE], capture_output=True, text=True, timeout=600)
    m = re.search(r"^CELL_FRACTURE (.*)$", p.stdout, re.M)
    if not m:
        raise RuntimeError("Cell Fracture did not run: " + (p.stdout + p.stderr)[-800:])
    return json.loads(m[1])


def main(argv):
    runs, argv = runs_option(argv)
    levels = [float(a) for a in argv] or [0.0, 0.25, 0.5, 1.0]
    print(f"block meshes of a 20 m tile at 5 cm, best of {runs} runs, {os.cpu_count()} CPUs, {cpu()}")
    print()
    with tempfile.TemporaryDirectory() as tmp:
        tile = os.path.join(tmp, "tile.tile")
        subprocess.run([BLOCKS, "-q", "--tile-size", "20", "--seed", "7", "--tile", tile,
                        "-o", os.path.join(tmp, "first.vdb")], check=True)
        ref = min((cell_fracture() for _ in range(runs)), key=lambda r: r["seconds"])
        print(f"reference: Blender's Cell Fracture, 20 m cube into {ref['pieces']} cells: "
              f"{ref['seconds']:.2f} s, {ref['vertices']} vertices")
        print()
        print("| --mesh-adaptivity | blocks | meshes phase | vertices | PLY | time / Cell Fracture's | vertices / Cell Fracture's |")
        print("|---|---|---|---|---|---|---|")
        for a in levels:
            seconds, vertices, mb, blocks = min((block_meshes(tile, a, tmp) for _ in range(runs)),
                                                key=lambda r: r[0])
            print(f"| {a:g} | {blocks} | {seconds:.2f} s | {vertices} | {mb:.1f} MB | "
                  f"{seconds / ref['seconds']:.1f}x | {vertices / ref['vertices']:.0f}x |")
            sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv[1:])
