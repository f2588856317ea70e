# SPDX-License-Identifier: Apache-2.0
"""The Blender add-on (python/blender/rockvdb_blender) in headless Blender: addon_checks.py
registers it, runs every operator and reports; these tests judge the report against the C++
stage tables and the CLI tools, which run here, outside Blender."""
import inspect
import json
import os
import shutil
import subprocess

import numpy as np
import pytest

import rockvdb

from conftest import BUILD, arches_small_scene, assert_bitwise_equal, run, tool

HERE = os.path.dirname(os.path.abspath(__file__))
ADDON = os.path.join(HERE, "..", "..", "python", "blender")
PYDIR = os.path.join(BUILD, "python")

pytestmark = pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")

STAGES = ["fractal_rock", "fractal_scatter", "block_tile", "rock_pile", "amplify", "stacks",
          "detail"]


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    d = tmp_path_factory.mktemp("addon")
    scene = arches_small_scene(d, quantum=0.02)  # not the table's 0.01
    p = subprocess.run(["blender", "-b", "--factory-startup", "--python",
                        os.path.join(HERE, "addon_checks.py"), "--", ADDON, str(d), str(scene)],
                       env=dict(os.environ, PYTHONPATH=PYDIR), capture_output=True, text=True,
                       timeout=900)
    assert (d / "report.json").exists(), (p.returncode, p.stdout[-3000:], p.stderr[-3000:])
    return d


@pytest.fixture(scope="module")
def report(out):
    r = json.loads((out / "report.json").read_text())
    assert r["errors"] == [], r["errors"][0]
    return r


def grids(path):
    import pyopenvdb
    return {g.name: g for g in pyopenvdb.readAll(str(path))[0]}


def params_of(path):
    return json.loads(grids(path)["surface"]["rockvdb:params"])


def test_registers_and_unregisters_cleanly(report):
    ops = sorted(f"ROCKVDB_OT_{s}" for s in STAGES + ["regenerate", "export_vdb"])
    assert report["registered"] == ops
    assert report["menu"]
    assert report["after_unregister"] == []
    assert report["registered_again"] == ops
    assert report["final_unregister"] == []
    assert all(report["undo"][s] for s in STAGES)


def _table_rows():
    """{stage: [(property name, row)]}: the rows each operator must show, computed here from
    the tables and the rockvdb functions' signatures (outside Blender)."""
    import rockvdb
    from rockvdb import _rockvdb

    def rows(table, fn, prefix=""):
        taken = {p.name for p in inspect.signature(fn).parameters.values()
                 if p.kind == p.KEYWORD_ONLY}
        schema = json.loads(_rockvdb.schema(table))["params"]
        # the derived rows' values at the defaults (tables without any need no call)
        auto = json.loads(_rockvdb.derive(table, "{}")) if any(r["derived"] for r in schema) else {}
        return [(prefix + r["python"], dict(r, auto=auto.get(r["name"])))
                for r in schema if r["python"] in taken and r["name"] not in ("chunks", "chunk")]
    return {
        "fractal_rock": rows("fractal_rock", rockvdb.fractal_rock),
        "fractal_scatter": rows("fractal_scatter", rockvdb.fractal_scatter),
        "block_tile": rows("block_tile", rockvdb.block_tile),
        "rock_pile": rows("rock_tiles", rockvdb.rock_tiles, "tiles_") + rows("rock_pile", rockvdb.rock_pile),
        "amplify": rows("amplify", rockvdb.amplify),
        "stacks": [(n, r) for n, r in rows("arches", rockvdb.Stacks)] +
                  [(r["python"], r) for r in json.loads(_rockvdb.schema("arches"))["params"]
                   if r["python"] == "terrain"],
        "detail": rows("detail", rockvdb.detail),
    }


def _in_range(value, r):
    lo, hi = r["min"], r["max"]
    v = np.float32(value)
    return ((lo is None or (v > np.float32(lo) if r["min_open"] else v >= np.float32(lo))) and
            (hi is None or (v < np.float32(hi) if r["max_open"] else v <= np.float32(hi))))


