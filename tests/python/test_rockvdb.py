# SPDX-License-Identifier: Apache-2.0
"""The rockvdb Python module: pyopenvdb grids in and out, analytic checks, errors."""
import json
import math

import numpy as np
import pyopenvdb as vdb
import pytest

import rockvdb
from conftest import assert_bitwise_equal, dense, one_line_error, run, tool, write_png16


def inside_volume(grid):
    """Volume of the inside region by counting voxels with value < 0 in the active band
    plus interior tiles (coarse but independent of our code)."""
    dx = grid.transform.voxelSize()[0]
    n = 0
    for it in grid.citerAllValues():
        if it.value < 0:
            n += it.count
    return n * dx ** 3


def test_bake_returns_pyopenvdb_level_set():
    g = rockvdb.sphere(1.0, center=(0.5, 0, 0)).bake(voxel_size=0.05)
    assert isinstance(g, vdb.FloatGrid)
    assert g.name == "surface"
    assert g.gridClass == vdb.GridClass.LEVEL_SET
    assert g.background == pytest.approx(0.15)
    acc = g.getConstAccessor()
    assert acc.getValue((10, 0, 0)) < 0 < acc.getValue((40, 0, 0))
    # Exact distance on a voxel inside the band: (0.5 + 1.05, 0, 0) is 0.05 outside.
    assert acc.getValue((31, 0, 0)) == pytest.approx(0.05, abs=1e-5)
    assert inside_volume(g) == pytest.approx(4 / 3 * math.pi, rel=0.02)


def test_operators_and_provenance_expression_rebuilds_field():
    f = (rockvdb.sphere(1.0) | rockvdb.box((2.5, 0.5, 0.5), rounding=0.1)) - rockvdb.sphere(0.4, (0, 0, 1))
    g = f.bake(voxel_size=0.05)
    version, generator, params = rockvdb.provenance(g)
    assert generator == "rockvdb.Field.bake" and version == rockvdb.__version__
    p = json.loads(params)
    again = rockvdb.expression(json.dumps(p["expression"])).bake(voxel_size=p["voxel_size"])
    a, b = np.zeros((80, 80, 80), np.float32), np.zeros((80, 80, 80), np.float32)
    g.copyToArray(a, ijk=(-40, -40, -40))
    again.copyToArray(b, ijk=(-40, -40, -40))
    assert np.array_equal(a, b)
    assert f.eval((1.2, 0, 0)) < 0      # inside the box's long arm (x up to 1.25)
    assert f.eval((0, 0, 0.9)) > 0      # carved away by the small sphere
    assert f.eval((0, 0, -0.9)) < 0     # the sphere's opposite side is untouched


def test_smooth_union_adds_material():
    a, b = rockvdb.sphere(0.6, (-0.5, 0, 0)), rockvdb.sphere(0.6, (0.5, 0, 0))
    hard = inside_volume((a | b).bake(voxel_size=0.04))
    soft = inside_volume(a.union(b, smooth=0.3).bake(voxel_size=0.04))
    assert soft > hard * 1.01


def test_attribute_grid_and_warp():
    f = rockvdb.sphere(0.5, (-1, 0, 0)).tag(3) | rockvdb.sphere(0.5, (1, 0, 0)).warp(0.05, 2, seed=1).tag(4)
    surface, ids = f.bake(voxel_size=0.05, attribute="rock_id")
    assert ids.name == "rock_id" and ids.background == -1
    assert ids.activeVoxelCount() == surface.activeVoxelCount()
    vals = {it.value for it in ids.citerOnValues()}
    assert vals == {3.0, 4.0}


def test_csg_on_grids_leaves_inputs_untouched():
    a = rockvdb.sphere(0.7, (-0.3, 0, 0)).bake(voxel_size=0.05)
    b = rockvdb.sphere(0.7, (0.3, 0, 0)).bake(voxel_size=0.05)
    na = a.activeVoxelCount()
    u = rockvdb.csg("union", [a, b])
    i = rockvdb.csg("intersection", [a, b])
    assert a.activeVoxelCount() == na
    assert inside_volume(u) + inside_volume(i) == pytest.approx(inside_volume(a) + inside_volume(b), rel=0.02)


