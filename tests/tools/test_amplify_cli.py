# SPDX-License-Identifier: Apache-2.0
"""vdb_amplify (heightfield terrains, one tile or several by strata; slope / distance /
anchor rules): grids, the slope rule on a plateau-and-cliff, flat terrain, bad input."""
import json
import os

import pyopenvdb as vdb
import pytest

from conftest import assert_bitwise_equal, one_line_error, run, tool, write_png16



@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("amp")
    cliff, flat = d / "cliff.png", d / "flat.png"
    rows = []
    for _ in range(65):
        rows.append([round(65535 * (1.0 if i * 0.5 < 14 else 0.0 if i * 0.5 > 18
                                     else 1.0 - (i * 0.5 - 14) / 4)) for i in range(65)])
    write_png16(cliff, rows)
    write_png16(flat, [[30000] * 65 for _ in range(65)])
    t = d / "eq.tile"
    run([tool("vdb_blocks"), "-q", "--type", "equidimensional", "--tile-size", "10",
         "--point-radius", "0.5", "--voxel-size", "0.25", "--seed", "3", "-o", str(d / "eq.vdb"),
         "--tile", str(t)], check=True)
    return {"dir": d, "cliff": cliff, "flat": flat, "tile": t}


def amplify(inputs, terrain, out, *extra):
    return run([tool("vdb_amplify"), "--terrain", str(terrain), "--cell-size", "0.5",
                "--height-scale", "10", "--tiles", str(inputs["tile"]), "--voxel-size", "0.2",
                "-o", str(out), *extra])


def test_cliff_gets_blocks_plateau_and_floor_stay_bare(inputs, tmp_path):
    out = tmp_path / "amplify_cliff.vdb"
    p = amplify(inputs, inputs["cliff"], out)
    assert p.returncode == 0, p.stderr
    assert "#R " in p.stderr
    grids, _ = vdb.readAll(str(out))
    g = {x.name: x for x in grids}
    assert set(g) == {"surface", "block_id", "material"}
    # Statistics: the active voxel count matches the file, and every phase is timed.
    active = int(p.stderr.split("bake: ")[1].split()[0])
    assert active == g["surface"].activeVoxelCount()
    for phase in ("presence", "bake", "cull", "fill", "split", "load", "write", "total"):
        assert f"{phase} " in p.stderr.split("phases: ")[1], p.stderr
    ids, mat = g["block_id"], g["material"]
    dx = g["surface"].transform.voxelSize()[0]
    count = 0
    for it in ids.citerOnValues():
        if it.value < 0:
            continue
        x = it.min[0] * dx
        assert 14 - 3.5 < x < 18 + 3.5, x
        count += 1
    assert count > 500
    # Material: 0 on bare terrain, 1 + the tile index on blocks.
    assert {it.value for it in mat.citerOnValues()} == {0.0, 1.0}


def test_flat_terrain_writes_the_bare_terrain(inputs, tmp_path):
    out = tmp_path / "flat.vdb"
    p = amplify(inputs, inputs["flat"], out)
    assert p.returncode == 0, p.stderr
    assert "no block qualifies" in p.stderr
    grids, _ = vdb.readAll(str(out))
    ids = [x for x in grids if x.name == "block_id"][0]
    assert all(it.value == -1.0 for it in ids.citerOnValues())