def test_properties_equal_the_tables(report):
    """Every row of every stage is a property with the row's default, limits, length and
    help; no property repeats a row under another name. No default is a sentinel: a derived
    row's box is Auto (on) beside its rule's value, which lies in the row's range, as does
    every other number's default (issue 55)."""
    tables = _table_rows()
    for stage, rows in tables.items():
        props = report["props"][stage]
        own = {"amplify": {"tiles", "terrain_as"}, "stacks": {"scene", "mesh_voxel"},
               "fractal_scatter": {"instances"}, "rock_pile": {"instances"}}.get(stage, set())
        panel = {"quality", "preview_voxel"} | {p for p in props if p.startswith("show_")}
        extra = set(props) - {name for name, _ in rows} - {"target", "source"} - own - panel - \
            {"use_" + name for name, r in rows if r["default"] is None and not r["derived"]} - \
            {"auto_" + name for name, r in rows if r["derived"]}
        assert not extra, (stage, extra)
        assert len(rows) > 5
        assert props["quality"]["default"] == "PREVIEW" and props["quality"]["items"] == ["PREVIEW", "FINAL"]
        shows = [p for p in props if p.startswith("show_")]
        assert len(shows) >= 2 and sum(props[p]["default"] for p in shows) == 1, (stage, shows)
        for name, r in rows:
            p = props[name]
            assert r["help"] in p["description"], (stage, name)
            derived, unset = bool(r["derived"]), r["default"] is None and not r["derived"]
            if derived:
                assert props["auto_" + name]["default"] is True, (stage, name)
            if unset:
                assert props["use_" + name]["default"] is False
            if r["type"] in ("int", "ints", "float", "floats"):
                assert p["type"] == ("INT" if r["type"] in ("int", "ints") else "FLOAT"), name
                assert p["length"] == (r["count"] if r["type"] in ("ints", "floats") else 0), name
                got = p["default"] if isinstance(p["default"], list) else [p["default"]]
                # no sentinel: every default inside the row's documented range
                assert all(_in_range(v, r) for v in got), (stage, name, got, r["range"])
                if not unset:
                    want = r["auto"] if derived else r["default"]
                    want = want if isinstance(want, list) else [want]
                    # Blender keeps 32-bit floats: the default as a float32.
                    assert np.array_equal(np.float32(got), np.float32(want)), (stage, name, got, want)
                integer = r["type"] in ("int", "ints")
                # The range is the soft range; a value typed beyond it reaches the stage,
                # which names it as typed.
                if r["min"] is not None:
                    lo = r["min"] + (1 if integer and r["min_open"] else 0)
                    assert np.float32(p["soft_min"]) == np.float32(lo), (stage, name, p["soft_min"], r["range"])
                    assert p["min"] < lo
                if r["max"] is not None:
                    hi = r["max"] - (1 if integer and r["max_open"] else 0)
                    assert np.float32(p["soft_max"]) == np.float32(hi), (stage, name, p["soft_max"], r["range"])
                if r["unit"] == "m":
                    assert p["unit"] == "LENGTH", name
                if r["count"] == 3:  # X / Y / Z labels
                    assert p["subtype"] in ("XYZ", "TRANSLATION", "XYZ_LENGTH", "DIRECTION"), (stage, name, p["subtype"])
            elif r["type"] == "bool":
                assert p["type"] == "BOOLEAN" and p["default"] == r["default"], name
            elif r["choices"]:
                assert p["type"] == "ENUM" and p["items"] == r["choices"], name
                assert p["default"] == r["default"], name
            else:
                assert p["type"] == "STRING", name
                if r["type"] == "str":
                    assert p["default"] == r["default"], name
                if r["file"]:  # a file browser
                    assert p["subtype"] == "FILE_PATH", (stage, name)


def test_descriptions_are_one_plain_sentence(report):
    """Each operator's tooltip is one sentence an artist reads: no paper citation, not cut."""
    for stage, text in report["descriptions"].items():
        assert text.endswith(".") and text.count(". ") == 0, (stage, text)
        assert "§" not in text and "et al" not in text and len(text) < 120, (stage, text)


def test_the_same_call_again_reuses_its_result(report):
    """The redo panel re-runs the operator when a group opens or closes: an unchanged call takes
    the last result (one bake for two calls; a changed seed bakes), in a file of its own; a
    file the call names, edited in between, bakes again."""
    assert report["same_call"] == {"bakes": 1, "scene_file_bakes": 2, "own_file": True,
                                   "same_bytes": True, "vertices": True}


