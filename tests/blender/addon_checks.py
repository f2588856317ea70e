# SPDX-License-Identifier: Apache-2.0
"""Run by headless Blender: the rockvdb add-on registered, every operator run, its results and
properties reported as JSON for test_addon.py to judge against the C++ tables and the CLI.
usage: blender -b --factory-startup --python addon_checks.py -- ADDON_DIR OUT_DIR SCENE.json
(PYTHONPATH: the rockvdb package)"""
import json
import os
import shutil
import sys
import time
import traceback

argv = sys.argv[sys.argv.index("--") + 1:]
sys.path.insert(0, argv[0])
OUT = argv[1]
SCENE = argv[2]  # a vdb_arches scene file

import bpy  # noqa: E402
import numpy as np  # noqa: E402

import rockvdb_blender  # noqa: E402
from rockvdb_blender import Run, results, stages  # noqa: E402

report = {"errors": []}


def registered():
    return sorted(c for c in dir(bpy.types) if c.startswith("ROCKVDB_OT_"))


def props_of(idname):
    """Every property of an operator: type, default, limits, length, enum items."""
    rna = getattr(bpy.ops.rockvdb, idname).get_rna_type()
    out = {}
    for p in rna.properties:
        if p.identifier == "rna_type":
            continue
        d = {"type": p.type, "hidden": p.is_hidden}
        if p.type in ("INT", "FLOAT"):
            d["length"] = p.array_length
            d["default"] = list(p.default_array) if p.array_length else p.default
            d["min"], d["max"] = p.hard_min, p.hard_max
            d["soft_min"], d["soft_max"] = p.soft_min, p.soft_max
            d["subtype"], d["unit"] = p.subtype, p.unit
        elif p.type == "BOOLEAN":
            d["default"] = p.default
        elif p.type == "ENUM":
            d["default"] = p.default
            d["items"] = [i.identifier for i in p.enum_items]
        elif p.type == "STRING":
            d["default"] = p.default
            d["subtype"] = p.subtype
        d["description"] = p.description
        out[p.identifier] = d
    return out


def evaluated(obj):
    me = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    attrs = {}
    for a in me.attributes:
        if a.name in ("material", "block_id", "rock_id"):
            v = np.zeros(len(me.vertices), np.float32)
            a.data.foreach_get("value", v)
            attrs[a.name] = sorted(set(int(x) for x in np.unique(v)))
    # arches §6 weights on the vertices: each one's [min, max], the share of vertices whose
    # weights sum to 1 (they are shares of visible faces) and of those with none.
    weights, total = {}, np.zeros(len(me.vertices), np.float32)
    for a in me.attributes:
        if a.name.startswith("weight_"):
            v = np.zeros(len(me.vertices), np.float32)
            a.data.foreach_get("value", v)
            weights[a.name] = [float(v.min()), float(v.max())] if len(v) else [0.0, 0.0]
            total += v
    lo = [min(v.co[i] for v in me.vertices) for i in range(3)] if me.vertices else None
    hi = [max(v.co[i] for v in me.vertices) for i in range(3)] if me.vertices else None
    nodes = [n for m in obj.data.materials for n in m.node_tree.nodes]
    return {"vertices": len(me.vertices), "attributes": attrs, "min": lo, "max": hi,
            "tint": [n.attribute_name for n in nodes if n.type == "ATTRIBUTE"],
            "weights": weights,
            # (over the vertices with any weight: the terrain's floor, facing nothing, has none)
            "weights_sum_one": float(np.mean(np.abs(total[total > 0.01] - 1) < 0.02)) if (total > 0.01).any() else 0.0,
            "weights_none": float(np.mean(total <= 0.01)) if weights and len(total) else 1.0,
            "noise_textures": sum(1 for n in nodes if n.type == "TEX_NOISE"),
            # each material's colour (the unlinked vector of its SCALE node)
            "colours": sorted([round(c, 6) for c in n.inputs[0].default_value] for n in nodes
                              if n.type == "VECT_MATH" and n.operation == "SCALE"
                              and not n.inputs[0].is_linked)}