def test_bad_input(inputs, tmp_path):
    out = tmp_path / "o.vdb"
    one_line_error(run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--tiles",
                        f"{inputs['tile']},{inputs['tile']}", "-o", str(out)]), 2, "need strata (--strata")
    strata = tmp_path / "strata.json"
    strata.write_text('{"layers": [{"tile": "eq", "top": 5}, {"tile": "granite"}]}')
    one_line_error(amplify(inputs, inputs["cliff"], out, "--strata", str(strata)), 2,
                   "unknown tile 'granite'", "eq")
    # Every key of the strata is checked (a misspelt one was ignored: issue 39).
    for text, needles in [
            ('{"noise": {"amplitud": 1}, "layers": [{"tile": "eq"}]}',
             ("strata: noise: unknown key 'amplitud'", "did you mean 'amplitude'")),
            ('{"layers": [{"tile": "eq", "topp": 5}, {"tile": "eq"}]}', ("layers[0]: unknown key 'topp'",)),
            ('{"layers": [{"tile": "eq", "top": 5}, {"tile": "eq", "top": 9}]}',
             ("layers[1] (the top one): unknown key 'top'", "keys: tile")),
            ('{"layers": [{"tile": "eq"}], "normals": [0, 0, 1]}', ("unknown key 'normals'", "did you mean 'normal'"))]:
        strata.write_text(text)
        one_line_error(amplify(inputs, inputs["cliff"], out, "--strata", str(strata)), 2, *needles)
    strata.write_text('{"layers": [{"tile": "eq", "top": 5}, {"tile": "granite"}]}')
    other = tmp_path / "other.tile"
    run([tool("vdb_blocks"), "-q", "--tile-size", "12", "--point-radius", "0.6",
         "--voxel-size", "0.25", "-o", str(tmp_path / "other.vdb"), "--tile", str(other)],
        check=True)
    strata.write_text('{"layers": [{"tile": "eq", "top": 5}, {"tile": "other"}]}')
    one_line_error(run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--tiles",
                        f"{inputs['tile']},{other}", "--strata", str(strata), "-o", str(out)]),
                   2, "tile sizes differ", "--mixed-tile-sizes")
    one_line_error(run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--tiles",
                        str(tmp_path / "none.tile"), "-o", str(out)]), 1, "none.tile")
    bad = tmp_path / "bad.tile"
    bad.write_text('{"format": "other"}')
    one_line_error(run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--tiles",
                        str(bad), "-o", str(out)]), 1, "tile file", "bad.tile")
    one_line_error(amplify(inputs, inputs["cliff"], out, "--distance-range", "1,0"), 2,
                   "amplify: distance-range needs va <= vb (got 1, 0)")
    one_line_error(amplify(inputs, inputs["cliff"], out, "--max-slope", "2"), 2,
                   "amplify: max-slope must be in [0, 1] (got 2.0)")
    assert not out.exists()


def test_level_set_terrain_and_union_property(inputs, tmp_path):
    """A 3D terrain level set (.vdb) in; every voxel inside the terrain stays inside."""
    ground = tmp_path / "ground.vdb"
    run([tool("vdb_heightfield"), "-q", str(inputs["cliff"]), "--cell-size", "0.5",
         "--height-scale", "10", "--voxel-size", "0.2", "-o", str(ground)], check=True)
    out = tmp_path / "amp.vdb"
    p = run([tool("vdb_amplify"), "--terrain", str(ground), "--tiles", str(inputs["tile"]),
             "--voxel-size", "0.2", "-o", str(out)])
    assert p.returncode == 0, p.stderr
    r = int(p.stderr.split("#R ")[1].split()[0])
    assert r > 10
    t = vdb.read(str(ground), "surface")
    a = vdb.read(str(out), "surface")
    acc = a.getConstAccessor()
    inside = 0
    for it in t.citerOnValues():
        if it.count == 1 and it.value < 0:
            assert acc.getValue(it.min) < 0, it.min
            inside += 1
    assert inside > 1000


def test_carve_option(inputs, tmp_path):
    out = tmp_path / "carved.vdb"
    p = amplify(inputs, inputs["cliff"], out, "--carve", "0.15")
    assert p.returncode == 0, p.stderr
    grids, _ = vdb.readAll(str(out))
    assert {g.name for g in grids} == {"surface", "block_id", "material"}
    one_line_error(amplify(inputs, inputs["cliff"], tmp_path / "o.vdb", "--carve=-1"), 2, "carve")


def test_roi_limits_the_blocks_and_huge_bakes_are_refused(inputs, tmp_path):
    out = tmp_path / "roi.vdb"
    p = amplify(inputs, inputs["cliff"], out, "--roi", "0,0,-10,40,12,40")
    assert p.returncode == 0, p.stderr
    ids = vdb.read(str(out), "block_id")
    dx = ids.transform.voxelSize()[0]
    ys = [it.min[1] * dx for it in ids.citerOnValues() if it.value >= 0]
    assert ys and max(ys) < 12 + 3.5  # anchors below y = 12; blocks reach < 3.5 m past
    one_line_error(amplify(inputs, inputs["cliff"], tmp_path / "o.vdb", "--roi", "0,0,0,1,1"), 2,
                   "--roi")
    huge = tmp_path / "huge.vdb"
    p = run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--cell-size", "0.5",
             "--height-scale", "10", "--tiles", str(inputs["tile"]), "--voxel-size", "0.0005",
             "-o", str(huge)])
    assert p.returncode == 2, p.stderr
    assert "refusing" in p.stderr and "needed" in p.stderr
    assert not huge.exists()