def test_addon_no_default_written_twice():
    """The add-on's source names no stage row's default: its properties come from the tables
    (a number written beside a row name would be a second truth)."""
    import re
    src = ""
    for f in os.listdir(os.path.join(ADDON, "rockvdb_blender")):
        if f.endswith(".py"):
            src += open(os.path.join(ADDON, "rockvdb_blender", f)).read()
    for stage, rows in _table_rows().items():
        for name, r in rows:
            assert not re.search(rf"(?<![.\w]){name}\s*=\s*[-0-9(\[]", src), (stage, name)
            assert not re.search(rf"[\"']{r['name']}[\"']\s*:\s*[-0-9(\[]", src), (stage, name)


def test_results_hold_their_grids_meshed_and_tinted(report):
    R = report["results"]
    want = {"fractal_rock": ["surface"], "block_tile": ["block_id", "surface"],
            "detail": ["surface"], "rock_pile": ["rock_id", "surface"],
            "rock_pile_material": ["material", "rock_id", "surface"],
            "fractal_scatter_mesh": ["rock_id", "surface"],
            "fractal_scatter_plane": ["material", "rock_id", "surface"],
            "amplify": ["block_id", "material", "surface"],
            "amplify_heightfield": ["block_id", "material", "surface"]}
    for name, names in want.items():
        r = R[name]
        assert r["volume_grids"] == names, name
        # real mesh data (saved in the .blend): nothing evaluated on the UI thread
        assert r["modifiers"] == [] and r["children"] == [] and r["mesh_users"] == 1, name
        assert r["vertices"] > 300, name
        ids = [g for g in ("material", "block_id", "rock_id") if g in names]
        assert sorted(r["attributes"]) == sorted(ids), name
        assert r["tint"] == ids[:1], name
    # material stacks: the ground 'surface' meshed, its 'material' ids and weight_* grids on
    # the vertices, textured by the weights (arches §6: three triplanar noise patterns per
    # material, blended by the weight attributes, which sum to 1 where the ground is visible)
    for name in ("stacks", "stacks_scene"):
        r = R[name]
        assert "surface" in r["volume_grids"] and "material" in r["volume_grids"], name
        assert r["modifiers"] == [], name
        assert r["vertices"] > 500, name
        assert "weight_bedrock" in r["weights"], name
        assert r["tint"] == sorted(r["weights"]), name
        assert r["noise_textures"] == 3 * len(r["weights"]), name
        # vdb_preview --texture's colours (one table: rockvdb.material_colour)
        expected = sorted(rockvdb.material_colour(w[len("weight_"):]) for w in r["weights"])
        assert np.allclose(r["colours"], expected, atol=1e-6), (name, r["colours"], expected)
        # (the floor of the terrain's block faces nothing: no weights there)
        assert r["weights_sum_one"] > 0.95 and r["weights_none"] < 0.35, (name, r["weights_sum_one"], r["weights_none"])
    assert set(R["stacks_scene"]["weights"]) == {"weight_sand", "weight_bedrock", "weight_rocks"}
    assert all(hi > 0.5 for lo, hi in R["stacks_scene"]["weights"].values()), R["stacks_scene"]["weights"]
    assert R["stacks"]["attributes"]["material"] == [3]             # bedrock only
    assert {2, 3, 4} <= set(R["stacks_scene"]["attributes"]["material"])  # sand, bedrock, rocks
    # amplify: terrain (material 0) and blocks; two strata, two tiles' materials
    assert R["amplify"]["attributes"]["material"] == [0, 1]
    assert R["amplify_heightfield"]["attributes"]["material"] == [0, 1, 2]
    # ids reach the mesh: many blocks and rocks, one material where one was asked for
    assert len(R["block_tile"]["attributes"]["block_id"]) > 30
    assert len(R["rock_pile"]["attributes"]["rock_id"]) > 30
    assert R["rock_pile_material"]["attributes"]["material"] == [3]
    assert R["fractal_scatter_plane"]["attributes"]["material"] == [4]
    assert len(R["fractal_scatter_plane"]["attributes"]["rock_id"]) == 6
    # non-defaults change the result; detail at its defaults changes the rock (issue 55)
    assert R["fractal_rock_seed5"]["vertices"] != R["fractal_rock"]["vertices"]
    assert R["detail"]["vertices"] != R["fractal_rock"]["vertices"]
    assert R["detail_warp"]["vertices"] != R["detail"]["vertices"]
    assert R["block_tile_tabular"]["vertices"] != R["block_tile"]["vertices"]


