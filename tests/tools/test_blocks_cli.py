# SPDX-License-Identifier: Apache-2.0
"""vdb_blocks: Table-1 statistics, grids and tile metadata, the tile file round trip, per-block
meshes, periods, and bad input (one line, right exit code, nothing written)."""
import json
import re
import struct
import zlib

import pyopenvdb as vdb
import pytest

from conftest import assert_bitwise_equal, one_line_error, run, tool

SMALL = ["--tile-size", "10", "--point-radius", "0.5", "--voxel-size", "0.1", "--seed", "3"]




@pytest.fixture(scope="module")
def tile(tmp_path_factory):
    d = tmp_path_factory.mktemp("tile")
    out, tfile, mesh = d / "t.vdb", d / "t.tile", d / "t.obj"
    p = run([tool("vdb_blocks"), "--type", "tabular", *SMALL, "-o", str(out), "--tile", str(tfile),
             "--meshes", str(mesh)], check=True)
    return {"dir": d, "vdb": out, "tile": tfile, "obj": mesh, "stderr": p.stderr}


def test_statistics_like_table_1(tile):
    err = tile["stderr"]
    m = re.search(r"#P (\d+) points, #D (\d+) discs, #B (\d+) blocks, mean #Pi ([\d.]+)", err)
    assert m, err
    points, discs, blocks, mean = int(m[1]), int(m[2]), int(m[3]), float(m[4])
    assert 4000 < points < 5500 and discs == 30 and blocks > 10
    assert mean * blocks <= points  # dropped clusters lose points, never gain
    g = re.findall(r"^vdb_blocks: generation: (\d+\.\d{3}) s$", err, re.M)
    assert len(g) == 1 and 0 < float(g[0]) < 5


def test_grids_ids_and_tile_metadata(tile):
    grids, meta = vdb.readAll(str(tile["vdb"]))
    names = {g.name: g for g in grids}
    assert set(names) == {"surface", "block_id"}
    s, ids = names["surface"], names["block_id"]
    assert s.gridClass == vdb.GridClass.LEVEL_SET
    assert s.activeVoxelCount() == ids.activeVoxelCount() > 10000
    t = json.loads(s["rockvdb:tile"])
    assert t["format"] == "rockvdb-tile" and t["params"]["type"] == "tabular"
    nblocks = len(t["blocks"])
    # Every active voxel carries an integer id of an existing block.
    seen = set()
    for item in ids.citerOnValues():
        v = item.value
        assert v == int(v) and 0 <= v < nblocks
        seen.add(int(v))
    assert len(seen) > nblocks // 2
    # The standalone tile file is the same description, and compact.
    assert json.loads(tile["tile"].read_text())["blocks"] == t["blocks"]
    assert tile["tile"].stat().st_size < 1_000_000


@pytest.mark.parametrize("source", ["tile", "vdb"])
def test_from_tile_reproduces_the_grid_bitwise(tile, source, tmp_path):
    out = tmp_path / "again.vdb"
    run([tool("vdb_blocks"), "-q", "--from-tile", str(tile[source]), "--voxel-size", "0.1",
         "-o", str(out)], check=True)
    assert_bitwise_equal(vdb.read(str(tile["vdb"]), "surface"), vdb.read(str(out), "surface"))


def test_one_mesh_per_block(tile, tmp_path):
    blocks = int(re.search(r"#B (\d+) blocks", tile["stderr"])[1])
    lines = tile["obj"].read_text().splitlines()
    objects = [l for l in lines if l.startswith("o block_")]
    assert len(objects) == blocks
    # Each block's faces carry its id (usemtl block_id_<i>, one per object), as the PLY's
    # vertex property block_id does.
    current = None
    for l in lines:
        if l.startswith("o block_"):
            current = l.split("_")[1]
        elif l.startswith("usemtl "):
            assert l == f"usemtl block_id_{current}", l
    assert sum(l.startswith("usemtl ") for l in lines) == blocks
    # Meshed in parallel, written in block order: the same bytes on one thread.
    one = tmp_path / "one.obj"
    run([tool("vdb_blocks"), "-q", "--threads", "1", "--from-tile", str(tile["tile"]),
         "--voxel-size", "0.1", "-o", str(tmp_path / "o.vdb"), "--meshes", str(one)], check=True)
    assert one.read_bytes() == tile["obj"].read_bytes()


def obj_mesh(path):
    """(points N x 3, polygon centres M x 3) of an OBJ."""
    import numpy as np
    pts, faces = [], []
    for l in path.read_text().splitlines():
        if l.startswith("v "):
            pts.append([float(x) for x in l.split()[1:4]])
        elif l.startswith("f "):
            faces.append([int(x.split("/")[0]) - 1 for x in l.split()[1:]])
    pts = np.array(pts)
    return pts, np.array([pts[f].mean(axis=0) for f in faces])