def test_heightfield_and_files_round_trip(tmp_path):
    ramp = np.tile(np.linspace(0, 1, 21, dtype=np.float32), (21, 1))  # rises along x (columns)
    path = str(tmp_path / "ramp.exr")
    rockvdb.write_heightfield(path, ramp)
    g = rockvdb.heightfield(path, cell_size=0.1, height_scale=2.0, voxel_size=0.05)
    # Slope 1 along x: point (1, 1, h + d) has signed distance d/sqrt(2).
    acc = g.getConstAccessor()
    x, y = 1.0, 1.0
    h = 2.0 * x / 2.0
    z = h + 0.1
    ijk = g.transform.worldToIndexCellCentered((x, y, z))
    assert acc.getValue(ijk) == pytest.approx(0.1 / math.sqrt(2), abs=0.003)
    out = str(tmp_path / "hf.vdb")
    rockvdb.write(out, [g])
    back = rockvdb.read(out)
    assert back.activeVoxelCount() == g.activeVoxelCount()
    grids, _ = vdb.readAll(out)
    assert [x.name for x in grids] == ["surface"]
    rockvdb.mesh(back, str(tmp_path / "hf.obj"))
    assert (tmp_path / "hf.obj").read_text().count("\nf ") > 100
    rockvdb.preview(back, str(tmp_path / "hf.png"), width=64, height=48)
    assert (tmp_path / "hf.png").read_bytes()[:4] == b"\x89PNG"


def test_write_stamps_foreign_grids_without_touching_them(tmp_path):
    foreign = vdb.createLevelSetSphere(1.0, voxelSize=0.1)
    foreign.name = "surface"
    rockvdb.write(str(tmp_path / "f.vdb"), [foreign])
    assert "rockvdb:generator" not in foreign.metadata
    back = rockvdb.read(str(tmp_path / "f.vdb"))
    assert rockvdb.provenance(back)[1] == "rockvdb.write"
    assert back.activeVoxelCount() == foreign.activeVoxelCount()
    # csg keeps its inputs' provenance.
    a = rockvdb.sphere(1).bake(voxel_size=0.1)
    sources = json.loads(rockvdb.provenance(rockvdb.csg("union", [a, back]))[2])["sources"]
    assert [s["generator"] for s in sources] == ["rockvdb.Field.bake", "rockvdb.write"]


def test_heightfield_exact_band_follows_the_bake(tmp_path):
    # A 60° slope breaking to 20° at x = 2 m, baked with a wide band (voxel 0.4 m, half width
    # 4 = 1.6 m) from an expression. Over the 20° part the global-slope lower bound is about
    # half the true distance, so every band value must come from the exact search, beyond the
    # field's 1 m default radius: the heightfield takes its radius from the bake's band.
    t60, t20 = math.tan(math.radians(60)), math.tan(math.radians(20))
    xs = np.arange(41, dtype=np.float64) * 0.25
    h = np.where(xs < 2, xs * t60, 2 * t60 + (xs - 2) * t20)
    path = str(tmp_path / "break.exr")
    rockvdb.write_heightfield(path, np.tile((h / 10.0).astype(np.float32), (41, 1)))
    f = rockvdb.expression(json.dumps({"type": "heightfield", "file": path, "cell_size": 0.25,
                                       "height_scale": 10.0, "base_depth": 30}))
    g = f.bake(voxel_size=0.4, half_width=4)
    worst, far, n = 0.0, 0, 0
    for it in g.citerOnValues():
        if it.count != 1:
            continue
        x, y, z = (c * 0.4 for c in it.min)
        surface = 2 * t60 + (x - 2) * t20
        if not (5 <= x <= 8 and 2 < y < 8 and abs(z - surface) < 3):
            continue  # the walls and the floor 30 m down are not part of the slope
        expected = (z - surface) * math.cos(math.radians(20))
        worst = max(worst, abs(it.value - expected))
        far += abs(expected) > 1.05
        n += 1
    assert n > 100 and far > 20
    assert worst < 0.05 * 0.4


