# SPDX-License-Identifier: Apache-2.0
"""rockvdb.Stacks: material stacks from Python (arches §3, §6) - the same stacks and grids as
vdb_arches for the same scene, stabilisation that conserves every material, numpy views that
agree with the stacks, files that round-trip, and bad input refused with one clear error."""
import json
import os
import re
import shutil
import subprocess

import numpy as np
import pyopenvdb as vdb
import pytest

import rockvdb
from conftest import arches_small_scene as small_scene, assert_bitwise_equal, run, tool

AR = tool("vdb_arches")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
GROUND = ("sand", "bedrock", "rocks")


def by_name(path):
    return {g.name: g for g in vdb.readAll(str(path))[0]}


def same_grids(cli_path, py):
    cli = by_name(cli_path)
    assert list(py) == [g.name for g in vdb.readAll(str(cli_path))[0]]  # the file's order
    assert sorted(cli) == sorted(py)
    for name, g in py.items():
        if g.activeVoxelCount() == 0:  # a material too thin for σ (the small scene's rocks)
            assert cli[name].activeVoxelCount() == 0
        else:
            assert_bitwise_equal(cli[name], g)
        assert g.metadata["rockvdb:generator"] == "vdb_arches"
        assert json.loads(g.metadata["rockvdb:params"]) == json.loads(cli[name].metadata["rockvdb:params"])


@pytest.fixture(scope="module")
def cliff_scene(tmp_path_factory):
    """A heightfield with a steep scarp under 1.5 m of sand: the sand must slide."""
    d = tmp_path_factory.mktemp("cliff")
    x = np.arange(48, dtype=np.float32)
    rows = np.tile(np.where(x < 20, 12.0, 2.0) + 0.05 * x, (32, 1)).astype(np.float32)
    rockvdb.write_heightfield(str(d / "scarp.exr"), rows)
    scene = {"terrain": {"type": "heightfield", "file": "scarp.exr", "cell_size": 0.5},
             "sand-depth": 1.5, "quantum": 0.01}
    (d / "scene.json").write_text(json.dumps(scene))
    return d / "scene.json"


def test_python_and_the_cli_give_the_same_grids_for_the_same_scene(tmp_path):
    scene = small_scene(tmp_path)
    run([AR, "-q", str(scene), "-o", str(tmp_path / "cli.vdb"), "--stacks", str(tmp_path / "cli.stacks")],
        check=True)
    s = rockvdb.Stacks.from_scene(scene)
    same_grids(tmp_path / "cli.vdb", s.bake(path=tmp_path / "py.vdb"))
    # The file too: the same grids in the same order (ids first, the ground last).
    assert [g.name for g in vdb.readAll(str(tmp_path / "py.vdb"))[0]] == \
        [g.name for g in vdb.readAll(str(tmp_path / "cli.vdb"))[0]]
    assert vdb.readAll(str(tmp_path / "cli.vdb"))[0][-1].name == "surface"
    # The terrain given as a dict with the same keywords: the same stacks.
    params = json.load(open(scene))
    terrain = params.pop("terrain")
    t = rockvdb.Stacks(terrain, **{k.replace("-", "_"): v for k, v in params.items()})
    assert t == s and t.params == s.params
    assert rockvdb.Stacks.load(tmp_path / "cli.stacks") == s