def test_scatter_rests_on_the_active_mesh_or_the_plane(report):
    """The grid sheet sits at z = 1; without a selection the ground is z = 0. Rocks are sunk
    by embed (15 % of their height), so their lowest points are just below the ground."""
    R = report["results"]
    assert 0.6 < R["fractal_scatter_mesh"]["min"][2] < 1.0
    assert -0.4 < R["fractal_scatter_plane"]["min"][2] < 0.0


CLI = {"vdb_fractal_rock": "vdb_fractal_rock", "vdb_blocks": "vdb_blocks",
       "vdb_rockpile": "vdb_rockpile"}


@pytest.mark.parametrize("name", ["fractal_rock", "fractal_rock_seed5", "block_tile",
                                  "block_tile_tabular", "rock_pile_material",
                                  "fractal_scatter_plane", "fractal_scatter_mesh", "amplify",
                                  "amplify_heightfield", "stacks", "stacks_scene"])
def test_cli_replays_the_addon_bit_for_bit_and_meshes_alike(report, out, tmp_path, name):
    """The result's own provenance through the CLI (--params) gives the same grids, and
    vdb_mesh of the CLI's file at the result's adaptivity gives the mesh Blender holds (the
    same volumeToMesh: the same vertex count)."""
    r = report["results"][name]
    mine = out / f"{name}.vdb"
    params = tmp_path / "params.json"
    params.write_text(json.dumps(params_of(mine)))
    again = tmp_path / "cli.vdb"
    run([tool(r["rockvdb_generator"]), "-q", "--params", str(params), "-o", str(again)], check=True)
    a, b = grids(mine), grids(again)
    assert sorted(a) == sorted(b)
    for g in a:
        assert_bitwise_equal(a[g], b[g])
    obj = tmp_path / "cli.obj"
    run([tool("vdb_mesh"), str(again), "-q", "--adaptivity", repr(r["rockvdb_mesh_adaptivity"]),
         "-o", str(obj)], check=True)
    verts = sum(1 for line in open(obj) if line.startswith("v "))
    assert verts == r["vertices"], (verts, r["vertices"])


def test_detail_of_a_result_is_vdb_detail_of_its_file(report, out, tmp_path):
    """Detail on the Block Tile result: vdb_detail on that result's grids gives the same
    surface and carried block_id, bit for bit."""
    cli = tmp_path / "detail.vdb"
    run([tool("vdb_detail"), "-q", str(out / "block_tile.vdb"), "--warp-amplitude", "0.05",
         "-o", str(cli)], check=True)
    a, b = grids(out / "detail_tile.vdb"), grids(cli)
    assert sorted(a) == sorted(b) == ["block_id", "surface"]
    for g in a:
        assert_bitwise_equal(a[g], b[g])
    assert len(report["results"]["detail_tile"]["attributes"]["block_id"]) > 30


def test_every_operator_runs_at_its_defaults(report):
    """Block Tile, Rock Pile, Material Stacks and Amplify with no property set but their
    inputs: each runs, and its provenance holds the table's defaults for every row."""
    from rockvdb import _rockvdb
    tables = {"block_tile": "block_tile", "rock_pile": "rock_pile", "stacks": "arches",
              "amplify": "amplify"}
    for stage, table in tables.items():
        d = report["defaults"][stage]
        assert d["ran"] == ["FINISHED"], stage
        params = json.loads(d["params"])
        params = params.get("pile", params)  # vdb_rockpile nests the pile's rows
        for row in json.loads(_rockvdb.schema(table))["params"]:
            if row["default"] is None or row["derived"] or row["name"] in ("terrain", "strata"):
                continue
            if row["resolution"]:  # Preview's voxel (test_defaults_are_the_clis_defaults)
                continue
            got = params.get(row["name"])
            assert got == row["default"] or (isinstance(got, float) and
                                             np.float32(got) == np.float32(row["default"])), \
                (stage, row["name"], got, row["default"])


