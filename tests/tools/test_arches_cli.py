# SPDX-License-Identifier: Apache-2.0
"""vdb_arches: material-stack terrain from a scene file (arches §3, §6)."""
import json
import os
import re

import numpy as np
import pyopenvdb as vdb
import pytest

import rockvdb

from conftest import arches_small_scene as small_scene, assert_bitwise_equal, one_line_error, run, run_sample, tool

AR = tool("vdb_arches")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = os.path.join(ROOT, "samples", "data", "arches_strata.json")


def test_a_scene_gives_the_ground_one_level_set_per_material_and_ids(tmp_path):
    out = tmp_path / "t.vdb"
    run([AR, "-q", str(small_scene(tmp_path)), "-o", str(out)], check=True)
    grids, meta = vdb.readAll(str(out))
    names = [g.name for g in grids]
    assert sorted(names) == sorted(["surface", "sand", "bedrock", "rocks", "material", "weight_sand",
                                    "weight_bedrock", "weight_rocks"])
    assert names[0] == "material" and names[-1] == "surface"
    for w in ("weight_sand", "weight_bedrock", "weight_rocks"):
        g = [x for x in grids if x.name == w][0]
        assert g.gridClass == vdb.GridClass.FOG_VOLUME
        vals = [v.value for v in g.citerOnValues()]
        assert min(vals) >= 0 and max(vals) <= 1
    by = {g.name: g for g in grids}
    for n in ["surface", "sand", "bedrock", "rocks"]:
        assert by[n].gridClass == vdb.GridClass.LEVEL_SET
        assert by[n].metadata["rockvdb:generator"] == "vdb_arches"
    ids = set(np.unique([v.value for v in by["material"].citerOnValues()]))
    assert ids <= {2.0, 3.0, 4.0} and 3.0 in ids
    # Overhangs: some vertical ray crosses the ground 4 times (the air stratum under bedrock).
    acc = by["surface"].getConstAccessor()
    bbox = by["surface"].evalActiveVoxelBoundingBox()
    most = 0
    for i in range(bbox[0][0], bbox[1][0], 3):
        for j in range(bbox[0][1], bbox[1][1], 3):
            col = [acc.getValue((i, j, k)) < 0 for k in range(bbox[0][2] - 2, bbox[1][2] + 2)]
            most = max(most, sum(a != b for a, b in zip(col, col[1:])))
    assert most >= 4