def test_mask_image_limits_the_blocks(inputs, tmp_path):
    mask = tmp_path / "mask.png"
    # White (blocks allowed) for rows y < 12 m (row j at y = 0.5 j), black beyond.
    write_png16(mask, [[65535 if j * 0.5 < 12 else 0] * 65 for j in range(65)])
    out = tmp_path / "masked.vdb"
    p = amplify(inputs, inputs["cliff"], out, "--mask", str(mask))
    assert p.returncode == 0, p.stderr
    ids = vdb.read(str(out), "block_id")
    dx = ids.transform.voxelSize()[0]
    ys = [it.min[1] * dx for it in ids.citerOnValues() if it.value >= 0]
    assert ys and max(ys) < 12 + 3.5
    one_line_error(amplify(inputs, inputs["cliff"], tmp_path / "o.vdb", "--mask",
                           str(tmp_path / "none.png")), 1, "none.png")
    assert not (tmp_path / "o.vdb").exists()


def test_sample_03_strata_order_on_the_cliff(tmp_path):
    """samples/03_amplify.sh at 25 cm: equidimensional blocks (tile 0) below the tilted
    boundary, tabular (tile 1) above; the plateau and sea floor stay bare."""
    from conftest import BUILD
    sample = os.path.join(os.path.dirname(__file__), "..", "..", "samples", "03_amplify.sh")
    p = run(["bash", sample, BUILD, str(tmp_path), "0.25"])
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "amplify_cliff.png").stat().st_size > 10000
    grids, _ = vdb.readAll(str(tmp_path / "amplify_cliff.vdb"))
    mat = {g.name: g for g in grids}["material"]
    dx = 0.25
    elev = {0: [], 1: []}
    for it in mat.citerOnValues():
        if it.value < 1:
            continue  # bare terrain (material 0)
        x, y, z = (c * dx for c in it.min)
        elev[int(it.value) - 1].append(z + 0.2 * x)  # the strata's n·p (unnormalised normal)
        # The cliff (steeper than the rule) lies within 24..36 ± 4 m in x: the plateau and
        # the sea floor beyond it stay bare (blocks reach ~2 m past their anchors).
        assert 17 < x < 43, (x, y, z)
    assert elev[0] and elev[1]
    # Boundary at 14 (n·p with n = (0.2, 0, 1) normalised, ±1.5 m noise, blocks ~2 m).
    assert max(elev[0]) < min(elev[1]) + 5
    assert sum(elev[0]) / len(elev[0]) < 14 * 1.02 < sum(elev[1]) / len(elev[1])


def test_chunks_merge_to_the_whole_bake(inputs, tmp_path):
    """Two --region chunks split on a leaf boundary (x = 16 m = 10 leaves of 0.2 m voxels),
    merged by vdb_merge, equal the whole bake: every grid, active voxels and the inside /
    outside values around them (a margin of 3 leaves)."""
    import numpy as np
    whole, a, b, merged = (tmp_path / f"{n}.vdb" for n in ("whole", "a", "b", "merged"))
    assert amplify(inputs, inputs["cliff"], whole).returncode == 0
    assert amplify(inputs, inputs["cliff"], a, "--region", "-5,-5,-5,16,40,40").returncode == 0
    assert amplify(inputs, inputs["cliff"], b, "--region", "16,-5,-5,40,40,40").returncode == 0
    p = run([tool("vdb_merge"), str(a), str(b), "-o", str(merged)])
    assert p.returncode == 0, p.stderr
    gw = {g.name: g for g in vdb.readAll(str(whole))[0]}
    gm = {g.name: g for g in vdb.readAll(str(merged))[0]}
    ga = {g.name: g for g in vdb.readAll(str(a))[0]}
    assert set(gm) == set(gw) == {"surface", "block_id", "material"}
    assert 0 < ga["surface"].activeVoxelCount() < gw["surface"].activeVoxelCount()
    for name in gw:
        assert gm[name].activeVoxelCount() == gw[name].activeVoxelCount()
        lo, hi = gw[name].evalActiveVoxelBoundingBox()
        lo = tuple(c - 24 for c in lo)
        shape = tuple(hi[k] - lo[k] + 25 for k in range(3))
        dw, dm = np.zeros(shape, np.float32), np.zeros(shape, np.float32)
        gw[name].copyToArray(dw, ijk=lo)
        gm[name].copyToArray(dm, ijk=lo)
        assert np.array_equal(dw, dm), name
    assert gm["surface"].gridClass == vdb.GridClass.LEVEL_SET
    assert "vdb_merge" in gm["surface"].metadata["rockvdb:generator"]