def test_errors_are_python_exceptions(tmp_path):
    with pytest.raises(ValueError, match="sphere: radius must be > 0"):
        rockvdb.sphere(-1)
    with pytest.raises(ValueError, match="bake: voxel_size must be in"):  # Python's spelling
        rockvdb.sphere(1).bake(voxel_size=0)
    with pytest.raises(ValueError, match="voxel_size must be finite"):
        rockvdb.sphere(1).bake(voxel_size=float("nan"))
    with pytest.raises(ValueError, match="refusing"):
        rockvdb.sphere(100).bake(voxel_size=1e-4)
    with pytest.raises(ValueError, match="unbounded"):
        rockvdb.plane().bake()
    with pytest.raises(TypeError):
        rockvdb.mesh(None, str(tmp_path / "x.obj"))
    with pytest.raises(TypeError):
        rockvdb.csg("union", [None])
    with pytest.raises(ValueError, match="unknown operation"):
        rockvdb.csg("xor", [rockvdb.sphere(1).bake(voxel_size=0.1)])
    with pytest.raises(IOError, match="no such file"):
        rockvdb.read(str(tmp_path / "missing.vdb"))
    (tmp_path / "junk.vdb").write_text("junk")
    with pytest.raises(IOError, match="not a VDB"):
        rockvdb.read(str(tmp_path / "junk.vdb"))
    g = rockvdb.sphere(1).bake(voxel_size=0.1)
    with pytest.raises(ValueError, match="no grid 'density'"):
        rockvdb.write(str(tmp_path / "s.vdb"), [g]) or rockvdb.read(str(tmp_path / "s.vdb"), "density")
    fog = g.deepCopy()
    fog.gridClass = vdb.GridClass.FOG_VOLUME
    with pytest.raises(ValueError, match="fog volume"):
        rockvdb.mesh(fog, str(tmp_path / "f.obj"))
    with pytest.raises(IOError):
        rockvdb.write("/nonexistent/dir/x.vdb", [g])
    with pytest.raises(ValueError, match="csg: refusing smooth radius"):
        rockvdb.csg("union", [g, g], smooth=1e4)
    with pytest.raises(ValueError, match="expression"):
        rockvdb.expression('{"type": "sphre"}')
    with pytest.raises(IOError):
        rockvdb.heightfield(str(tmp_path / "none.exr"))


SMALL_TILE = dict(tile_size=10, point_radius=0.5)



def test_block_tile_grids_blocks_and_stats():
    t = rockvdb.block_tile(type="tabular", seed=4, voxel_size=0.1, **SMALL_TILE)
    assert isinstance(t.surface, vdb.FloatGrid) and isinstance(t.block_id, vdb.FloatGrid)
    assert t.surface.gridClass == vdb.GridClass.LEVEL_SET and t.block_id.name == "block_id"
    assert t.stats["blocks"] == len(t.blocks) > 10
    assert t.stats["points"] > 4000 and t.stats["discs"] == 30
    assert all(b["kind"] in ("polytope", "segment", "point") for b in t.blocks)
    # Every block's planes hold its anchors (centroid first) inside: n·a <= d.
    for b in t.blocks:
        if b["kind"] != "polytope":
            continue
        for nx, ny, nz, d in b["planes"]:
            ax, ay, az = b["anchors"][0]
            assert nx * ax + ny * ay + nz * az <= d + 1e-4
    # The periodic field repeats with the tile.
    f = t.field(periodic=True)
    for p in [(1.3, 2.7, 4.1), (7.9, 0.2, 9.6)]:
        q = (p[0] + 10, p[1], p[2] - 10)
        assert f.eval(p) == pytest.approx(f.eval(q), abs=2e-4)