def test_a_file_replays_from_its_own_provenance_and_from_its_stacks(tmp_path):
    first, stacks = tmp_path / "first.vdb", tmp_path / "t.stacks"
    run([AR, "-q", str(small_scene(tmp_path)), "--repose-sand", "31", "-o", str(first), "--stacks", str(stacks)],
        check=True)
    prov = json.loads(vdb.read(str(first), "surface").metadata["rockvdb:params"])
    assert prov["repose-sand"] == 31 and prov["terrain"]["type"] == "strata"
    (tmp_path / "p.json").write_text(json.dumps(prov))
    run([AR, "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "again.vdb")], check=True)
    run([AR, "-q", "--from-stacks", str(stacks), "-o", str(tmp_path / "stacks.vdb")], check=True)
    for name in ["surface", "bedrock", "material"]:
        a = vdb.read(str(first), name)
        assert_bitwise_equal(a, vdb.read(str(tmp_path / "again.vdb"), name))
        assert_bitwise_equal(a, vdb.read(str(tmp_path / "stacks.vdb"), name))


@pytest.mark.parametrize("edit,needles", [
    (lambda s: s["terrain"]["layers"][1].update(material="lava"), ["terrain.layers[1].material", "lava"]),
    (lambda s: s["terrain"]["layers"][2].update(thickness=-1), ["terrain.layers[2]", ">= 0"]),
    (lambda s: s["terrain"]["layers"][0].update(colour="red"),
     ["terrain.layers[0]: unknown key 'colour'", "keys: material, thickness"]),
    (lambda s: s.update(sigma=0), ["sigma"]),
    (lambda s: s.update(kernel="gauss"), ["kernel", "gauss", "interpolate, box"]),
    (lambda s: s.update(kernel="box", reach=2), ["reach", "box"]),
    (lambda s: s.update(reach=-1), ["reach"]),
    (lambda s: s.update({"cell-sise": 1}), ["cell-size"]),
    (lambda s: s["terrain"].update(samples=[200000, 200000]), ["GB", "--max-memory"]),
])
def test_bad_scenes_are_one_line_and_no_file(tmp_path, edit, needles):
    scene = json.load(open(SCENE))
    edit(scene)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(scene))
    out = tmp_path / "o.vdb"
    p = run([AR, "-q", str(path), "-o", str(out), "--stacks", str(tmp_path / "o.stacks")])
    one_line_error(p, 2, *needles)
    assert not out.exists() and not (tmp_path / "o.stacks").exists()
    assert not [f for f in os.listdir(tmp_path) if ".tmp-" in f]


def test_malformed_json_and_a_corrupt_stacks_file_are_refused(tmp_path):
    (tmp_path / "m.json").write_text('{"terrain": {"type": "strata",')
    one_line_error(run([AR, "-q", str(tmp_path / "m.json"), "-o", str(tmp_path / "o.vdb")]), 2, "m.json")
    (tmp_path / "c.stacks").write_bytes(b"RVSTACKS" + b"\x00" * 40)
    one_line_error(run([AR, "-q", "--from-stacks", str(tmp_path / "c.stacks"), "-o", str(tmp_path / "o.vdb")]), 1,
                   "c.stacks")
    assert not (tmp_path / "o.vdb").exists()


def test_sample_08_overhangs_and_sand_that_slid_off_the_canyon_walls(tmp_path):
    """samples/08_arches.sh: the strata scene has columns crossing the ground 4 times; the
    canyon's sand is all still there (exactly) but no longer on the walls."""
    import rockvdb
    run_sample("08_arches.sh", tmp_path)
    for stem in ("arches_strata", "arches_canyon"):
        assert (tmp_path / f"{stem}.png").stat().st_size > 10000
        assert [g.name for g in vdb.readAll(str(tmp_path / f"{stem}.vdb"))[0]][-1] == "surface"
    g = vdb.read(str(tmp_path / "arches_strata.vdb"), "surface")
    lo, hi = g.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(h - l + 1 for l, h in zip(lo, hi)), np.float32)
    g.copyToArray(a, ijk=lo)
    flips = (np.diff((a < 0).astype(np.int8), axis=2) != 0).sum(axis=2)
    assert (flips >= 4).mean() > 0.05, "overhangs over at least 5% of the strata"
    settled = rockvdb.Stacks.load(tmp_path / "arches_canyon.stacks")
    fresh = rockvdb.Stacks.from_scene(os.path.join(ROOT, "samples", "data", "arches_canyon.json"),
                                      stabilize=False)
    assert settled.volume("sand") == fresh.volume("sand")
    # The sand left the walls (the stacks whose ground drops > 2 m to a neighbour) for the floor.
    top = fresh.top()
    steep = np.zeros(top.shape, bool)
    steep[:, :-1] |= np.abs(np.diff(top, axis=1)) > 2
    steep[:-1, :] |= np.abs(np.diff(top, axis=0)) > 2
    assert steep.sum() > 50
    assert settled.thickness("sand")[steep].mean() < 0.5 * fresh.thickness("sand")[steep].mean()
    assert settled.thickness("sand").max() > 2 * 1.2


