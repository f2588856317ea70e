# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: import an OBJ written with ids (vdb_mesh: faces under usemtl
NAME_ID) with Blender's own importer and report, for every 7th polygon, its centre (world) and
the name of its material slot.
usage: blender --background --factory-startup --python blender_ids.py -- in.obj report.json"""
import json
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from blender_obj import import_obj  # noqa: E402

if "--" in sys.argv:
    path, report = sys.argv[sys.argv.index("--") + 1:][:2]
    out = {"polygons": [], "slots": []}
    for obj in import_obj(path):
        names = [s.material.name if s.material else None for s in obj.material_slots]
        out["slots"] += names
        for p in list(obj.data.polygons)[::7]:
            c = obj.matrix_world @ p.center
            out["polygons"].append([c[0], c[1], c[2], names[p.material_index] if names else None])
    with open(report, "w") as f:
        json.dump(out, f)