def test_defaults_are_the_clis_defaults(report, tmp_path):
    """The add-on's operators at their defaults pass the parameters the CLI's defaults are
    (Blender's 32-bit floats read back as the decimals the table gives)."""
    from rockvdb import _rockvdb
    # Final: the CLI's defaults, bit for bit; Preview: the same with the preview rule's voxel
    # (a result's extent / PREVIEW_VOXELS_ACROSS, three digits), meshed at its adaptivity.
    cli = tmp_path / "rock.vdb"
    run([tool("vdb_fractal_rock"), "-q", "-o", str(cli)], check=True)
    final = params_of(cli)
    assert json.loads(report["results"]["fractal_rock_final"]["rockvdb_params"]) == final
    assert report["results"]["fractal_rock_final"]["rockvdb_mesh_adaptivity"] == 0.0
    preview = json.loads(report["results"]["fractal_rock"]["rockvdb_params"])
    voxel = _rockvdb.preview_voxel_size(final["voxel-size"], 2 * max(final["size"]))
    assert preview == dict(final, **{"voxel-size": float(f"{voxel:.3g}")})
    assert preview["voxel-size"] > final["voxel-size"]
    assert report["results"]["fractal_rock"]["rockvdb_mesh_adaptivity"] == _rockvdb.PREVIEW_ADAPTIVITY
    cli = tmp_path / "tile.vdb"
    run([tool("vdb_blocks"), "-q", "--tile-size", "6", "--voxel-size", "0.1", "-o", str(cli)],
        check=True)
    assert json.loads(report["results"]["block_tile"]["rockvdb_params"]) == params_of(cli)
    cli = tmp_path / "scatter.vdb"
    run([tool("vdb_fractal_rock"), "-q", "--count", "6", "--voxel-size", "0.05", "--seed", "2",
         "--area=-4,-4,4,4", "--material", "4", "-o", str(cli)], check=True)
    assert json.loads(report["results"]["fractal_scatter_plane"]["rockvdb_params"]) == params_of(cli)


def test_scatter_as_instances_places_each_rock_where_the_level_set_has_it(report, out):
    """With instances, each rock is its own mesh instanced at the stage's position and
    orientation: the instances sit at the positions the stage reports, and together they span
    the level set's mesh (within two voxels), which is hidden."""
    import rockvdb
    stats = {}
    rockvdb.fractal_scatter(None, count=6, voxel_size=0.05, seed=2, area=(-4, -4, 4, 4),
                            material=4, stats=stats)
    inst = report["instances"]
    assert inst["rocks"] == 6 and inst["points"] == 6 and not inst["surface_shown"]
    assert inst["tint"] == ["INSTANCER"]
    got = sorted(map(tuple, np.round(inst["translations"], 4)))
    want = sorted(map(tuple, np.round(np.asarray(stats["positions"]), 4)))
    assert got == want
    level_set = report["results"]["fractal_scatter_plane"]
    assert np.allclose(inst["min"], level_set["min"], atol=0.1)
    assert np.allclose(inst["max"], level_set["max"], atol=0.1)
    # the level set itself is the scatter's, bit for bit (grids unchanged by the option)
    assert inst["result"]["rockvdb_params"] == level_set["rockvdb_params"]
    a, b = grids(out / "scatter_instances.vdb"), grids(out / "fractal_scatter_plane.vdb")
    for g in a:
        assert_bitwise_equal(a[g], b[g])
    # each instance carries the rock_id the level set has at its seed (the tint agrees)
    acc = a["rock_id"].getConstAccessor()
    for t, rid in zip(inst["translations"], inst["rock_ids"]):
        i, j, k = (int(round(c / 0.05)) for c in t)
        # up from the seed (inside the rock, below its band) to the rock's first id voxel
        above = next(v for v in (acc.getValue((i, j, k + d)) for d in range(200)) if v != -1)
        assert above == rid