def test_tile_file_round_trip_is_bitwise(tmp_path):
    t = rockvdb.block_tile(type="equidimensional", seed=2, voxel_size=0.1, **SMALL_TILE)
    path = tmp_path / "eq.tile"
    t.save(path)
    u = rockvdb.load_tile(path)
    assert u.blocks == t.blocks and u.params == t.params
    s, ids = u.bake(voxel_size=0.1)
    (ba, a), (bb, b) = dense(t.surface), dense(s)
    assert ba == bb and np.array_equal(a.view(np.uint32), b.view(np.uint32))
    assert json.loads(s["rockvdb:tile"])["blocks"] == t.blocks
    assert rockvdb.provenance(s)[1] == "vdb_blocks"  # the same record as the CLI writes


def test_authored_expression_block_cli_python_and_replay_agree(tmp_path):
    """Any bounded expression is an authored block (implicit blocks section 4.2): a smooth
    union of a sphere and a capsule is block 0 from the CLI and from Python, the same bits,
    and the output's own provenance replays it."""
    expr = {"type": "union", "smooth": 0.6, "children": [
        {"type": "sphere", "center": [5, 5, 5], "radius": 1.5},
        {"type": "capsule", "a": [3.5, 5, 5], "b": [7, 6, 5.5], "radius": 0.8}]}
    (tmp_path / "a.json").write_text(json.dumps([expr]))
    args = ["--tile-size", "10", "--point-radius", "0.5", "--voxel-size", "0.1", "--seed", "2"]
    run([tool("vdb_blocks"), *args, "--authored", str(tmp_path / "a.json"), "-q",
         "-o", str(tmp_path / "cli.vdb")], check=True)
    t = rockvdb.block_tile(authored=[expr], voxel_size=0.1, seed=2, **SMALL_TILE)
    assert t.blocks[0]["kind"] == "expression" and t.blocks[0]["expression"] == expr
    cli = {g.name: g for g in vdb.readAll(str(tmp_path / "cli.vdb"))[0]}
    assert_bitwise_equal(cli["surface"], t.surface)
    assert_bitwise_equal(cli["block_id"], t.block_id)
    # Voxels in the band around the sphere's top (z = 6.5, away from the capsule) are block 0.
    acc, ids = t.surface.getConstAccessor(), t.block_id.getConstAccessor()
    top = [(50, 50, k) for k in range(62, 66) if abs(acc.getValue((50, 50, k))) < 0.1]
    assert top and all(ids.getValue(ijk) == 0 for ijk in top if acc.getValue(ijk) < 0)
    (tmp_path / "p.json").write_text(cli["surface"].metadata["rockvdb:params"])
    run([tool("vdb_blocks"), "--params", str(tmp_path / "p.json"), "-q",
         "-o", str(tmp_path / "replay.vdb")], check=True)
    again = {g.name: g for g in vdb.readAll(str(tmp_path / "replay.vdb"))[0]}
    assert_bitwise_equal(again["surface"], t.surface)
    # A bad expression block: one line naming the entry, nothing written.
    (tmp_path / "bad.json").write_text(json.dumps([{"type": "plane", "normal": [0, 0, 1]}]))
    p = run([tool("vdb_blocks"), *args, "--authored", str(tmp_path / "bad.json"),
             "-o", str(tmp_path / "bad.vdb")])
    one_line_error(p, 2, "authored[0]", "unbounded")
    assert not (tmp_path / "bad.vdb").exists()
    with pytest.raises(ValueError, match="authored\\[0\\].*'warp'"):
        rockvdb.block_tile(authored=[{"type": "warp", "child": expr}], bake=False, **SMALL_TILE)