def test_mesh_adaptivity_merges_flat_faces_on_the_surface(tile, tmp_path):
    """--meshes at the default adaptivity: a fraction of the uniform mesh's vertices, its
    polygon centres still on the blocks' surface (the tile's level set: blocks bake whole, in
    their home frame); 0 is one quad per surface voxel."""
    import numpy as np
    uniform = tmp_path / "u.obj"
    run([tool("vdb_blocks"), "-q", "--from-tile", str(tile["tile"]), "--voxel-size", "0.1",
         "-o", str(tmp_path / "o.vdb"), "--meshes", str(uniform), "--mesh-adaptivity", "0"],
        check=True)
    s = vdb.read(str(tile["vdb"]), "surface")
    dx = s.transform.voxelSize()[0]
    lo, hi = s.evalActiveVoxelBoundingBox()
    lo = np.array(lo)
    dense = np.full(tuple(np.array(hi) - lo + 1), s.background, dtype=np.float32)
    s.copyToArray(dense, ijk=tuple(int(x) for x in lo))

    def phi(points):
        """Trilinear φ (voxel centres at index · dx, as the grid's transform)."""
        g = points / dx - lo
        i0 = np.floor(g).astype(int)
        t = g - i0
        out = np.zeros(len(points))
        for corner in range(8):
            o = np.array([(corner >> k) & 1 for k in range(3)])
            idx = np.clip(i0 + o, 0, np.array(dense.shape) - 1)
            w = np.prod(np.where(o, t, 1 - t), axis=1)
            out += w * dense[idx[:, 0], idx[:, 1], idx[:, 2]]
        return out

    up, uc = obj_mesh(uniform)
    ap, ac = obj_mesh(tile["obj"])  # the fixture's: the default adaptivity
    assert len(ap) < 0.4 * len(up), (len(ap), len(up))
    # Each block is meshed from its own level set, the tile's unites them (fracture faces
    # differ by a fraction of a voxel): the uniform mesh is the yardstick, and merging flat
    # faces must not move the polygon centres off the surface beyond it.
    eu, ea = (np.percentile(np.abs(phi(c)) / dx, [50, 90, 95]) for c in (uc, ac))
    assert eu[0] < 0.3 and (ea <= eu + 0.1).all(), (eu, ea)
    bad = run([tool("vdb_blocks"), "-q", "--from-tile", str(tile["tile"]), "--voxel-size", "0.1",
               "-o", str(tmp_path / "b.vdb"), "--meshes", str(tmp_path / "b.obj"),
               "--mesh-adaptivity", "1.5"])
    one_line_error(bad, 2, "mesh-adaptivity")
    assert not (tmp_path / "b.vdb").exists() and not (tmp_path / "b.obj").exists()
    bad = run([tool("vdb_blocks"), "-q", "--from-tile", str(tile["tile"]), "--voxel-size", "0.1",
               "-o", str(tmp_path / "c.vdb"), "--mesh-adaptivity", "0.5"])
    one_line_error(bad, 2, "--mesh-adaptivity applies to --meshes")


def test_periods_repeat_the_tile(tmp_path):
    one, two = tmp_path / "1.vdb", tmp_path / "2.vdb"
    common = [tool("vdb_blocks"), "-q", "--type", "equidimensional", *SMALL, "--warp-amplitude", "0"]
    run(common + ["-o", str(one)], check=True)
    run(common + ["--periods", "2,1,1", "-o", str(two)], check=True)
    a, b = vdb.read(str(one), "surface"), vdb.read(str(two), "surface")
    # Two copies; where their bands meet across the shared face (blocks fill the tile up to
    # it) voxels are counted once: a 10 m x 10 m face, a few voxels deep, of ~1.6 M.
    assert 1.9 * a.activeVoxelCount() < b.activeVoxelCount() <= 2 * a.activeVoxelCount()
    lo, hi = b.evalActiveVoxelBoundingBox()
    lo1, hi1 = a.evalActiveVoxelBoundingBox()
    assert hi[0] - lo[0] == pytest.approx(hi1[0] - lo1[0] + 100, abs=2)  # one tile = 100 voxels