def test_from_stacks_refuses_rows_that_made_the_stacks_and_bad_edits_name_their_index(tmp_path):
    scene = small_scene(tmp_path)
    stacks, out = tmp_path / "t.stacks", tmp_path / "o.vdb"
    run([AR, "-q", str(scene), "-o", str(tmp_path / "a.vdb"), "--stacks", str(stacks)], check=True)
    p = run([AR, "-q", "--from-stacks", str(stacks), "--repose-sand", "30", "-o", str(out)])
    one_line_error(p, 2, "repose-sand made the stacks; a bake of them may change only")
    edits = tmp_path / "e.json"
    edits.write_text(json.dumps([{"tool": "deposit", "center": [3, 3], "radius": 2, "amount": 1},
                                 {"tool": "erode", "center": [3, 3, 12], "radius": -1}]))
    p = run([AR, "-q", str(scene), "--edits", str(edits), "-o", str(out), "--stacks", str(tmp_path / "n.stacks")])
    one_line_error(p, 2, "edits[1] (erode): radius must be > 0")
    p = run([AR, "-q", "--from-stacks", str(stacks), "--edits", str(edits), "-o", str(out)])
    one_line_error(p, 2, "edits[1] (erode)")
    assert not out.exists() and not (tmp_path / "n.stacks").exists()


def column_crossings(grid, x, y):
    """Sign changes of a level set along the vertical line through world (x, y)."""
    dx = grid.transform.voxelSize()[0]
    lo, hi = grid.evalActiveVoxelBoundingBox()
    acc = grid.getConstAccessor()
    i, j = int(round(x / dx)), int(round(y / dx))
    col = [acc.getValue((i, j, k)) < 0 for k in range(lo[2] - 1, hi[2] + 2)]
    return sum(a != b for a, b in zip(col, col[1:]))


def test_sample_09_sea_arches_and_a_cave_network(tmp_path):
    """samples/09_arches_coast.sh at 0.5 m: the coastal tunnel leaves arches (4 crossings at
    some points of its axis, 2 where a bay opened it), the junction cave holds rubble."""
    run_sample("09_arches_coast.sh", tmp_path, "0.5")
    assert (tmp_path / "arches_coast.png").stat().st_size > 10000
    g = vdb.read(str(tmp_path / "arches_coast.vdb"), "surface")
    along = [column_crossings(g, 39.0, y) for y in range(6, 75, 2)]
    assert along.count(4) >= 5, along   # roof over the tunnel: arches and caves
    assert along.count(2) >= 3, along   # opened by a bay
    assert column_crossings(g, 26.0, 40.0) >= 4  # the junction cave under the plateau
    params = json.loads(g.metadata["rockvdb:params"])
    assert [e["tool"] for e in params["edits"]] == ["tunnel", "tunnel", "erode", "deposit"]
    rocks = vdb.read(str(tmp_path / "arches_coast.vdb"), "material")
    assert any(v.value == 4.0 for v in rocks.citerOnValues())  # the collapse's rubble shows


def test_sample_10_ravine_with_undercut_walls_and_rocks_at_its_bottom(tmp_path):
    """samples/10_arches_ravine.sh at 0.5 m: across the ravine a vertical line meets its
    undercut walls (more than 2 crossings somewhere along it), and rocks lie in it."""
    run_sample("10_arches_ravine.sh", tmp_path, "0.5")
    stacks = rockvdb.Stacks.load(tmp_path / "arches_ravine.stacks")
    scene = json.load(open(os.path.join(ROOT, "samples", "data", "arches_ravine.json")))
    fresh = rockvdb.Stacks(scene["terrain"], cell_size=0.5, quantum=0.01)
    # The crack removed bedrock; the collapses turned bedrock into granular material, exactly.
    edits = [e for e in stacks.params["edits"]]
    assert [e["tool"] for e in edits] == ["crack", "erode", "erode", "erode"]
    assert stacks.volume("bedrock") < fresh.volume("bedrock")
    assert stacks.volume("rocks") > fresh.volume("rocks")
    g = vdb.read(str(tmp_path / "arches_ravine.vdb"), "surface")
    # Beside the first arc's axis (4.5 m across it: the profile's ledge over its undercut), a
    # vertical line meets floor, undercut floor, ledge underside and ledge top: 4 crossings.
    t = np.array([24.0, -6.0]) / np.hypot(24.0, -6.0)
    n = np.array([-t[1], t[0]])
    counts = []
    for x in np.arange(8.0, 24.0, 1.0):
        c = np.array([x, 30.0 - 6.0 * (x - 4.0) / 24.0])
        for side in (-1, 1):
            q = c + side * 4.5 * n
            counts.append(column_crossings(g, q[0], q[1]))
    assert counts.count(4) >= len(counts) // 2, counts
    assert (tmp_path / "arches_ravine.png").stat().st_size > 10000


