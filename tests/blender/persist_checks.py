# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender, in two processes (issue 55: results survive save and reopen).
  make DIR    every operator at its defaults in an unsaved file (what an artist does first),
              then save DIR/scene.blend and quit; report DIR/made.json
  check BLEND open BLEND in a new Blender; report each result's mesh, ids and cache, and
              export one result's grids; report BLEND's folder/checked.json
usage: blender -b --factory-startup --python persist_checks.py -- ADDON_DIR make|check PATH
(PYTHONPATH: the rockvdb package)"""
import json
import os
import sys
import time
import traceback

argv = sys.argv[sys.argv.index("--") + 1:]
sys.path.insert(0, argv[0])
MODE, PATH = argv[1], argv[2]

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import rockvdb_blender  # noqa: E402
from rockvdb_blender import results  # noqa: E402

report = {"errors": []}


def describe(obj):
    """What an artist sees of a result: its mesh's vertex count and its id attributes."""
    me = obj.data
    ids = {}
    for a in me.attributes:
        if a.name in results.ID_GRIDS:
            v = np.zeros(len(me.vertices), np.float32)
            a.data.foreach_get("value", v)
            ids[a.name] = {"values": sorted(int(x) for x in np.unique(v)),
                           "sum": float(v.astype(np.float64).sum())}
    co = np.zeros(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", co)
    return {"stage": obj["rockvdb_stage"], "vertices": len(me.vertices),
            "polygons": len(me.polygons), "ids": ids,
            "co_sum": float(co.astype(np.float64).sum()),
            "cache": obj["rockvdb_cache"], "cache_missing": results.missing_cache(obj)}


def none_active():
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None


def timed(name, call):
    t0 = time.time()
    status = call()
    obj = bpy.context.active_object
    report["seconds"][name] = time.time() - t0
    report["status"][name] = sorted(status)
    return obj


try:
    rockvdb_blender.register()
    if MODE == "make":
        report["tempdir"] = bpy.app.tempdir
        report["seconds"], report["status"] = {}, {}
        made = {}
        none_active()
        rock = timed("fractal_rock", lambda: bpy.ops.rockvdb.fractal_rock())
        made["fractal_rock"] = rock.name
        none_active()
        made["block_tile"] = timed("block_tile", lambda: bpy.ops.rockvdb.block_tile()).name
        bpy.context.view_layer.objects.active = rock
        made["detail"] = timed("detail", lambda: bpy.ops.rockvdb.detail()).name
        none_active()
        made["fractal_scatter"] = timed("fractal_scatter", lambda: bpy.ops.rockvdb.fractal_scatter()).name
        bpy.ops.mesh.primitive_cube_add(size=2.0, location=(20, 0, 1))
        made["rock_pile"] = timed("rock_pile", lambda: bpy.ops.rockvdb.rock_pile()).name
        # A small landscape: a sheet with a 4 m step across it (a wall for the blocks).
        bpy.ops.mesh.primitive_grid_add(size=10, x_subdivisions=10, y_subdivisions=10,
                                        location=(6, 6, 0))
        sheet = bpy.context.active_object
        for v in sheet.data.vertices:
            if v.co.x > 0.5:
                v.co.z = 4.0
        made["amplify"] = timed("amplify", lambda: bpy.ops.rockvdb.amplify()).name
        bpy.context.view_layer.objects.active = sheet
        made["stacks"] = timed("stacks", lambda: bpy.ops.rockvdb.stacks()).name
        report["results"] = {k: describe(bpy.data.objects[n]) for k, n in made.items()}
        report["names"] = made
        # the detail's input and output grids, for its displacement
        report["rock_cache"] = results.cache_file(rock["rockvdb_cache"])
        report["detail_cache_before_save"] = results.cache_file(bpy.data.objects[made["detail"]]["rockvdb_cache"])
        bpy.ops.wm.save_as_mainfile(filepath=os.path.join(PATH, "scene.blend"))
        report["cache_dir_after_save"] = results.cache_dir()
        report["after_save"] = {k: describe(bpy.data.objects[n]) for k, n in made.items()}
        out = os.path.join(PATH, "made.json")
    else:
        bpy.ops.wm.open_mainfile(filepath=PATH)
        report["results"] = {o["rockvdb_stage"] + ":" + o.name: describe(o)
                             for o in bpy.data.objects if o.get("rockvdb_stage")}
        report["grids"] = {}
        for o in bpy.data.objects:
            if o.get("rockvdb_stage") and not results.missing_cache(o):
                report["grids"][o.name] = sorted(g.name for g in results.grids_of(o))
        out = os.path.join(os.path.dirname(PATH), "checked.json")
    rockvdb_blender.unregister()
except Exception:
    report["errors"].append(traceback.format_exc())
    out = os.path.join(PATH if MODE == "make" else os.path.dirname(PATH),
                       "made.json" if MODE == "make" else "checked.json")

with open(out, "w") as f:
    json.dump(report, f, indent=1, default=str)
