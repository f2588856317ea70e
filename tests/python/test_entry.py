# SPDX-License-Identifier: Apache-2.0
"""One truth per parameter, one entry per stage.

- Every public Python function's keyword defaults are the C++ tables' (rockvdb._rockvdb.schema),
  so a default written by hand in Python, or a row the signature lost, fails here.
- The CLI and Python run the same entry point: the entry's phases (what the entry ran, in
  order) and counts are the same from both sides (vdb_* --stats vs stats=), and a guard that
  only the entry enforces answers both with the same message.
"""
import inspect
import json

import pytest

import rockvdb
from conftest import run, tool


def table(stage):
    return json.loads(rockvdb._rockvdb.schema(stage))["params"]


def python_default(row):
    d = row["default"]
    return tuple(d) if isinstance(d, list) else d


# Every function (or method) whose keywords come from a table, with the rows its mode does not
# read, and the keywords that are the front-end's own (files written, dicts filled, modes).
ROWS = rockvdb._rockvdb.fractal_rows()
TABLE_FUNCTIONS = [
    (rockvdb.block_tile, "block_tile", [], {"bake", "stats"}),
    (rockvdb.amplify, "amplify", [], {"terrain", "tiles", "mask", "stats"}),
    (rockvdb.detail, "detail", [], {"grid", "blend_mask", "ids", "stats"}),
    (rockvdb.rock_tiles, "rock_tiles", [], {"path", "max_memory"}),
    (rockvdb.rock_pile, "rock_pile", [], {"tiles", "support", "stats"}),
    (rockvdb.fractal_rock, "fractal_rock", ROWS["scatter"] + ROWS["carve"],
     {"path", "mesh_path", "mesh_up", "normal_map", "normal_map_path", "level_set"}),
    (rockvdb.fractal_scatter, "fractal_rock", ROWS["single"] + ROWS["carve"],
     {"ground", "path", "stats", "mesh"}),
    (rockvdb.fractal_carve, "fractal_rock", ROWS["single"] + ROWS["ground"], {"solid", "path"}),
    (rockvdb.Stacks, "arches", ["terrain"], {"terrain"}),
    (rockvdb.Field.bake, "bake", [], {"self", "attribute"}),
    (rockvdb.heightfield, "heightfield", [], {"path", "stats"}),
    (rockvdb.mesh, "mesh", [], {"grid", "path", "ids"}),
    (rockvdb.preview, "preview", [], {"grid", "path", "ids", "palette", "weights"}),
    (rockvdb.csg, "csg", ["ids"], {"op", "grids", "ids"}),
    (rockvdb.asset, "asset", [], {"grid", "path", "ids", "mask", "stats"}),
    (rockvdb.asset_each, "asset", ["id"], {"grid", "ids", "mask", "stats"}),
    (rockvdb.asset_instances, "asset", ["id"], {"points", "tiles", "path", "stats"}),
]


@pytest.mark.parametrize("fn, stage, excluded, own", TABLE_FUNCTIONS,
                         ids=[f[0].__qualname__ for f in TABLE_FUNCTIONS])
def test_python_defaults_are_the_tables(fn, stage, excluded, own):
    sig = inspect.signature(fn).parameters
    rows = {r["python"]: r for r in table(stage) if r["name"] not in excluded}
    for name, row in rows.items():
        assert name in sig, f"{fn.__qualname__} lost row {name}"
        assert sig[name].default == python_default(row), (fn.__qualname__, name)
    extra = set(sig) - set(rows)
    assert extra <= own, f"{fn.__qualname__}: keywords on no table: {extra - own}"


def test_block_tile_bake_takes_exactly_the_tables_bake_rows():
    tile_rows = {r["name"] for r in table("tile")}
    bake_rows = [r["python"] for r in table("block_tile") if r["name"] not in tile_rows]
    assert list(rockvdb.BlockTile.BAKE_ROWS) == bake_rows
    assert {"periods", "voxel_size", "chunks", "chunk"} <= set(bake_rows)


def test_every_bake_has_the_same_default_sizes():
    """The bake rows of every table that gives the sizes a default share BakeSettings'."""
    bake = {r["python"]: python_default(r) for r in table("bake")}
    for stage in ("heightfield", "block_tile", "amplify"):
        rows = {r["python"]: python_default(r) for r in table(stage)}
        for name in ("voxel_size", "half_width"):
            assert rows[name] == bake[name], (stage, name)