def test_mesh_ids_from_python_are_the_clis(tmp_path):
    """rockvdb.mesh(ids=[...]) writes the ids per vertex as vdb_mesh does: the same bytes."""
    t = rockvdb.block_tile(voxel_size=0.2, seed=4, tile_size=8, point_radius=0.5)
    rockvdb.write(str(tmp_path / "t.vdb"), [t.surface, t.block_id])
    for ext in ("ply", "obj"):
        run([tool("vdb_mesh"), "-q", str(tmp_path / "t.vdb"), "-o", str(tmp_path / f"cli.{ext}")],
            check=True)
        rockvdb.mesh(t.surface, tmp_path / f"py.{ext}", ids=[t.block_id])
        assert (tmp_path / f"cli.{ext}").read_bytes() == (tmp_path / f"py.{ext}").read_bytes()
    assert b"property int block_id" in (tmp_path / "py.ply").read_bytes()[:400]
    with pytest.raises(TypeError, match="ids"):
        rockvdb.mesh(t.surface, tmp_path / "x.obj", ids=t.block_id)


def test_block_tile_errors_are_exceptions(tmp_path):
    with pytest.raises(ValueError, match="type must be one of"):
        rockvdb.block_tile(type="granite", bake=False)
    with pytest.raises(ValueError, match=r"point_radius must be in \(0, tile_size / 2\)"):
        rockvdb.block_tile(tile_size=10, point_radius=6, bake=False)
    with pytest.raises(ValueError, match="fractures"):
        rockvdb.block_tile(fractures=[{"center": [1, 2, 3]}], bake=False, **SMALL_TILE)
    with pytest.raises(TypeError):
        rockvdb.block_tile(colour="red", bake=False)
    # A positional argument names the function it was given to.
    with pytest.raises(TypeError, match=r"rockvdb\.block_tile\(\): too many positional arguments"):
        rockvdb.block_tile(10)
    with pytest.raises(IOError):
        rockvdb.load_tile(tmp_path / "missing.tile")
    (tmp_path / "bad.tile").write_text("{}")
    with pytest.raises(IOError, match="tile file .*bad.tile.: not a rockvdb tile"):
        rockvdb.load_tile(tmp_path / "bad.tile")


def test_amplify_grids_in_and_out(tmp_path):
    """pyopenvdb terrain grid in, (surface, block_id, material) out; strata by tile index."""
    # A ramp terrain: flat, a 60° slope, flat (heightfield written to disk, baked to a grid).
    png = tmp_path / "ramp.png"
    write_png16(png, [[round(65535 * min(1.0, max(0.0, (i - 20) / 12))) for i in range(65)]
                      for _ in range(65)])
    ground = rockvdb.heightfield(str(png), cell_size=0.25, height_scale=5.0, voxel_size=0.1)
    eq = rockvdb.block_tile(type="equidimensional", seed=3, bake=False, **SMALL_TILE)
    tab = rockvdb.block_tile(type="tabular", seed=4, bake=False, **SMALL_TILE)
    strata = {"layers": [{"tile": 0, "top": 2.5}, {"tile": 1}]}
    s, ids, mat = rockvdb.amplify(ground, [eq, tab], strata=strata, voxel_size=0.1)
    assert s.gridClass == vdb.GridClass.LEVEL_SET and ids.name == "block_id"
    assert mat.name == "material"
    assert s.activeVoxelCount() == ids.activeVoxelCount() == mat.activeVoxelCount()
    mats = {it.value for it in mat.citerOnValues()}
    assert mats == {0.0, 1.0, 2.0}  # bare terrain, tile 0's blocks, tile 1's
    # The same from the heightfield path; bad input raises.
    s2, _, _ = rockvdb.amplify(str(png), [eq], cell_size=0.25, height_scale=5.0, voxel_size=0.1)
    assert s2.activeVoxelCount() > 0
    with pytest.raises(ValueError, match="strata"):
        rockvdb.amplify(ground, [eq, tab], voxel_size=0.1)
    with pytest.raises(ValueError, match="unknown tile"):
        rockvdb.amplify(ground, [eq, tab], strata={"layers": [{"tile": "granite"}]})
    with pytest.raises(TypeError):
        rockvdb.amplify(None, [eq])