def test_sample_11_canyon_cliffs_shed_rock_piles(tmp_path):
    """samples/11_arches_canyon_collapse.sh at 0.5 m: the collapses' bedrock became rocks and
    sand (exactly), the rocks lie lower than where they broke off, every slope at rest."""
    run_sample("11_arches_canyon_collapse.sh", tmp_path, "0.5")
    s = rockvdb.Stacks.load(tmp_path / "arches_canyon_collapse.stacks")
    assert s.volume("rocks") > 100
    a = s.arrays()
    rock_tops = (a["bottom_m"] + a["thickness_m"])[a["material"] == 4]
    assert np.median(rock_tops) < 9.0  # piled at the cliffs' feet, below the bites (z 7-11)
    again = rockvdb.Stacks.load(tmp_path / "arches_canyon_collapse.stacks")
    assert again.stabilize()["moves"] == 0  # already at rest
    assert (tmp_path / "arches_canyon_collapse.png").stat().st_size > 10000


def test_preview_textures_the_ground_by_its_weight_grids(tmp_path):
    """§6 in vdb_preview (--texture): each ground material's pattern, triplanar Lp (p = 8),
    blended by the weight_* grids; the CLI and Python give the same PNG; a file without
    weights is refused in one line, nothing written."""
    out = tmp_path / "a.vdb"
    run([AR, "-q", str(small_scene(tmp_path)), "--voxel-size", "0.25", "-o", str(out)], check=True)
    png = tmp_path / "t.png"
    p = run([tool("vdb_preview"), str(out), "--texture", "--width", "240", "--height", "160", "-o", str(png)])
    assert p.returncode == 0, p.stderr
    shares = dict((m, float(v)) for m, v in re.findall(r"(\w+) ([\d.]+)%", p.stderr.split("by material:")[1]))
    assert shares["bedrock"] > 5 and sum(shares.values()) > 10, p.stderr
    grids, _ = vdb.readAll(str(out))
    surface = [g for g in grids if g.name == "surface"][0]
    weights = [g for g in grids if g.name.startswith("weight_")]
    r = rockvdb.preview(surface, tmp_path / "py.png", weights=weights, texture=True, width=240, height=160)
    assert (tmp_path / "py.png").read_bytes() == png.read_bytes()
    assert abs(100 * r["materials"]["bedrock"] - shares["bedrock"]) < 0.06
    with pytest.raises(ValueError, match="weights apply to texture=True"):
        rockvdb.preview(surface, tmp_path / "no.png", weights=weights)
    assert not (tmp_path / "no.png").exists()
    # The texture shows: the same view untextured differs.
    run([tool("vdb_preview"), str(out), "--width", "240", "--height", "160", "-o", str(tmp_path / "u.png")],
        check=True)
    assert (tmp_path / "u.png").read_bytes() != png.read_bytes()
    bare = tmp_path / "bare.vdb"
    run([AR, "-q", str(small_scene(tmp_path)), "--voxel-size", "0.25", "--no-weights", "-o", str(bare)], check=True)
    one_line_error(run([tool("vdb_preview"), str(bare), "--texture", "-o", str(tmp_path / "n.png")]), 2,
                   "--texture needs weight_* grids")
    assert not (tmp_path / "n.png").exists()