def test_merge_refuses_chunks_of_different_bakes(inputs, tmp_path):
    a, coarse, other, out = (tmp_path / f"{n}.vdb" for n in ("a", "coarse", "other", "out"))
    assert amplify(inputs, inputs["cliff"], a, "--region", "-5,-5,-5,16,40,40").returncode == 0
    assert run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--cell-size", "0.5",
                "--height-scale", "10", "--tiles", str(inputs["tile"]), "--voxel-size", "0.25",
                "-o", str(coarse)]).returncode == 0
    one_line_error(run([tool("vdb_merge"), str(a), str(coarse), "-o", str(out)]), 2, "transform")
    assert not out.exists()
    # Overlapping chunks of two different bakes (the carving variant) disagree on voxels.
    assert amplify(inputs, inputs["cliff"], other, "--carve", "0.1").returncode == 0
    one_line_error(run([tool("vdb_merge"), str(a), str(other), "-o", str(out)]), 2, "disagree")
    assert not out.exists()
    # A file with other grids.
    sphere = tmp_path / "sphere.vdb"
    run([tool("vdb_primitive"), "sphere", "--radius", "1", "-o", str(sphere)], check=True)
    one_line_error(run([tool("vdb_merge"), str(a), str(sphere), "-o", str(out)]), 2, "other grids")
    assert not out.exists()