def test_stabilize_conserves_every_material_leaves_bedrock_and_is_the_clis(tmp_path, cliff_scene):
    raw = rockvdb.Stacks.from_scene(cliff_scene, stabilize=False)
    before = {m: raw.volume(m) for m in GROUND}
    bedrock = raw.thickness("bedrock"), raw.top("bedrock")
    assert raw.params["stabilize"] is False and raw.stabilize_stats["moves"] == 0
    stats = raw.stabilize()
    assert stats["moves"] > 100 and stats["moved_quanta"] > 0
    assert {m: raw.volume(m) for m in GROUND} == before  # whole quanta: exactly
    assert np.array_equal(raw.thickness("bedrock"), bedrock[0])
    assert np.array_equal(raw.top("bedrock"), bedrock[1], equal_nan=True)
    # At rest: no sand slope between 8-neighbours steeper than the repose angle (+ one quantum
    # over the diagonal's run, the rounding of whole-quantum moves).
    top = raw.top()
    s, q = raw.cell_size, raw.quantum
    sand = raw.thickness("sand") > 0
    tan = np.tan(np.radians(raw.params["repose-sand"]))
    for dj, di in [(0, 1), (1, 0), (1, 1), (1, -1)]:
        run_ = s * np.hypot(di, dj)
        a = top[max(0, -dj):top.shape[0] - max(0, dj), max(0, -di):top.shape[1] - max(0, di)]
        b = top[max(0, dj):, max(0, di):][:a.shape[0], :a.shape[1]]
        sa = sand[max(0, -dj):top.shape[0] - max(0, dj), max(0, -di):top.shape[1] - max(0, di)]
        sb = sand[max(0, dj):, max(0, di):][:a.shape[0], :a.shape[1]]
        drop = a - b
        # Sand on the high side that could slide: the drop is within the angle.
        high = np.where(drop > 0, sa, sb)
        assert np.all(np.abs(drop)[high] <= run_ * tan + q + 1e-9)
    # Again: already at rest, nothing moves and nothing changes.
    copy = raw.arrays()
    assert raw.stabilize()["moves"] == 0
    assert all(np.array_equal(copy[k], raw.arrays()[k]) for k in copy)
    # Built stabilised (the default), the stacks are the same; so are vdb_arches' grids.
    assert rockvdb.Stacks.from_scene(cliff_scene) == raw and raw.params["stabilize"] is True
    run([AR, "-q", str(cliff_scene), "-o", str(tmp_path / "cli.vdb")], check=True)
    same_grids(tmp_path / "cli.vdb", raw.bake())


def test_numpy_views_agree_with_the_stacks(tmp_path):
    s = rockvdb.Stacks.from_scene(small_scene(tmp_path))
    a = s.arrays()
    ny, nx = s.shape
    assert a["offsets"].shape == (nx * ny + 1,) and a["offsets"][-1] == len(a["material"])
    # Per stack: contiguous layers from z0, runs merged, as layers(i, j) gives them.
    for (i, j) in [(0, 0), (7, 3), (nx - 1, ny - 1), (20, 15)]:
        k = j * nx + i
        lo, hi = a["offsets"][k], a["offsets"][k + 1]
        names = ["air", "water", "sand", "bedrock", "rocks"]
        got = [(names[m], t) for m, t in zip(a["material"][lo:hi], a["thickness_m"][lo:hi])]
        assert [(m, pytest.approx(t)) for m, t in s.layers(i, j)] == got
        assert np.array_equal(a["bottom"][lo + 1:hi], (a["bottom"] + a["thickness"])[lo:hi - 1])
        assert all(a["material"][lo:hi - 1] != a["material"][lo + 1:hi])
    for mid, m in [(2, "sand"), (3, "bedrock"), (4, "rocks")]:
        quanta = int(a["thickness"][a["material"] == mid].sum())
        assert s.volume(m) == pytest.approx(quanta * s.cell_size ** 2 * s.quantum, rel=1e-12)
        assert s.thickness(m).sum() == pytest.approx(quanta * s.quantum, rel=1e-9)
    # The strata's air band: overhangs are air between ground below and above.
    assert (a["material"] == 0).sum() > 0
    top = s.top()
    assert top.shape == (ny, nx) and not np.isnan(top).any()
    assert s.bytes < 3 * len(a["material"]) + nx * ny + 64  # delta-coded: under 3 bytes a layer