def test_heightfield_runs_the_heightfield_entry_from_both_sides(tmp_path):
    import numpy as np
    z = np.fromfunction(lambda j, i: 2 + np.sin(i / 4.0) + 0.05 * j, (24, 32), dtype=np.float32)
    rockvdb.write_heightfield(str(tmp_path / "h.exr"), z)
    args = dict(cell_size=0.25, height_scale=1.5, voxel_size=0.1)
    cli = cli_stats(tmp_path, "vdb_heightfield", [str(tmp_path / "h.exr")] + cli_args(args) +
                    ["-o", str(tmp_path / "h.vdb")])
    py = {}
    grid = rockvdb.heightfield(tmp_path / "h.exr", stats=py, **args)
    assert phases(cli) == phases(py) == ["bake"]
    assert cli["samples"] == py["samples"] == [32, 24]
    from conftest import assert_bitwise_equal
    import pyopenvdb as vdb
    other = vdb.read(str(tmp_path / "h.vdb"), "surface")
    assert_bitwise_equal(grid, other)
    assert grid.metadata["rockvdb:params"] == other.metadata["rockvdb:params"]


def test_field_bake_renormalize_is_the_tables_choice():
    row = next(r for r in table("bake") if r["name"] == "renormalize")
    assert row["choices"] == ["auto", "on", "off"]
    doc = inspect.getdoc(rockvdb.Field.bake)
    assert "one of auto, on, off" in doc and "first-order" not in doc
    with pytest.raises(ValueError, match="renormalize"):
        rockvdb.sphere(1).bake(voxel_size=0.25, renormalize="tracker")


# ---- the same entry from both sides ------------------------------------------------------------

BLOCKS = dict(tile_size=8, point_radius=0.5, voxel_size=0.2, seed=3)


def cli_args(kwargs):
    out = []
    for k, v in kwargs.items():
        out += ["--" + k.replace("_", "-"),
                ",".join(map(str, v)) if isinstance(v, (tuple, list)) else str(v)]
    return out


def phases(stats):
    return [p["name"] for p in stats["phases"]]


def cli_stats(tmp_path, name, args):
    path = tmp_path / f"{name}.json"
    run([tool(name), *args, "-q", "--stats", str(path)], check=True)
    return json.loads(path.read_text())


def test_block_tile_runs_the_blocks_entry_from_both_sides(tmp_path):
    cli = cli_stats(tmp_path, "vdb_blocks", cli_args(BLOCKS) + ["-o", str(tmp_path / "b.vdb"),
                                                                 "--tile", str(tmp_path / "b.tile")])
    py = {}
    t = rockvdb.block_tile(stats=py, **BLOCKS)
    assert phases(cli) == phases(py) == ["generation", "bake"]
    assert cli["tile"] == py["tile"] == t.stats
    assert cli["bake"]["active_voxels"] == py["bake"]["active_voxels"] == t.surface.activeVoxelCount()
    # Baking a given tile: the same entry, without generation.
    again = {}
    rockvdb.load_tile(str(tmp_path / "b.tile")).bake(stats=again, voxel_size=0.2)
    cli = cli_stats(tmp_path, "vdb_blocks", ["--from-tile", str(tmp_path / "b.tile"),
                                             "--voxel-size", "0.2", "-o", str(tmp_path / "c.vdb")])
    assert phases(again) == phases(cli) == ["bake"]
    assert again["bake"]["active_voxels"] == cli["bake"]["active_voxels"] == py["bake"]["active_voxels"]


def test_stats_share_no_output_with_the_grids(tmp_path):
    out = tmp_path / "b.vdb"
    p = run([tool("vdb_blocks"), *cli_args(BLOCKS), "-q", "-o", "-", "--stats", "-"])
    assert p.returncode == 2 and p.stdout == b"" and "--stats" in p.stderr
    p = run([tool("vdb_blocks"), *cli_args(BLOCKS), "-q", "-o", str(out), "--stats",
             str(tmp_path / "no" / "s.json")])
    assert p.returncode == 1 and not out.exists()