def test_amplify_mask_roi_carve_and_stats(tmp_path):
    """mask (array or image file), roi, carve and stats, as vdb_amplify offers them."""
    png = tmp_path / "ramp.png"
    write_png16(png, [[round(65535 * min(1.0, max(0.0, (i - 20) / 12))) for i in range(65)]
                      for _ in range(65)])
    eq = rockvdb.block_tile(type="equidimensional", seed=3, bake=False, **SMALL_TILE)
    common = dict(cell_size=0.25, height_scale=5.0, voxel_size=0.1, max_slope=0.8)

    def block_ys(ids):
        return [it.min[1] * 0.1 for it in ids.citerOnValues() if it.value >= 0]

    full = {}
    _, ids_full, _ = rockvdb.amplify(str(png), [eq], stats=full, **common)
    assert full["replicated"] > 0 and full["active_voxels"] > 0
    assert 1e5 < full["block_field_bytes"] < 4e6  # the tile's planes, anchors and relief table
    assert all(full[k] >= 0 for k in ("presence_seconds", "bake_seconds", "split_seconds"))
    # Mask: blocks allowed only where y >= 8 m (rows are y, one pixel per heightfield cell).
    mask = np.zeros((65, 65), dtype=np.float32)
    mask[32:, :] = 1.0
    masked = {}
    _, ids_m, _ = rockvdb.amplify(str(png), [eq], mask=mask, stats=masked, **common)
    assert 0 < masked["replicated"] < full["replicated"]
    # A present copy has more than half its anchors in the mask: its voxels reach at most
    # one block (10 m tile, blocks ~2 m) below y = 8 m.
    assert min(block_ys(ids_m)) > 8.0 - 4.0
    # The same mask as a 16-bit PNG file gives the same grids.
    mpng = tmp_path / "mask.png"
    write_png16(mpng, [[65535 if j >= 32 else 0 for _ in range(65)] for j in range(65)])
    _, ids_f, _ = rockvdb.amplify(str(png), [eq], mask=str(mpng), **common)
    assert ids_f.activeVoxelCount() == ids_m.activeVoxelCount()
    assert np.array_equal(dense(ids_f)[1], dense(ids_m)[1])
    # roi: anchors limited to y <= 6 m.
    _, ids_r, _ = rockvdb.amplify(str(png), [eq], roi=(-100, -100, -100, 100, 6, 100), **common)
    assert 0 < len(block_ys(ids_r)) and max(block_ys(ids_r)) < 6.0 + 4.0
    # carve: the bare terrain is cut back beside blocks, so the carved solid is not a superset.
    s_u, _, _ = rockvdb.amplify(str(png), [eq], **common)
    s_c, _, _ = rockvdb.amplify(str(png), [eq], carve=0.05, **common)
    lo = np.minimum(s_u.evalActiveVoxelBoundingBox()[0], s_c.evalActiveVoxelBoundingBox()[0])
    hi = np.maximum(s_u.evalActiveVoxelBoundingBox()[1], s_c.evalActiveVoxelBoundingBox()[1])
    du = np.zeros(tuple(hi - lo + 1), np.float32)
    dc = np.zeros_like(du)
    s_u.copyToArray(du, ijk=tuple(int(v) for v in lo))
    s_c.copyToArray(dc, ijk=tuple(int(v) for v in lo))
    assert np.count_nonzero((du < 0) & (dc > 0)) > 100
    # Mixed tile sizes need an explicit choice.
    big = rockvdb.block_tile(type="equidimensional", seed=3, bake=False, tile_size=12,
                             point_radius=0.5)
    strata = {"layers": [{"tile": 0, "top": 2.5}, {"tile": 1}]}
    with pytest.raises(ValueError, match="tile sizes differ"):
        rockvdb.amplify(str(png), [eq, big], strata=strata, **common)
    s_mix, _, _ = rockvdb.amplify(str(png), [eq, big], strata=strata, mixed_tile_sizes=True,
                                  **common)
    assert s_mix.activeVoxelCount() > 0