def test_coverage_is_the_share_of_surface_voxels_with_an_id(tmp_path):
    """rockvdb.coverage on a sphere of radius 3 m with the cap x > 1 m tagged: a sphere's area
    is uniform along any axis, so steep ground (|n_z| < 0.6, |z| < 1.8 m) is 60% of it and the
    cap a third; the shares within each part, from uniform points on the sphere."""
    import numpy as np
    import rockvdb
    u = np.random.default_rng(1).normal(size=(400000, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    steep_part, cap = np.abs(u[:, 2]) < 0.6, u[:, 0] > 1 / 3
    want_steep, want_gentle = cap[steep_part].mean(), cap[~steep_part].mean()
    g = rockvdb.sphere(3.0).bake(voxel_size=0.1)
    lo, hi = g.evalActiveVoxelBoundingBox()
    shape = tuple(h - l + 1 for l, h in zip(lo, hi))
    tag = np.full(shape, -1.0, np.float32)
    x = (np.arange(shape[0]) + lo[0]) * 0.1
    tag[x > 1.0] = 7.0
    ids = vdb.FloatGrid(-1.0)
    ids.copyFromArray(tag, ijk=lo)
    c = rockvdb.coverage(g, ids)
    total = c["steep_voxels"] + c["gentle_voxels"]
    assert c["steep_voxels"] / total == pytest.approx(0.6, abs=0.04)
    assert c["steep"] == pytest.approx(want_steep, abs=0.03)
    assert c["gentle"] == pytest.approx(want_gentle, abs=0.03)
    # The region limits what counts: only x > 1 m is all tagged.
    assert rockvdb.coverage(g, ids, region=(1.05, -9, 9, 9))["steep"] == 1.0
    with pytest.raises(TypeError, match="coverage.*ids"):
        rockvdb.coverage(g, "block_id")
    with pytest.raises(ValueError, match="coverage: region"):
        rockvdb.coverage(g, ids, region=(5, 0, 1, 1))
    empty = vdb.FloatGrid(0.3)
    assert rockvdb.coverage(empty, ids) == {"steep": 0.0, "gentle": 0.0, "steep_voxels": 0,
                                            "gentle_voxels": 0}


def test_cliffs_read_as_walls_of_blocks(inputs, tmp_path):
    """At the default presence rules and with the default filled tile, >= 90% of the steep
    surface of a cliff carries a block id (2 m clear of the footprint's edges), while gentle
    ground (plateau, floor) stays mostly bare terrain."""
    import rockvdb
    out = tmp_path / "walls.vdb"
    p = amplify(inputs, inputs["cliff"], out)
    assert p.returncode == 0, p.stderr
    g = {x.name: x for x in vdb.readAll(str(out))[0]}
    c = rockvdb.coverage(g["surface"], g["block_id"], region=(2, 2, 30, 30))
    assert c["steep_voxels"] > 5000
    assert c["steep"] >= 0.9, c
    assert c["gentle"] < 0.5, c
    # Python without presence arguments takes the same defaults: the same grids, bit for bit.
    s, ids, _ = rockvdb.amplify(str(inputs["cliff"]), [str(inputs["tile"])], cell_size=0.5,
                                height_scale=10, voxel_size=0.2)
    assert_bitwise_equal(s, g["surface"])
    assert_bitwise_equal(ids, g["block_id"])


def test_aperiodic_tiles_cli_python_and_replay(inputs, tmp_path):
    """--aperiodic: the blocks of corner-coloured cube tiles (the tile's parameters) on the
    cliff only; ids name region content (8192-id slots, not the periodic tile's indices); the
    CLI, Python and the file's own provenance give the same grids; bad input is refused."""
    import rockvdb

    out = tmp_path / "ap.vdb"
    p = amplify(inputs, inputs["cliff"], out, "--aperiodic", "--colours", "2")
    assert p.returncode == 0, p.stderr
    assert "#R " in p.stderr
    g = {x.name: x for x in vdb.readAll(str(out))[0]}
    assert g["surface"].gridClass == vdb.GridClass.LEVEL_SET
    dx = g["surface"].transform.voxelSize()[0]
    ids = set()
    for it in g["block_id"].citerOnValues():
        if it.value >= 0:
            assert 14 - 3.5 < it.min[0] * dx < 18 + 3.5
            ids.add(int(it.value))
    assert len(ids) > 20
    # Every region of a cube tile has a slot: the cube's own blocks (slot 7), its faces' ...
    assert max(ids) >= 8192 and len({i // 8192 for i in ids}) >= 4, sorted(ids)[:20]
    # Python, the same call.
    s, b, _ = rockvdb.amplify(str(inputs["cliff"]), [str(inputs["tile"])], cell_size=0.5, height_scale=10,
                              voxel_size=0.2, aperiodic=True, colours=2)
    assert_bitwise_equal(s, g["surface"])
    assert_bitwise_equal(b, g["block_id"])
    # The file's provenance replays it.
    params = tmp_path / "params.json"
    prov = json.loads(g["surface"].metadata["rockvdb:params"])
    assert prov["aperiodic"] is True and prov["colours"] == 2
    params.write_text(json.dumps(prov))
    again = tmp_path / "again.vdb"
    p = run([tool("vdb_amplify"), "--params", str(params), "-o", str(again)])
    assert p.returncode == 0, p.stderr
    assert_bitwise_equal(vdb.read(str(again), "surface"), g["surface"])
    # Bad input: two tiles, a colour count out of range, a tile with user fractures.
    one_line_error(run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--tiles",
                        f"{inputs['tile']},{inputs['tile']}", "--aperiodic", "-o", str(tmp_path / "o.vdb")]),
                   2, "need strata")
    one_line_error(amplify(inputs, inputs["cliff"], tmp_path / "o.vdb", "--aperiodic", "--colours", "5"), 2,
                   "colours")
    frac = tmp_path / "frac.tile"
    run([tool("vdb_blocks"), "-q", "--tile-size", "10", "--point-radius", "0.5", "--voxel-size", "0.25",
         "--fractures", '[{"center": [5, 5, 5], "normal": [0, 0, 1], "radius": 3}]', "--tile", str(frac),
         "-o", str(tmp_path / "frac.vdb")], check=True)
    p = run([tool("vdb_amplify"), "--terrain", str(inputs["cliff"]), "--cell-size", "0.5", "--tiles", str(frac),
             "--aperiodic", "-o", str(tmp_path / "o.vdb")])
    one_line_error(p, 2, "user fractures")
    assert not (tmp_path / "o.vdb").exists()