def test_pile_as_instances_moves_each_library_rock_onto_the_pile(report, out):
    """With instances, the pile's rocks are its tile set's rocks instanced at their shifts:
    the mesh of every instanced rock lies on the pile's surface (median within half a voxel,
    the nearest-voxel read), each instance carries the rock_id the pile has there, and a rock
    used twice is one mesh."""
    inst = report["pile_instances"]
    r = inst["result"]
    assert not inst["surface_shown"] and inst["tint"] == ["INSTANCER"]
    assert inst["points"] == len(inst["translations"]) > 30
    assert inst["rocks"] <= inst["points"]
    assert np.allclose(inst["min"], report["results"]["rock_pile_material"]["min"], atol=0.1)
    assert np.allclose(inst["max"], report["results"]["rock_pile_material"]["max"], atol=0.1)
    # the level set is the plain pile's, bit for bit
    a, b = grids(out / "pile_instances.vdb"), grids(out / "rock_pile_material.vdb")
    for g in a:
        assert_bitwise_equal(a[g], b[g])
    # every instance's id is the pile's id under its mesh: instances sit where the pile has
    # its rocks, and the tint agrees
    assert sorted(inst["rock_ids"]) == list(range(inst["points"]))
    acc, dx = a["rock_id"].getConstAccessor(), a["surface"].transform.voxelSize()[0]
    agree = 0
    for rid, pts in zip(inst["rock_ids"], inst["samples"]):
        vals = [acc.getValue(tuple(int(round(c / dx)) for c in p)) for p in pts]
        agree += max(set(vals), key=vals.count) == rid
    assert agree >= 0.95 * inst["points"], (agree, inst["points"])


def test_regenerate_in_place_gives_the_same_bits(report, out):
    assert report["regenerate"] == {"same_object": True, "scene_unchanged": True, "new_cache": True}
    a, b = grids(out / "regen_before.vdb"), grids(out / "regen_after.vdb")
    assert sorted(a) == sorted(b) == ["surface"]
    assert_bitwise_equal(a["surface"], b["surface"])


def test_regenerate_reads_the_stored_input_object(report, out):
    """A pile regenerated while the pile itself is active reads its cube again: same bits. Its
    tile rows did not change, so its tile set is the first one's file (linked, not remade)."""
    assert report["regenerate_pile_same_object"]
    assert report["regenerate_pile_tiles"] == {"new_name": True, "same_file": True}
    a, b = grids(out / "regen_pile_before.vdb"), grids(out / "regen_pile_after.vdb")
    assert sorted(a) == sorted(b) == ["rock_id", "surface"]
    for g in a:
        assert_bitwise_equal(a[g], b[g])


def test_regenerate_keeps_a_scene_files_keys(report, out):
    """Stacks from a scene file (quantum 0.02, the table says 0.01), regenerated: the stored
    call holds only what it set, so the scene's quantum holds again; same bits."""
    assert report["regenerate_stacks_operator"] == {"scene": report["regenerate_stacks_operator"]["scene"],
                                                    "source": ""}
    assert json.loads(report["results"]["stacks_scene"]["rockvdb_params"])["quantum"] == 0.02
    a, b = grids(out / "regen_stacks_before.vdb"), grids(out / "regen_stacks_after.vdb")
    assert sorted(a) == sorted(b)
    for g in a:
        assert_bitwise_equal(a[g], b[g])


def test_export_writes_the_grids_with_the_clis_provenance(report, out):
    exported = grids(out / "exported.vdb")
    assert sorted(exported) == ["surface"]
    assert_bitwise_equal(exported["surface"], grids(out / "regen_after.vdb")["surface"])
    s = exported["surface"]
    assert s["rockvdb:generator"] == "vdb_fractal_rock"
    assert json.loads(s["rockvdb:params"]) == json.loads(report["results"]["fractal_rock"]["rockvdb_params"])
    p = run([tool("vdb_info"), "--json", str(out / "exported.vdb")], check=True)
    assert json.loads(p.stdout)[0]["grids"][0]["rockvdb"]["generator"] == "vdb_fractal_rock"


def test_bad_input_is_a_one_line_report_and_adds_nothing(report):
    bad = report["bad"]
    # a bad value is reported as typed (not clamped to the range first)
    assert bad["voxel_as_typed"].startswith("Error: rockvdb.fractal_rock: ")
    assert "voxel_size must be in [1e-06, 1000000] (got -1" in bad["voxel_as_typed"], bad["voxel_as_typed"]
    assert "select a mesh object" in bad["pile_no_mesh"]
    assert "select a rockvdb result" in bad["detail_no_result"]
    assert "fractures: not valid JSON" in bad["bad_choice_json"]
    assert "h_up must be in (0, 1)" in bad["open_bound"]
    assert "select a mesh object" in bad["stacks_no_terrain"]
    assert "a heightfield starts at the world origin" in bad["amplify_heightfield_origin"]
    assert "'Nope' is neither a Block Tile result nor a .tile file" in bad["amplify_unknown_tile"]
    for message in bad.values():
        assert message.count("\n") == 1 and message.endswith("\n"), message
    assert report["bad_scene_unchanged"]