def test_aperiodic_periods_are_cubes_of_the_coloured_tiling(tmp_path):
    """--aperiodic: the cubes [0, periods) of the corner-coloured tiling, from the lattice's
    origin, ids naming each region's content; the file's provenance replays it bit for bit, and
    block meshes are refused in one line."""
    out = tmp_path / "ap.vdb"
    common = [tool("vdb_blocks"), "-q", "--type", "polyhedral", "--tile-size", "10", "--point-radius", "0.5",
              "--voxel-size", "0.25", "--seed", "3"]
    run(common + ["--aperiodic", "--periods", "2,1,1", "-o", str(out)], check=True)
    s, ids = vdb.read(str(out), "surface"), vdb.read(str(out), "block_id")
    assert s.gridClass == vdb.GridClass.LEVEL_SET
    lo, hi = s.evalActiveVoxelBoundingBox()
    assert 70 < hi[0] - lo[0] < 120  # two 10 m cubes (40 voxels each) and what straddles them
    values = {int(it.value) for it in ids.citerOnValues() if it.value >= 0}
    assert len({v // 8192 for v in values}) == 8  # every region of a cube tile shows
    prov = json.loads(s.metadata["rockvdb:params"])
    assert prov["aperiodic"] is True and prov["periods"] == [2, 1, 1]
    (tmp_path / "p.json").write_text(json.dumps(prov))
    again = tmp_path / "again.vdb"
    run([tool("vdb_blocks"), "-q", "--params", str(tmp_path / "p.json"), "-o", str(again)], check=True)
    assert_bitwise_equal(vdb.read(str(again), "block_id"), ids)
    one_line_error(run(common + ["--aperiodic", "--meshes", str(tmp_path / "m.obj"), "-o", str(tmp_path / "o.vdb")]),
                   2, "without aperiodic")
    assert not (tmp_path / "o.vdb").exists() and not (tmp_path / "m.obj").exists()


def write_png8_rgb(path, w, h):
    raw = b"".join(b"\x00" + b"".join(bytes([(x * 7) % 256, (y * 5) % 256, 9]) for x in range(w))
                   for y in range(h))

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def test_bad_input(tmp_path):
    out = tmp_path / "o.vdb"
    base = [tool("vdb_blocks"), *SMALL, "-o", str(out)]
    one_line_error(run(base + ["--type", "granite"]), 2, "type must be one of equidimensional")
    one_line_error(run([tool("vdb_blocks"), "--tile-size", "10", "--point-radius", "6", "-o",
                        str(out)]), 2, "point-radius must be in (0, tile-size / 2) (got 6)")
    one_line_error(run(base + ["--neighbour-radius", "0.3"]), 2, "neighbour-radius must be in (point-radius")
    one_line_error(run([tool("vdb_blocks"), "--tile-size", "10", "--voxel-size", "0.5", "-o",
                        str(out)]), 2, "too coarse")
    one_line_error(run(base + ["--disc-radius", "2,1"]), 2, "disc-radius (max)")
    one_line_error(run(base + ["--disc-radius", "-1,2"]), 2, "blocks: disc-radius must be in [0, 40000] (got -1.0)")
    bad = tmp_path / "f.json"
    bad.write_text('[{"center": [1, 2, 3], "normal": [0, 0, 1]}]')
    one_line_error(run(base + ["--fractures", str(bad)]), 2, "radius")
    bad.write_text('[{"center": [1, 2, 3], "normal": [0, 0, 1], "radius": }]')
    one_line_error(run(base + ["--fractures", str(bad)]), 2, "malformed")
    one_line_error(run(base + ["--warp-relief", str(tmp_path / "none.png")]), 1, "none.png")
    rgb = tmp_path / "rgb.png"
    write_png8_rgb(rgb, 8, 8)
    one_line_error(run(base + ["--warp-relief", str(rgb)]), 2, "rgb.png")
    one_line_error(run(base + ["--from-tile", str(bad)]), 1, "tile file", "f.json")  # a bad file: exit 1
    one_line_error(run(base + ["--tile", "/nonexistent/dir/t.tile"]), 1, "does not exist")
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.json", "rgb.png"]


def test_fill_grows_blocks_to_their_fractures(tmp_path):
    """--fill (the default): the same tile's blocks grown to their fractures hold much more
    rock than the hull-only reading (--no-fill); the tile file and provenance keep the mode
    and the width."""
    def solid(args, name):
        out = tmp_path / f"{name}.vdb"
        run([tool("vdb_blocks"), "-q", "--type", "polyhedral", "--tile-size", "8",
             "--point-radius", "0.4", "--voxel-size", "0.1", "--seed", "2", "-o", str(out),
             "--tile", str(tmp_path / f"{name}.tile")] + args, check=True)
        g = vdb.read(str(out), "surface")
        n = sum(it.count for it in g.citerAllValues() if it.value < 0)
        return n * 0.1 ** 3, g
    hull, _ = solid(["--no-fill"], "hull")
    grown, g = solid(["--fill", "--fracture-width", "0.03"], "fill")
    assert grown > 1.25 * hull, (grown, hull)
    params = json.loads(g["rockvdb:params"])
    assert params["fill"] is True and params["fracture-width"] == 0.03
    tile = json.loads((tmp_path / "fill.tile").read_text())
    assert tile["params"]["fill"] is True and tile["params"]["fracture-width"] == 0.03