def test_each_grid_is_the_same_whichever_bake_asks_for_it(tmp_path):
    s = rockvdb.Stacks.from_scene(small_scene(tmp_path))
    grids = s.bake()
    surface, material = grids["surface"], grids["material"]
    materials = [grids[m] for m in ("sand", "bedrock", "rocks")]
    weights = [grids[w] for w in ("weight_sand", "weight_bedrock", "weight_rocks")]
    assert list(grids) == ["material", "weight_sand", "weight_bedrock", "weight_rocks", "sand", "bedrock",
                           "rocks", "surface"]
    for w, again in zip(weights, s.bake("weights")):
        assert_bitwise_equal(w, again)
    assert_bitwise_equal(surface, s.bake("surface"))
    assert_bitwise_equal(surface, s.bake("ground"))
    for g in materials:
        if g.activeVoxelCount():
            assert_bitwise_equal(g, s.bake(g.name))
    su, ids = s.bake("material")
    assert_bitwise_equal(su, surface)
    assert_bitwise_equal(ids, material)
    water = s.bake("water")  # no water in these strata: an empty level set
    assert water.name == "water" and water.activeVoxelCount() == 0
    # Bake rows: recorded, so the file replays through vdb_arches --params.
    coarse = s.bake("surface", voxel_size=1.0)
    prov = json.loads(coarse.metadata["rockvdb:params"])
    assert prov["voxel-size"] == 1.0 and coarse.transform.voxelSize()[0] == 1.0
    (tmp_path / "p.json").write_text(json.dumps(prov))
    run([AR, "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "r.vdb")], check=True)
    assert_bitwise_equal(coarse, vdb.read(str(tmp_path / "r.vdb"), "surface"))


def test_a_level_set_grid_terrain_keeps_its_overhang(tmp_path):
    """A mushroom rock's level set as stacks: the cap's rim stands over air; baked again, a
    vertical ray under the rim crosses the surface 4 times; provenance names the grid's own."""
    mushroom = (rockvdb.sphere(1.6, (3, 3, 3.2)) | rockvdb.capsule((3, 3, 0.5), (3, 3, 3), 0.55)
                | rockvdb.box((5.8, 5.8, 0.5), (3, 3, 0.25)))
    grid = mushroom.bake(voxel_size=0.1)
    s = rockvdb.Stacks(grid, cell_size=0.1, quantum=0.001, extent=(0, 0, 6, 6), floor=0)
    assert [m for m, _ in s.layers(44, 30)][:3] == ["bedrock", "air", "bedrock"]
    g = s.bake("surface")
    prov = json.loads(g.metadata["rockvdb:params"])
    assert prov["terrain"]["source"]["generator"] == "rockvdb.Field.bake"
    acc = g.getConstAccessor()
    col = [acc.getValue((44, 30, k)) < 0 for k in range(-5, 60)]
    assert sum(a != b for a, b in zip(col, col[1:])) == 4
    # From a file, the same stacks.
    rockvdb.write(str(tmp_path / "m.vdb"), [grid])
    assert rockvdb.Stacks(tmp_path / "m.vdb", cell_size=0.1, quantum=0.001, extent=(0, 0, 6, 6), floor=0) == s


def test_save_and_load_round_trip_and_continue_in_the_cli(tmp_path, cliff_scene):
    s = rockvdb.Stacks.from_scene(cliff_scene, stabilize=False)
    s.stabilize()
    s.save(tmp_path / "t.stacks")
    back = rockvdb.Stacks.load(tmp_path / "t.stacks")
    assert back == s and back.params == s.params and back.params["stabilize"] is True
    run([AR, "-q", "--from-stacks", str(tmp_path / "t.stacks"), "-o", str(tmp_path / "c.vdb")], check=True)
    same_grids(tmp_path / "c.vdb", back.bake())


def test_the_kernel_is_a_bake_row_and_cli_and_python_agree_on_it(tmp_path, cliff_scene):
    """kernel and reach (issue 38) change only the bake: saved stacks bake with either, the
    same bits from vdb_arches --from-stacks and Stacks.bake, recorded in provenance."""
    s = rockvdb.Stacks.from_scene(cliff_scene)
    s.save(tmp_path / "t.stacks")
    assert {"kernel", "reach"} <= set(rockvdb.Stacks.BAKE_ROWS)
    grids = {}
    for kernel, extra in (("box", []), ("interpolate", ["--reach", "3"])):
        out = tmp_path / f"{kernel}.vdb"
        run([AR, "-q", "--from-stacks", str(tmp_path / "t.stacks"), "--kernel", kernel, *extra, "-o", str(out)],
            check=True)
        keywords = {"kernel": kernel, **({"reach": 3.0} if extra else {})}
        grids[kernel] = s.bake("surface", **keywords)
        assert_bitwise_equal(by_name(out)["surface"], grids[kernel])
        prov = json.loads(grids[kernel].metadata["rockvdb:params"])
        assert prov["kernel"] == kernel and prov.get("reach") == keywords.get("reach")
    def voxels(g):
        return sorted((v.min, v.value) for v in g.citerOnValues())
    assert voxels(grids["box"]) != voxels(grids["interpolate"]), "the kernels differ"
    # The default is interpolate with a reach of 4 cells (here 0.5 m cells: 2 m).
    assert_bitwise_equal(s.bake("surface"), s.bake("surface", kernel="interpolate", reach=2.0))


@pytest.mark.parametrize("call,error,needles", [
    (lambda d: rockvdb.Stacks({"type": "strata"}, cell_sise=1), TypeError, ["cell_sise", "cell_size"]),
    (lambda d: rockvdb.Stacks(42), TypeError, ["terrain", "int"]),
    (lambda d: rockvdb.Stacks({"type": "strata", "samples": [4, 4],
                               "layers": [{"material": "lava", "thickness": 1}]}),
     ValueError, ["terrain.layers[0].material", "lava"]),
    (lambda d: rockvdb.Stacks({"type": "strata", "samples": [4, 4],
                               "layers": [{"material": "sand", "thickness": -1}]}),
     ValueError, ["terrain.layers[0].thickness", ">= 0"]),
    (lambda d: rockvdb.Stacks({"type": "strata", "samples": [200000, 200000],
                               "layers": [{"material": "sand", "thickness": 1}]}),
     ValueError, ["GB", "max_memory"]),
    (lambda d: rockvdb.Stacks.from_scene(d / "missing.json"), IOError, ["missing.json"]),
    (lambda d: rockvdb.Stacks.from_scene(d / "bad.json"), ValueError, ["bad.json"]),
    (lambda d: rockvdb.Stacks.from_scene(d / "scene.json", sigma=0), ValueError, ["sigma"]),
    (lambda d: rockvdb.Stacks.from_scene(d / "scene.json").bake("lava"), ValueError, ["material", "lava"]),
    (lambda d: rockvdb.Stacks.from_scene(d / "scene.json").layers(40, 0), IndexError, ["(40, 0)", "40 x 30"]),
    (lambda d: rockvdb.Stacks.from_scene(d / "scene.json").save(d / "x.vdb"), ValueError, [".stacks"]),
    (lambda d: rockvdb.Stacks.load(d / "bad.json"), IOError, ["bad.json"]),
])
def test_bad_input_is_one_clear_error(tmp_path, call, error, needles):
    small_scene(tmp_path)
    (tmp_path / "bad.json").write_text("{\"terrain\": ")
    before = sorted(os.listdir(tmp_path))
    with pytest.raises(error) as e:
        call(tmp_path)
    text = str(e.value)
    assert "\n" not in text
    for n in needles:
        assert n in text, text
    assert sorted(os.listdir(tmp_path)) == before


def test_stacks_help_lists_the_tables_keywords():
    import inspect
    sig = inspect.signature(rockvdb.Stacks)
    table = json.loads(rockvdb._rockvdb.schema("arches"))["params"]
    assert list(sig.parameters)[0] == "terrain"
    assert sorted(sig.parameters) == sorted(r["python"] for r in table)
    for r in table:
        if r["name"] != "terrain":
            default = sig.parameters[r["python"]].default
            assert default == (tuple(r["default"]) if isinstance(r["default"], list) else r["default"])
            assert r["python"] in rockvdb.Stacks.__doc__


def test_a_sand_map_sets_the_sand_per_stack_and_bad_maps_are_refused(tmp_path):
    x = np.arange(24, dtype=np.float32)
    rockvdb.write_heightfield(str(tmp_path / "h.exr"), np.tile(5 + 0.1 * x, (16, 1)))
    ramp = np.tile(np.clip(x / 23, 0, 1), (16, 1)).astype(np.float32)
    ramp[3, 5] = 0.5
    rockvdb.write_heightfield(str(tmp_path / "sand.exr"), ramp)
    s = rockvdb.Stacks(tmp_path / "h.exr", sand_depth=2.0, sand_map=str(tmp_path / "sand.exr"),
                       quantum=0.001, stabilize=False)
    assert s.shape == (16, 24)
    assert np.allclose(s.thickness("sand"), 2.0 * ramp, atol=0.001)
    assert s.thickness("sand")[3, 5] == pytest.approx(1.0, abs=0.001)  # pixel row = stack row j
    assert np.allclose(s.top(), 5 + 0.1 * x[None, :], atol=0.001)  # the top stays the heightfield
    rockvdb.write_heightfield(str(tmp_path / "small.exr"), ramp[:8])
    with pytest.raises(ValueError, match="sand_map .* 24 x 8 pixels; the heightfield has 24 x 16"):
        rockvdb.Stacks(tmp_path / "h.exr", sand_depth=2.0, sand_map=str(tmp_path / "small.exr"))
    with pytest.raises(ValueError, match="sand_map needs a heightfield terrain"):
        rockvdb.Stacks({"type": "strata", "samples": [4, 4], "layers": [{"material": "sand", "thickness": 1}]},
                       sand_map=str(tmp_path / "sand.exr"))
    with pytest.raises(IOError, match="nothing.exr"):
        rockvdb.Stacks(tmp_path / "h.exr", sand_map=str(tmp_path / "nothing.exr"))


EDITS = [{"tool": "sculpt", "mode": "carve", "points": [[6.0, 5.0, 12.0], [7.0, 5.5, 12.0]], "radius": 1.5},
         {"tool": "deposit", "center": [4.0, 9.0], "radius": 2.5, "amount": 1.0},
         {"tool": "erode", "mode": "collapse", "center": [14.0, 7.0, 12.0], "radius": 2.0, "rho": 0.6},
         {"tool": "crack", "nodes": [[3.0, 3.0], [10.0, 6.0], [16.0, 4.0]],
          "profile": [[-1.0, 1.0], [1.0, 1.0], [0.0, -3.0]]},
         {"tool": "tunnel", "nodes": [[2.0, 11.0, 9.0], [18.0, 11.0, 9.5]],
          "profile": [[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]},
         {"tool": "erode", "points": [[3.0, 14.0, 12.0], [12.0, 15.0, 12.0]], "radius": 1.5},
         {"tool": "crack", "nodes": [[4.0, 13.0, 11.3], [9.0, 13.0, 11.7]],  # under an overhang: 3D nodes
          "profile": [[-0.5, 0.5], [0.5, 0.5], [0.0, -0.8]]}]


def test_edits_from_python_replay_through_the_cli_and_continue_from_stacks(tmp_path):
    """Edits made one by one in Python = the same edits in a scene = saved stacks continued
    with more edits in vdb_arches; each grid's provenance lists them and replays bit for bit."""
    scene = small_scene(tmp_path)
    s = rockvdb.Stacks.from_scene(scene)
    stats = [s.sculpt(EDITS[0]["points"], 1.5, mode="carve"),
             s.deposit((4.0, 9.0), 2.5, 1.0),
             s.erode((14.0, 7.0, 12.0), 2.0, mode="collapse", rho=0.6),
             s.crack(EDITS[3]["nodes"], profile=EDITS[3]["profile"]),
             s.tunnel(EDITS[4]["nodes"], profile=EDITS[4]["profile"]),
             s.erode(points=EDITS[5]["points"], radius=1.5),
             s.crack(EDITS[6]["nodes"], profile=EDITS[6]["profile"])]
    assert s.params["edits"] == EDITS
    assert [e["tool"] for e in s.edit_stats] == ["sculpt", "deposit", "erode", "crack", "tunnel", "erode", "crack"]
    assert stats[6]["bedrock_quanta"] < 0  # cut up into the overhang's underside
    assert -stats[5]["bedrock_quanta"] == stats[5]["sand_quanta"] > 0  # a stroke's band (surface mode)
    assert stats[3]["bedrock_quanta"] < 0 and stats[4]["bedrock_quanta"] < 0
    assert stats[0]["bedrock_quanta"] < 0 and stats[1]["sand_quanta"] > 0
    assert -stats[2]["bedrock_quanta"] == stats[2]["sand_quanta"] + stats[2]["rocks_quanta"] > 0
    # The same edits given to the constructor.
    assert rockvdb.Stacks.from_scene(scene, edits=EDITS) == s
    grids = s.bake(path=tmp_path / "py.vdb")
    prov = json.loads(grids["surface"].metadata["rockvdb:params"])
    assert prov["edits"] == EDITS
    (tmp_path / "p.json").write_text(json.dumps(prov))
    run([AR, "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "cli.vdb")], check=True)
    same_grids(tmp_path / "cli.vdb", grids)
    # Saved after the first edit, continued in the CLI with the others.
    first = rockvdb.Stacks.from_scene(scene, edits=EDITS[:1])
    first.save(tmp_path / "first.stacks")
    (tmp_path / "more.json").write_text(json.dumps(EDITS[1:]))
    run([AR, "-q", "--from-stacks", str(tmp_path / "first.stacks"), "--edits", str(tmp_path / "more.json"),
         "-o", str(tmp_path / "continued.vdb")], check=True)
    same_grids(tmp_path / "continued.vdb", grids)
    # stabilize() after edits is an edit of its own, recorded in order.
    s.stabilize()
    assert s.params["edits"][-1] == {"tool": "stabilize"}


def test_bad_edits_are_one_line_naming_the_edit_and_change_nothing(tmp_path):
    s = rockvdb.Stacks.from_scene(small_scene(tmp_path))
    before = s.arrays()
    for call, needle in [(lambda: s.sculpt([(1, 1, 5)], 0), "edits[0] (sculpt): radius must be > 0"),
                         (lambda: s.deposit((500, 1), 2, 1), "outside the terrain"),
                         (lambda: s.erode((5, 5, 12), 2, rho=0.5), "rho applies to mode collapse"),
                         (lambda: s.erode(radius=2), "give center or points (a stroke), one of them"),
                         (lambda: s.edit({"tool": "smash"}), "unknown tool 'smash'")]:
        with pytest.raises(ValueError) as e:
            call()
        assert needle in str(e.value) and "\n" not in str(e.value)
    assert all(np.array_equal(before[k], s.arrays()[k]) for k in before)
    assert s.params["edits"] == []
    with pytest.raises(TypeError, match="radius"):
        s.sculpt([(1, 1, 5)])
    with pytest.raises(ValueError, match="sigma made the stacks; a bake of them may change only kernel, reach, voxel_size"):
        s.bake("surface", sigma=1.0)


def test_rocks_are_instanced_in_the_rock_layers_and_cli_and_python_agree(tmp_path):
    """§5: a tile set's rocks where their seeds fall in rock layers: most of every rock lies in
    the rock layers, the ground (sand and bedrock) is united with them, rock_id names them."""
    tiles = tmp_path / "tiles.vdb"
    rockvdb.rock_tiles(n=4, voxels_per_cell=5, seed=3, path=tiles)
    terrain = {"type": "strata", "samples": [24, 24], "base": 4, "amplitude": 0.6, "frequency": 0.2,
               "warp": 0.3, "warp_frequency": 0.3,
               "layers": [{"material": "bedrock", "thickness": 3}, {"material": "rocks", "thickness": 40}]}
    scene = {"terrain": terrain, "cell-size": 0.25, "quantum": 0.005, "rock-tiles": str(tiles)}
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    s = rockvdb.Stacks.from_scene(tmp_path / "scene.json")
    grids = s.bake(path=tmp_path / "py.vdb")
    assert list(grids) == ["material", "rock_id", "weight_bedrock", "weight_rocks", "bedrock", "rocks", "surface"]
    run([AR, "-q", str(tmp_path / "scene.json"), "-o", str(tmp_path / "cli.vdb")], check=True)
    same_grids(tmp_path / "cli.vdb", grids)
    rocks, ids = grids["rocks"], grids["rock_id"]
    dx = rocks.transform.voxelSize()[0]
    assert dx == pytest.approx(0.05)  # the tile set's voxel size (voxel-size unset)
    # Inside voxels of the instanced rocks: in the rock layers (stack material at their height).
    a = s.arrays()
    q, z0 = s.quantum, s.origin[2]
    inside = total = 0
    per_rock = {}
    acc = ids.getConstAccessor()
    for it in rocks.citerOnValues():
        if it.value >= 0 or not it.active:
            continue
        x, y, z = (c * dx for c in it.min)
        i, j = int(x / s.cell_size), int(y / s.cell_size)
        if not (0 <= i < s.shape[1] and 0 <= j < s.shape[0]):
            continue
        k = j * s.shape[1] + i
        lo, hi = a["offsets"][k], a["offsets"][k + 1]
        mats = a["material"][lo:hi]
        bottoms = a["bottom_m"][lo:hi]
        tops = bottoms + a["thickness_m"][lo:hi]
        here = [m for m, b, t in zip(mats, bottoms, tops) if b <= z < t]
        total += 1
        inside += bool(here) and here[0] == 4
        rid = acc.getValue(it.min)
        per_rock[rid] = per_rock.get(rid, 0) + 1
    assert total > 1000 and len(per_rock) > 50
    assert inside / total > 0.9, inside / total
    # The ground is bedrock and the rocks: material ids 3 and 4 only.
    assert set(np.unique([v.value for v in grids["material"].citerOnValues()])) <= {3.0, 4.0}


def points_of(path, tmp_path):
    """A VDB points file's positions, through Debian's vdb_tool (pyopenvdb reads no points)."""
    obj = tmp_path / (path.stem + "_points.obj")
    p = subprocess.run(["vdb_tool", "-read", str(path), "-vdb2points", "-write", str(obj)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    return np.array([[float(v) for v in l.split()[1:4]] for l in obj.read_text().splitlines()
                     if l.startswith("v ")])


@pytest.mark.skipif(not shutil.which("vdb_tool"), reason="libopenvdb-tools not installed")
def test_rock_instances_as_points_and_material_ids_agree_between_cli_and_python(tmp_path):
    """§5's instances as vdb_rockpile pile writes them (--points / points_path): one point per
    instanced rock, inside the rock rock_id names; material-ids relabel 'material' (a bake row,
    so a saved terrain can take other ids)."""
    tiles = tmp_path / "tiles.vdb"
    rockvdb.rock_tiles(n=4, voxels_per_cell=5, seed=3, path=tiles)
    terrain = {"type": "strata", "samples": [20, 20], "base": 3, "amplitude": 0.5, "frequency": 0.2,
               "layers": [{"material": "bedrock", "thickness": 1}, {"material": "rocks", "thickness": 1.7},
                          {"material": "sand", "thickness": 10}]}
    scene = {"terrain": terrain, "cell-size": 0.25, "quantum": 0.005, "rock-tiles": str(tiles),
             "weights": False}
    (tmp_path / "scene.json").write_text(json.dumps(scene))
    r = run([AR, str(tmp_path / "scene.json"), "--material-ids", "12,13,14", "--points",
             str(tmp_path / "cli_points.vdb"), "-o", str(tmp_path / "cli.vdb")])
    assert r.returncode == 0, r.stderr
    placed = int(re.search(r"(\d+) rocks instanced", r.stderr).group(1))
    s = rockvdb.Stacks.from_scene(tmp_path / "scene.json")
    grids = s.bake(material_ids=(12, 13, 14), points_path=tmp_path / "py_points.vdb")
    same_grids(tmp_path / "cli.vdb", grids)
    cli_pts = points_of(tmp_path / "cli_points.vdb", tmp_path)
    assert np.array_equal(cli_pts, points_of(tmp_path / "py_points.vdb", tmp_path))
    assert len(cli_pts) == placed > 20
    # Each point is its rock's seed: inside the ground, on a voxel of some instanced rock, and
    # the rocks they name are distinct.
    dx = grids["surface"].transform.voxelSize()[0]
    ground, ids = grids["surface"].getConstAccessor(), grids["rock_id"].getConstAccessor()
    named = []
    for p in cli_pts:
        c = tuple(int(round(v / dx)) for v in p)
        if ground.getValue(c) < 0 and ids.getValue(c) >= 0:
            named.append(ids.getValue(c))
    assert len(named) > 0.9 * placed and len(set(named)) == len(named)
    # 'material' holds the ids given: sand 12, bedrock 13, rocks 14, nothing else.
    seen = set(np.unique([v.value for v in grids["material"].citerOnValues()]))
    assert seen == {12.0, 13.0, 14.0}, seen
    # A bake of the same stacks with the default ids differs only in those values.
    default = s.bake("material")[1]
    assert set(np.unique([v.value for v in default.citerOnValues()])) == {2.0, 3.0, 4.0}
    assert default.activeVoxelCount() == grids["material"].activeVoxelCount()
    # Bad uses: points without rock tiles, a material that instances nothing, an id out of range.
    bare = rockvdb.Stacks(terrain, cell_size=0.25, quantum=0.005)
    with pytest.raises(ValueError, match="points need rock_tiles"):
        bare.bake(points_path=tmp_path / "x.vdb")
    with pytest.raises(ValueError, match="instances the rocks"):
        s.bake("sand", points_path=tmp_path / "x.vdb")
    with pytest.raises(ValueError, match="material_ids"):
        s.bake(material_ids=(1, 2, -1))
    assert not (tmp_path / "x.vdb").exists()
    r = run([AR, str(tmp_path / "scene.json"), "--rock-tiles", "", "--points", str(tmp_path / "x.vdb"),
             "-o", str(tmp_path / "y.vdb")])
    assert r.returncode == 2 and "points need rock-tiles" in r.stderr and "\n" not in r.stderr.strip()
    assert not (tmp_path / "x.vdb").exists() and not (tmp_path / "y.vdb").exists()