def test_cancel_stops_within_a_second_and_adds_nothing(report):
    c = report["cancel"]
    assert c["cancelled"] and not c["finished_before"] and c["error"] is None
    assert 0 < c["progress_seen"] < 1
    assert c["seconds"] < 1.0
    assert c["scene_unchanged"] and not c["cache_written"]


@pytest.mark.skipif(not shutil.which("xvfb-run"), reason="xvfb not installed")
def test_modal_run_keeps_blender_responsive_esc_cancels_and_undo_removes(tmp_path):
    """Blender with a window (Xvfb): an operator started as from the menu returns
    RUNNING_MODAL and the event loop keeps ticking while the stage works on its thread; Esc
    ends the worker and adds nothing; a finished result is one undo step."""
    out = tmp_path / "modal.json"
    build_addons = os.path.join(BUILD, "blender")
    p = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x800x24", "blender",
                        "--factory-startup", "--enable-event-simulate", "--python",
                        os.path.join(HERE, "modal_checks.py"), "--", str(out)],
                       env=dict(os.environ, PYTHONPATH=PYDIR, BLENDER_USER_SCRIPTS=build_addons),
                       capture_output=True, text=True, timeout=600, cwd=str(tmp_path))
    assert out.exists(), (p.returncode, p.stdout[-3000:], p.stderr[-3000:])
    r = json.loads(out.read_text())
    assert r["errors"] == [], r["errors"][0]
    assert r["invoke"] == ["RUNNING_MODAL"]
    assert r["tick_after"] < 1.5                      # the UI was not blocked
    assert r["workers_during"] == ["rockvdb block_tile"]
    assert r["during"] == r["start"]                  # nothing before the grids are complete
    assert r["workers_after_esc"] == [] and r["after_esc"] == r["start"]
    assert r["invoke_rock"] == ["RUNNING_MODAL"]
    assert r["workers_after_rock"] == []
    assert sorted(set(r["after_rock"]) - set(r["start"])) == ["Fractal Rock"]
    assert r["after_undo"] == r["start"]


def _blender_script(script, *args):
    return subprocess.run(["blender", "-b", "--factory-startup", "--python",
                           os.path.join(HERE, script), "--", ADDON, *map(str, args)],
                          env=dict(os.environ, PYTHONPATH=PYDIR), capture_output=True,
                          text=True, timeout=900)


@pytest.fixture(scope="module")
def persisted(tmp_path_factory):
    """Every operator at its defaults in an unsaved file, saved, Blender quit (issue 55)."""
    d = tmp_path_factory.mktemp("persist")
    (d / "a").mkdir()
    p = _blender_script("persist_checks.py", "make", d / "a")
    made = d / "a" / "made.json"
    assert made.exists(), (p.returncode, p.stdout[-3000:], p.stderr[-3000:])
    r = json.loads(made.read_text())
    assert r["errors"] == [], r["errors"][0]
    return d, r


def _reopen(blend):
    p = _blender_script("persist_checks.py", "check", blend)
    checked = blend.parent / "checked.json"
    assert checked.exists(), (p.returncode, p.stdout[-3000:], p.stderr[-3000:])
    r = json.loads(checked.read_text())
    assert r["errors"] == [], r["errors"][0]
    return r, p.stderr


def _by_stage(results):
    return {v["stage"]: v for v in results.values()}