def result(name, obj, copy=True):
    """A result object's report; its cache .vdb copied to OUT/name.vdb."""
    r = evaluated(obj)
    r["name"] = obj.name
    r.update({k: obj[k] for k in ("rockvdb_stage", "rockvdb_version", "rockvdb_generator",
                                  "rockvdb_params", "rockvdb_cache", "rockvdb_mesh_adaptivity")})
    r["volume_grids"] = sorted(g.name for g in results.grids_of(obj))
    r["modifiers"] = [m.type for m in obj.modifiers]
    r["children"] = sorted(c.name for c in obj.children)
    r["mesh_users"] = obj.data.users
    if copy:
        shutil.copy(results.cache_file(obj["rockvdb_cache"]), os.path.join(OUT, name + ".vdb"))
    return r


def op_error(call):
    """The one-line report a failing operator call gives (bpy raises it as RuntimeError)."""
    try:
        call()
    except RuntimeError as e:
        return str(e)
    return None


def instances_of(name, obj):
    """What a result's instances evaluate to: each instance's translation and its point's
    rock_id, the world bounds of the instanced rocks, the rocks collection's size."""
    inst = obj["rockvdb_instances"]
    dg = bpy.context.evaluated_depsgraph_get()
    pts = [v.co.copy() for v in inst.data.vertices]
    ids = [d.value for d in inst.data.attributes["rock_id"].data]
    found, rock_ids, samples = [], [], []
    lo, hi = [1e9] * 3, [-1e9] * 3
    for di in dg.object_instances:
        if di.is_instance and di.parent and di.parent.original == inst:
            m = di.matrix_world.copy()
            t = m.translation
            found.append([t[k] for k in range(3)])
            rock_ids.append(ids[di.persistent_id[0]])  # the instancing point's index
            verts = di.object.original.data.vertices
            samples.append([list(m @ verts[i].co) for i in range(0, len(verts), max(1, len(verts) // 9))])
            for v in verts:
                w = m @ v.co
                lo = [min(lo[k], w[k]) for k in range(3)]
                hi = [max(hi[k], w[k]) for k in range(3)]
    rocks = inst.modifiers[0].node_group.nodes["Collection Info"].inputs["Collection"].default_value
    return {"translations": found, "rock_ids": rock_ids, "samples": samples, "min": lo, "max": hi,
            "rocks": len(rocks.objects), "points": len(pts),
            "tint": [n.attribute_type for m in bpy.data.materials if m.name.startswith(obj.name + " instances")
                     for n in m.node_tree.nodes if n.type == "ATTRIBUTE"],
            "surface_shown": obj.display_type != "BOUNDS" or not obj.hide_render,
            "result": result(name, obj)}


def none_selected():
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None


def scene_names():
    return sorted(o.name for o in bpy.data.objects)


try:
    # A saved file: the caches go to //rockvdb_cache beside it (and outlive this Blender).
    bpy.ops.wm.save_as_mainfile(filepath=os.path.join(OUT, "scene.blend"))
    # Register, unregister, register again: nothing left behind, nothing doubled.
    rockvdb_blender.register()
    report["registered"] = registered()
    report["menu"] = hasattr(bpy.types, "VIEW3D_MT_rockvdb_add")
    rockvdb_blender.unregister()
    report["after_unregister"] = registered() + (["menu"] if hasattr(bpy.types, "VIEW3D_MT_rockvdb_add") else [])
    rockvdb_blender.register()
    report["registered_again"] = registered()

    report["props"] = {s.name: props_of(s.name) for s in stages.STAGES}
    report["descriptions"] = {s.name: getattr(bpy.types, f"ROCKVDB_OT_{s.name}").bl_description
                              for s in stages.STAGES}
    report["undo"] = {s.name: "UNDO" in getattr(bpy.types, f"ROCKVDB_OT_{s.name}").bl_options
                      for s in stages.STAGES}
    R = report["results"] = {}

    # Defaults, nothing selected: a fractal rock, a block tile.
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None
    bpy.ops.rockvdb.fractal_rock()
    rock = bpy.context.active_object
    R["fractal_rock"] = result("fractal_rock", rock)
    bpy.ops.rockvdb.fractal_rock(quality="FINAL")
    R["fractal_rock_final"] = result("fractal_rock_final", bpy.context.active_object)
    # The same call again (what the redo panel does when a group opens): the result is the
    # last one's, not baked again; its own cache file, the same bytes.
    works = []
    real_work = Run._work
    Run._work = lambda self: (works.append(1), real_work(self))[1]
    bpy.ops.rockvdb.fractal_rock(quality="FINAL")
    again = bpy.context.active_object
    bpy.ops.rockvdb.fractal_rock(quality="FINAL", seed=1)
    # A scene file edited between two calls: baked again (three calls, two bakes).
    none_selected()
    scene_works = len(works)
    bpy.ops.rockvdb.stacks(scene=SCENE)
    bpy.ops.rockvdb.stacks(scene=SCENE)
    st = os.stat(SCENE)
    os.utime(SCENE, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    bpy.ops.rockvdb.stacks(scene=SCENE)
    scene_bakes = len(works) - scene_works
    Run._work = real_work
    first = results.cache_file(bpy.data.objects[R["fractal_rock_final"]["name"]]["rockvdb_cache"])
    report["same_call"] = {"bakes": len(works) - scene_bakes, "scene_file_bakes": scene_bakes, "own_file": results.cache_file(again["rockvdb_cache"]) != first,
                           "same_bytes": open(results.cache_file(again["rockvdb_cache"]), "rb").read() == open(first, "rb").read(),
                           "vertices": len(again.data.vertices) == R["fractal_rock_final"]["vertices"]}
    bpy.ops.rockvdb.fractal_rock(seed=5, roughness=0.3)
    R["fractal_rock_seed5"] = result("fractal_rock_seed5", bpy.context.active_object)

    bpy.context.view_layer.objects.active = None
    bpy.ops.rockvdb.block_tile(tile_size=6.0, voxel_size=0.1)   # the default tile is 20 m at 5 cm
    R["block_tile"] = result("block_tile", bpy.context.active_object)
    bpy.ops.rockvdb.block_tile(type="tabular", tile_size=6.0, voxel_size=0.1)
    R["block_tile_tabular"] = result("block_tile_tabular", bpy.context.active_object)

    # Detail on the block tile: its block_id carried.
    bpy.context.view_layer.objects.active = bpy.data.objects[R["block_tile"]["name"]]
    bpy.ops.rockvdb.detail(warp_amplitude=0.05)
    R["detail_tile"] = result("detail_tile", bpy.context.active_object)

    # Amplify a bumpy sheet with the first tile (as a level set), and with both tiles in two
    # strata (as a heightfield, the sheet moved to x, y >= 0).
    bpy.ops.mesh.primitive_grid_add(size=10, x_subdivisions=10, y_subdivisions=10, location=(6, 6, 0))
    sheet = bpy.context.active_object
    sheet.data.vertices[60].co.z = 3.0
    bpy.ops.rockvdb.amplify(tiles="Block Tile", voxel_size=0.1)
    R["amplify"] = result("amplify", bpy.context.active_object)
    bpy.context.view_layer.objects.active = sheet
    bpy.ops.rockvdb.amplify(voxel_size=0.1, terrain_as="HEIGHTFIELD", cell_size=0.5, use_strata=True,
                            strata='{"layers": [{"tile": "Block_Tile", "top": 1}, {"tile": "Block_Tile_001"}]}')
    R["amplify_heightfield"] = result("amplify_heightfield", bpy.context.active_object)
    # Material stacks of the sheet, and of a vdb_arches scene file.
    bpy.context.view_layer.objects.active = sheet
    bpy.ops.rockvdb.stacks(cell_size=0.5, use_cell_size=True)
    R["stacks"] = result("stacks", bpy.context.active_object)
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None
    bpy.ops.rockvdb.stacks(scene=SCENE)
    R["stacks_scene"] = result("stacks_scene", bpy.context.active_object)

    # Detail on the active result (defaults, then a warp).
    bpy.context.view_layer.objects.active = rock
    bpy.ops.rockvdb.detail()
    R["detail"] = result("detail", bpy.context.active_object)
    bpy.context.view_layer.objects.active = rock
    bpy.ops.rockvdb.detail(warp_amplitude=0.03)
    R["detail_warp"] = result("detail_warp", bpy.context.active_object)

    # A rock pile inside a cube; fractal rocks scattered on a grid sheet and on the plane.
    bpy.ops.mesh.primitive_cube_add(size=3.0, location=(0, 0, 1.5))
    bpy.ops.rockvdb.rock_pile(tiles_cube_size=1.5, tiles_voxels_per_cell=8)
    R["rock_pile"] = result("rock_pile", bpy.context.active_object)
    bpy.ops.mesh.primitive_cube_add(size=3.0, location=(0, 0, 1.5))
    bpy.ops.rockvdb.rock_pile(tiles_cube_size=1.5, tiles_voxels_per_cell=8, material=3)
    R["rock_pile_material"] = result("rock_pile_material", bpy.context.active_object)
    bpy.ops.mesh.primitive_grid_add(size=8, x_subdivisions=16, y_subdivisions=16, location=(0, 0, 1))
    bpy.ops.rockvdb.fractal_scatter(count=6, voxel_size=0.05, seed=2)
    R["fractal_scatter_mesh"] = result("fractal_scatter_mesh", bpy.context.active_object)
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None
    bpy.ops.rockvdb.fractal_scatter(count=6, voxel_size=0.05, seed=2, area=(-4, -4, 4, 4),
                                    use_area=True, material=4)
    R["fractal_scatter_plane"] = result("fractal_scatter_plane", bpy.context.active_object)

    # The same scatter, and a pile, as instances: rocks instanced on points, the level sets'
    # meshes hidden.
    none_selected()
    bpy.ops.rockvdb.fractal_scatter(count=6, voxel_size=0.05, seed=2, area=(-4, -4, 4, 4),
                                    use_area=True, material=4, instances=True)
    report["instances"] = instances_of("scatter_instances", bpy.context.active_object)
    bpy.ops.mesh.primitive_cube_add(size=3.0, location=(0, 0, 1.5))
    bpy.ops.rockvdb.rock_pile(tiles_cube_size=1.5, tiles_voxels_per_cell=8, material=3,
                              instances=True)
    report["pile_instances"] = instances_of("pile_instances", bpy.context.active_object)

    # Regenerate in place: same object, same grids (copied before, the cache is replaced).
    bpy.context.view_layer.objects.active = rock
    before_names = scene_names()
    shutil.copy(results.cache_file(rock["rockvdb_cache"]), os.path.join(OUT, "regen_before.vdb"))
    bpy.ops.rockvdb.regenerate()
    report["regenerate"] = {"same_object": bpy.context.active_object == rock,
                            "scene_unchanged": scene_names() == before_names,
                            "new_cache": rock["rockvdb_cache"] != R["fractal_rock"]["rockvdb_cache"]}
    shutil.copy(results.cache_file(rock["rockvdb_cache"]), os.path.join(OUT, "regen_after.vdb"))

    # The other operators at their table defaults (only their inputs given): a block tile
    # (20 m at 5 cm), a pile in a cube, stacks and an amplified sheet.
    D = report["defaults"] = {}
    none_selected()
    r = bpy.ops.rockvdb.block_tile()
    D["block_tile"] = {"ran": list(r), "params": bpy.context.active_object["rockvdb_params"]}
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0, 0, 1))
    r = bpy.ops.rockvdb.rock_pile()
    D["rock_pile"] = {"ran": list(r), "params": bpy.context.active_object["rockvdb_params"]}
    bpy.context.view_layer.objects.active = sheet
    r = bpy.ops.rockvdb.stacks()
    D["stacks"] = {"ran": list(r), "params": bpy.context.active_object["rockvdb_params"]}
    bpy.context.view_layer.objects.active = sheet
    r = bpy.ops.rockvdb.amplify(tiles="Block Tile")
    D["amplify"] = {"ran": list(r), "params": bpy.context.active_object["rockvdb_params"]}

    # Regenerate stacks made from a scene file whose quantum is not the table's: the scene's
    # keys still hold (only what the call set is stored and passed again).
    stacks = bpy.data.objects[R["stacks_scene"]["name"]]
    shutil.copy(results.cache_file(stacks["rockvdb_cache"]), os.path.join(OUT, "regen_stacks_before.vdb"))
    bpy.context.view_layer.objects.active = stacks
    bpy.ops.rockvdb.regenerate()
    report["regenerate_stacks_operator"] = json.loads(stacks["rockvdb_operator"])
    shutil.copy(results.cache_file(stacks["rockvdb_cache"]), os.path.join(OUT, "regen_stacks_after.vdb"))

    # Regenerate a result made from a scene object (the pile in its cube), with another
    # object active: it reads the same cube again.
    pile = bpy.data.objects[R["rock_pile"]["name"]]
    shutil.copy(results.cache_file(pile["rockvdb_cache"]), os.path.join(OUT, "regen_pile_before.vdb"))
    bpy.context.view_layer.objects.active = pile
    bpy.ops.rockvdb.regenerate()
    report["regenerate_pile_same_object"] = bpy.context.active_object == pile
    # The same tile rows: the tile set is the earlier file (a hard link), not made again.
    tiles = [json.loads(o["rockvdb_params"])["pile"]["tiles"] for o in (pile,)]
    first = json.loads(R["rock_pile"]["rockvdb_params"])["pile"]["tiles"]
    report["regenerate_pile_tiles"] = {"new_name": tiles[0] != first,
                                       "same_file": os.path.samefile(tiles[0], first)}
    shutil.copy(results.cache_file(pile["rockvdb_cache"]), os.path.join(OUT, "regen_pile_after.vdb"))

    # Export the rock: its grids with their provenance.
    bpy.context.view_layer.objects.active = rock
    bpy.ops.rockvdb.export_vdb(filepath=os.path.join(OUT, "exported.vdb"))

    # Bad input: one-line reports, nothing added.
    bpy.ops.mesh.primitive_grid_add(size=4, location=(0, 0, 0))
    centred = bpy.context.active_object
    before_names = scene_names()
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.objects.active = None
    report["bad"] = {
        "voxel_as_typed": op_error(lambda: bpy.ops.rockvdb.fractal_rock(voxel_size=-1.0, quality="FINAL")),
        "pile_no_mesh": op_error(lambda: bpy.ops.rockvdb.rock_pile()),
        "detail_no_result": op_error(lambda: bpy.ops.rockvdb.detail()),
        "stacks_no_terrain": op_error(lambda: bpy.ops.rockvdb.stacks()),
        "amplify_heightfield_origin": op_error(lambda: bpy.ops.rockvdb.amplify(
            {"active_object": centred}, tiles="Block Tile", terrain_as="HEIGHTFIELD")),
        "amplify_unknown_tile": op_error(lambda: bpy.ops.rockvdb.amplify(
            {"active_object": centred}, tiles="Nope")),
        "bad_choice_json": op_error(lambda: bpy.ops.rockvdb.block_tile(tile_size=6.0, voxel_size=0.1,
                                                                         use_fractures=True, fractures="[1, 2")),
        "open_bound": op_error(lambda: bpy.ops.rockvdb.fractal_rock(h_up=0.0)),
    }
    report["bad_scene_unchanged"] = scene_names() == before_names

    # Cancel mid-run (what Esc does in the modal operator): the worker stops within a second
    # and nothing is added.
    op = stages.STAGES[[s.name for s in stages.STAGES].index("block_tile")]
    before_names = scene_names()

    class Props:  # the block-tile operator's properties at their defaults, 2 cm voxels
        pass
    p = Props()
    for row in op.rows():
        setattr(p, row["prop"], row["default"])
        if row["derived"]:
            setattr(p, "auto_" + row["prop"], True)
        elif row["default"] is None:
            setattr(p, "use_" + row["prop"], False)
    p.voxel_size = 0.02
    cache = os.path.join(OUT, "cancelled.vdb")
    run = Run(op, op.keywords(p), {"cache": cache, "adaptivity": 0.0, "scale": 1.0}).start()
    # Mid-run: once it reports progress (a loaded machine may take longer than a second to
    # start), and a little after.
    started = time.time()
    while run.job.progress <= 0 and run.grids is None and time.time() - started < 30:
        time.sleep(0.05)
    time.sleep(0.3)
    progress = run.job.progress
    t0 = time.time()
    run.cancel()
    report["cancel"] = {"seconds": time.time() - t0, "cancelled": run.interrupted,
                        "finished_before": run.grids is not None, "error": run.error,
                        "progress_seen": progress, "scene_unchanged": scene_names() == before_names,
                        "cache_written": os.path.exists(cache)}

    # Blender's Unit Scale 0.01 (a centimetre scene): the same rock in metres, 100 scene
    # units across.
    bpy.context.scene.unit_settings.scale_length = 0.01
    none_selected()
    bpy.ops.rockvdb.fractal_rock()
    cm = bpy.context.active_object
    report["unit_scale"] = {"params": cm["rockvdb_params"], "dimensions": list(cm.dimensions),
                            "metre_dimensions": list(rock.dimensions)}
    shutil.copy(results.cache_file(cm["rockvdb_cache"]), os.path.join(OUT, "fractal_rock_cm.vdb"))
    bpy.context.scene.unit_settings.scale_length = 1.0

    rockvdb_blender.unregister()
    report["final_unregister"] = registered()
except Exception:
    report["errors"].append(traceback.format_exc())

with open(os.path.join(OUT, "report.json"), "w") as f:
    json.dump(report, f, indent=1, default=str)