def test_block_tile_chunks_reach_the_entry():
    """chunk / chunks were left out of Python's bake keys: block_tile(chunk=...) failed."""
    whole = rockvdb.block_tile(**BLOCKS)
    half = rockvdb.block_tile(chunks="2x1x1", chunk="0/2", **BLOCKS)
    assert 0 < half.surface.activeVoxelCount() < whole.surface.activeVoxelCount()
    tile = rockvdb.block_tile(bake=False, **BLOCKS)
    s, _ = tile.bake(chunks="2x1x1", chunk="1/2", voxel_size=0.2)
    assert half.surface.activeVoxelCount() + s.activeVoxelCount() == whole.surface.activeVoxelCount()
    with pytest.raises(TypeError, match="tile_size"):
        tile.bake(tile_size=3)


def test_the_blocks_voxel_guard_answers_both_sides_alike(tmp_path):
    """runBlocks refuses a voxel too coarse for the tile before generating it: before the
    generation reads its relief image (missing here), from both sides alike."""
    missing = str(tmp_path / "no_relief.png")
    p = run([tool("vdb_blocks"), "--tile-size", "8", "--voxel-size", "0.9", "--warp-relief",
             missing, "-q", "-o", str(tmp_path / "x.vdb")])
    assert p.returncode == 2
    message = p.stderr.strip().split("error: ", 1)[1]
    with pytest.raises(ValueError) as e:
        rockvdb.block_tile(tile_size=8, voxel_size=0.9, warp_relief=missing)
    assert str(e.value) == message
    assert "too coarse" in message
    with pytest.raises(OSError):  # a fine voxel reaches the generation, which reads the image
        rockvdb.block_tile(tile_size=8, voxel_size=0.1, warp_relief=missing)


FRACTAL = dict(levels=2, voxel_size=0.05, seed=5)
SCATTER = dict(count=6, levels=1, size=(0.6, 0.5, 0.35), voxel_size=0.05, area=(-2, -2, 2, 2),
               seed=4)


def without_times(stats):
    """Counts only: no times (any depth), no phases, no numpy arrays."""
    return {k: without_times(v) if isinstance(v, dict) else v for k, v in stats.items()
            if not k.endswith("seconds") and k != "phases" and not hasattr(v, "shape")}


def test_fractal_modes_run_the_fractal_entry_from_both_sides(tmp_path):
    cli = cli_stats(tmp_path, "vdb_fractal_rock", cli_args(FRACTAL) + ["-o", str(tmp_path / "r.vdb")])
    surface, mesh = rockvdb.fractal_rock(**FRACTAL)
    assert phases(cli)[0] == "mesh" and phases(cli)[-1] == "level set"
    assert cli["active_voxels"] == surface.activeVoxelCount()
    assert cli["triangles"] == len(mesh["triangles"])

    cli = cli_stats(tmp_path, "vdb_fractal_rock", cli_args(SCATTER) + ["-o", str(tmp_path / "s.vdb")])
    py = {}
    rockvdb.fractal_scatter(stats=py, **SCATTER)
    assert phases(cli) == phases(py) == ["place", "meshes", "level set"]
    assert without_times(cli) == without_times(py)
    assert py["positions"].shape == (py["placed"], 3)

    carve = dict(count=3, levels=1, size=(0.8, 0.8, 0.8), seed=2)
    solid = rockvdb.box((4, 4, 4)).bake(voxel_size=0.1)
    rockvdb.write(str(tmp_path / "solid.vdb"), [solid])
    cli = cli_stats(tmp_path, "vdb_fractal_rock", cli_args(carve) + [
        "--carve", str(tmp_path / "solid.vdb"), "-o", str(tmp_path / "c.vdb")])
    _, cave = rockvdb.fractal_carve(solid, **carve)
    assert cli["rocks"] == 3 and cli["cave_voxels"] == cave.activeVoxelCount()


def test_the_fractal_carve_guard_answers_both_sides_alike(tmp_path):
    solid = rockvdb.box((4, 4, 4)).bake(voxel_size=0.1)
    rockvdb.write(str(tmp_path / "solid.vdb"), [solid])
    p = run([tool("vdb_fractal_rock"), "--carve", str(tmp_path / "solid.vdb"), "--count", "0",
             "-q", "-o", str(tmp_path / "c.vdb")])
    assert p.returncode == 2
    message = p.stderr.strip().split("error: ", 1)[1]
    with pytest.raises(ValueError) as e:
        rockvdb.fractal_carve(solid, count=0)
    assert str(e.value) == message and "count" in message
    assert not (tmp_path / "c.vdb").exists()