def test_every_default_is_light_and_does_something(persisted, tmp_path):
    """Each operator at its defaults (Quality Preview): at most 500 k vertices, and a visible
    result: rocks scattered, blocks and rocks with their ids, Detail's surface moved."""
    import pyopenvdb
    _, made = persisted
    assert all(s == ["FINISHED"] for s in made["status"].values()), made["status"]
    R = made["results"]
    for stage, r in R.items():
        assert 200 < r["vertices"] <= 500_000, (stage, r["vertices"])
    assert len(R["fractal_scatter"]["ids"]["rock_id"]["values"]) >= 3      # rocks scattered
    assert len(R["block_tile"]["ids"]["block_id"]["values"]) > 30
    assert len(R["rock_pile"]["ids"]["rock_id"]["values"]) > 10
    assert len(R["amplify"]["ids"]["block_id"]["values"]) > 5
    # Detail moved the rock's surface: the detailed level set, read at the rock's own surface
    # voxels, is off zero by a good part of the warp amplitude.
    moved_to = made["cache_dir_after_save"]  # the caches followed the .blend on save
    rock = pyopenvdb.read(os.path.join(moved_to, os.path.basename(made["rock_cache"])), "surface")
    detail = pyopenvdb.read(os.path.join(moved_to, os.path.basename(made["detail_cache_before_save"])),
                            "surface")
    amplitude = json.loads(detail["rockvdb:params"])["warp-amplitude"]
    assert amplitude > 0
    dx, acc = rock.transform.voxelSize()[0], detail.getConstAccessor()
    moved = [abs(acc.getValue(item.min)) for item in rock.citerOnValues()
             if item.count == 1 and abs(item.value) < 0.5 * dx]
    assert len(moved) > 100 and max(moved) > 0.3 * amplitude, (len(moved), max(moved or [0]), amplitude)


def test_results_survive_save_quit_and_reopen(persisted):
    """Made in an unsaved file, saved, Blender quit and its temporary folder deleted: a new
    Blender shows every result with the same mesh and ids, its grids found beside the .blend."""
    d, made = persisted
    shutil.rmtree(made["tempdir"], ignore_errors=True)
    assert made["after_save"] == made["results"]  # the same names, now beside the .blend
    r, _ = _reopen(d / "a" / "scene.blend")
    got = _by_stage(r["results"])
    for stage, want in made["results"].items():
        assert got[stage]["vertices"] == want["vertices"] > 200, stage
        assert got[stage]["ids"] == want["ids"], stage
        assert got[stage]["co_sum"] == want["co_sum"], stage
        assert got[stage]["cache_missing"] is None, stage
    assert len(r["grids"]) == len(made["results"])
    assert all("surface" in g for g in r["grids"].values())


def test_results_survive_moving_the_blend_with_its_cache_folder(persisted):
    """The .blend and its rockvdb_cache folder moved together: the same results, grids found;
    a cache deleted: the mesh still shows and one line names the missing file."""
    d, made = persisted
    shutil.copytree(d / "a", d / "b")
    shutil.rmtree(d / "a" / "rockvdb_cache", ignore_errors=True)  # the old place is gone
    r, _ = _reopen(d / "b" / "scene.blend")
    got = _by_stage(r["results"])
    for stage, want in made["results"].items():
        assert got[stage]["vertices"] == want["vertices"], stage
        assert got[stage]["ids"] == want["ids"], stage
        assert got[stage]["cache_missing"] is None, stage
    # One cache lost: its result keeps its mesh, and the file is named in one line.
    lost = got["block_tile"]["cache"]
    os.remove(d / "b" / "rockvdb_cache" / lost)
    r, stderr = _reopen(d / "b" / "scene.blend")
    got = _by_stage(r["results"])
    assert got["block_tile"]["vertices"] == made["results"]["block_tile"]["vertices"]
    assert got["block_tile"]["cache_missing"].endswith(lost)
    lines = [line for line in stderr.splitlines() if "cache" in line and lost in line]
    assert len(lines) == 1 and "Regenerate" in lines[0], stderr[-2000:]


def test_unit_scale_is_applied(report, out):
    """Unit Scale 0.01: the defaults are the table's metres, so the rock is the metre scene's
    bit for bit, and its mesh is 1 m of scene length (100 scene units) across."""
    u = report["unit_scale"]
    assert json.loads(u["params"]) == json.loads(report["results"]["fractal_rock"]["rockvdb_params"])
    a, b = grids(out / "fractal_rock_cm.vdb"), grids(out / "fractal_rock.vdb")
    assert_bitwise_equal(a["surface"], b["surface"])
    assert np.allclose(np.array(u["dimensions"]) * 0.01, u["metre_dimensions"], rtol=1e-5)
    assert max(u["metre_dimensions"]) > 0.5