def test_stacks_open_and_bake_the_arches_scene_from_both_sides(tmp_path):
    """vdb_arches and rockvdb.Stacks open a scene through openScene and bake it through
    bakeScene: the same stabilisation and edits, the same bake, the same refusals."""
    from conftest import arches_small_scene
    edits = [{"tool": "deposit", "center": [6, 6], "radius": 2, "amount": 1}]
    scene = arches_small_scene(tmp_path, edits=edits)
    stacks = tmp_path / "t.stacks"
    cli = cli_stats(tmp_path, "vdb_arches", [str(scene), "--stacks", str(stacks), "-o",
                                             str(tmp_path / "a.vdb")])
    s = rockvdb.Stacks.from_scene(str(scene))
    assert cli["stabilize"]["moves"] == s.stabilize_stats["moves"] > 0
    assert [without_times(e) for e in cli["edits"]] == [without_times(e) for e in s.edit_stats]
    assert cli["layers"] == s.layer_count and cli["bytes"] == s.bytes
    assert cli["active_voxels"] == s.bake("surface").activeVoxelCount()
    assert phases(cli)[0] == "stacks" and {"edit", "convolution", "redistance"} <= set(phases(cli))
    # The rule of saved stacks, one message from both sides.
    p = run([tool("vdb_arches"), "-q", "--from-stacks", str(stacks), "--repose-sand", "30", "-o",
             str(tmp_path / "b.vdb")])
    assert p.returncode == 2
    message = p.stderr.strip().split("error: ", 1)[1]
    with pytest.raises(ValueError) as e:
        rockvdb.Stacks.load(str(stacks)).bake("surface", repose_sand=30)
    # (each in its own spelling: the CLI's options, Python's keywords)
    import re
    assert "repose-sand made the stacks" in message
    assert str(e.value) == re.sub(r"\b([a-z]+)-([a-z]+)\b", r"\1_\2", message)


def test_derived_defaults_are_shown_and_the_docs_quote_their_numbers():
    """A default that follows other rows is a rule of the table: its help says so, and the
    numbers docs/blocks.md quotes for them are the rule's (a changed factor fails here)."""
    import os
    import re
    rows = {r["name"]: r for r in table("block_tile")}
    assert rows["point-radius"]["derived"] == "0.034 x tile-size"
    assert rows["fracture-width"]["derived"] == "0.002 x tile-size"
    assert rows["neighbour-radius"]["derived"] == "2 x point-radius"
    assert "(0 = 0.034 x tile-size)" in rows["point-radius"]["help"]
    assert "0.034 x tile-size" in rockvdb.block_tile.__doc__
    assert rows["tile-size"]["derived"] is None
    page = open(os.path.join(os.path.dirname(__file__), "..", "..", "docs", "blocks.md")).read()
    for name in ("point-radius", "fracture-width"):
        factor = re.match(r"([0-9.]+) x tile-size", rows[name]["derived"]).group(1)
        assert f"{factor}·s" in page, name


def test_detail_carries_id_grids_as_vdb_detail_does(tmp_path):
    """rockvdb.detail(grid, ids=[...]) carries the id grids onto the result through the same
    entry point as vdb_detail carries a file's: the same surface and ids, bit for bit; the
    caller's id grids are left as they were."""
    import pyopenvdb
    from conftest import assert_bitwise_equal
    tile = tmp_path / "tile.vdb"
    run([tool("vdb_blocks"), "-q", "--tile-size", "4", "--voxel-size", "0.1", "--seed", "3",
         "-o", str(tile)], check=True)
    cli = tmp_path / "detailed.vdb"
    run([tool("vdb_detail"), "-q", str(tile), "--warp-amplitude", "0.05", "-o", str(cli)],
        check=True)
    grids = {g.name: g for g in pyopenvdb.readAll(str(tile))[0]}
    before = grids["block_id"].deepCopy()
    surface, block_id = rockvdb.detail(grids["surface"], ids=[grids["block_id"]],
                                       warp_amplitude=0.05)
    want = {g.name: g for g in pyopenvdb.readAll(str(cli))[0]}
    assert sorted(want) == ["block_id", "surface"]
    assert_bitwise_equal(surface, want["surface"])
    assert_bitwise_equal(block_id, want["block_id"])
    assert block_id.name == "block_id"
    assert_bitwise_equal(grids["block_id"], before)
    assert block_id.activeVoxelCount() == surface.activeVoxelCount() != before.activeVoxelCount()
