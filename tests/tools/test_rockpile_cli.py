# SPDX-License-Identifier: Apache-2.0
"""vdb_rockpile tiles (issue 6): a tile set file that real clients read, its stone count and
phases on stderr, periodic and aperiodic sets, determinism across threads, and bad input (one
line, exit 2, no file)."""
import json
import re

import numpy as np
import pyopenvdb as vdb
import pytest

from conftest import one_line_error, run, tool


def tiles(out, *args, threads=None, n=4):
    cmd = [tool("vdb_rockpile")]
    if threads:
        cmd += ["--threads", str(threads)]
    return run(cmd + ["tiles", "--n", str(n), "--voxels-per-cell", "5", *args, "-o", str(out)])


def read(path):
    g = vdb.read(str(path), "rho")
    return g, json.loads(g.metadata["rockvdb:tiles"])


def box_values(acc, lo, dims):
    return [acc.getValue(tuple(int(v) for v in lo + np.array([x, y, z])))
            for x in range(dims[0]) for y in range(dims[1]) for z in range(dims[2])]


def test_aperiodic_tile_set_file(tmp_path):
    out, lib = tmp_path / "rocks.tiles.vdb", tmp_path / "library.vdb"
    r = tiles(out, "--library", str(lib))
    assert r.returncode == 0, r.stderr
    g, meta = read(out)
    assert g.gridClass == vdb.GridClass.FOG_VOLUME
    # 2 vertex + 12 edge + 48 face + 256 centre regions; every seed a rock.
    assert len(meta["regions"]) == 318
    assert [sum(1 for x in meta["regions"] if x["type"] == t) for t in (3, 2, 1, 0)] == [2, 12, 48, 256]
    stones = meta["stats"]["stones"]
    assert stones == sum(1 for rock in meta["rocks"] if rock["solid"] > 0)
    assert re.search(r"\b%d stones" % stones, r.stderr)
    assert "voronoi + erosion" in r.stderr and "level sets" in r.stderr
    # Each rock's slot holds its solid voxels (rho > 1/2), as many as the description says,
    # and the library holds its level set (inside values) at the slot the metadata names.
    acc = g.getConstAccessor()
    library = vdb.read(str(lib), "library")
    assert library.gridClass == vdb.GridClass.LEVEL_SET
    slots = json.loads(library.metadata["rockvdb:library_offsets"])
    lacc = library.getConstAccessor()
    sample = list(range(0, len(meta["rocks"]), 97))
    for i in sample:
        rock = meta["rocks"][i]
        origin, dims = np.array(rock["origin"]), np.array(rock["dims"])
        rho = box_values(acc, origin + np.array(rock["offset"]), dims)
        assert sum(v > 0.5 for v in rho) == rock["solid"]
        phi = box_values(lacc, origin + np.array(slots[i]), dims)
        assert min(phi) < 0 and max(phi) > 0
    assert len(slots) == len(meta["rocks"])


def test_periodic_tile_set(tmp_path):
    out = tmp_path / "p.tiles.vdb"
    r = tiles(out, "--tiling", "periodic", n=3)
    assert r.returncode == 0, r.stderr
    _, meta = read(out)
    assert len(meta["regions"]) == 1 and meta["params"]["tiling"] == "periodic"
    assert meta["stats"]["stones"] > 10


def test_tile_sets_are_deterministic_across_threads(tmp_path):
    a, b = tmp_path / "a.tiles.vdb", tmp_path / "b.tiles.vdb"
    assert tiles(a, threads=1).returncode == 0
    assert tiles(b, threads=2).returncode == 0
    ga, ma = read(a)
    gb, mb = read(b)
    assert ma["rocks"] == mb["rocks"] and ma["regions"] == mb["regions"]
    lo, hi = ga.evalActiveVoxelBoundingBox()
    shape = tuple(np.array(hi) - np.array(lo) + 1)
    x, y = np.zeros(shape, np.float32), np.zeros(shape, np.float32)
    ga.copyToArray(x, ijk=lo)
    gb.copyToArray(y, ijk=lo)
    assert np.array_equal(x, y)


@pytest.mark.parametrize("args,needle", [
    (["--n", "3"], "rockpile: n must be >= 4 for aperiodic corner cubes"),
    (["--n", "1"], "rockpile: n must be in [3, 64] (got 1)"),
    (["--n", "five"], 'rockpile: n must be an integer (got "five")'),
    (["--seeds-per-cell", "0,2"], "rockpile: seeds-per-cell must be in [1, 64] (got 0)"),
    (["--contact-radii", "0.5,0.2"], "a < b"),
    (["--g-max", "0.5"], "rockpile: g-max must be in [1, 16] (got 0.5)"),
    (["--tiling", "hexagonal"], "rockpile: tiling must be one of aperiodic, periodic (got 'hexagonal')"),
])
def test_bad_parameters(tmp_path, args, needle):
    out = tmp_path / "o.tiles.vdb"
    one_line_error(run([tool("vdb_rockpile"), "tiles", *args, "-o", str(out)]), 2, needle)
    assert not out.exists()


# ---- piles (§6) ----------------------------------------------------------------------------

CUBE_OBJ = """v -0.87 -0.87 -0.87
v 0.87 -0.87 -0.87
v 0.87 0.87 -0.87
v -0.87 0.87 -0.87
v -0.87 -0.87 0.87
v 0.87 -0.87 0.87
v 0.87 0.87 0.87
v -0.87 0.87 0.87
f 1 4 3 2
f 5 6 7 8
f 1 2 6 5
f 2 3 7 6
f 3 4 8 7
f 4 1 5 8
"""


@pytest.fixture(scope="module")
def tile_set(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiles") / "rocks.tiles.vdb"
    r = tiles(out)
    assert r.returncode == 0, r.stderr
    return out


def pile(tiles_path, support, out, *args):
    return run([tool("vdb_rockpile"), "pile", "--tiles", str(tiles_path), "--support", str(support),
                *args, "-o", str(out)])


def test_pile_in_a_closed_mesh(tmp_path, tile_set):
    mesh = tmp_path / "cube.obj"
    mesh.write_text(CUBE_OBJ)
    out, pts = tmp_path / "pile.vdb", tmp_path / "points.vdb"
    r = pile(tile_set, mesh, out, "--points", str(pts))
    assert r.returncode == 0, r.stderr
    placed = int(re.search(r"placed (\d+) rocks", r.stderr).group(1))
    assert placed > 50
    grids = vdb.readAll(str(out))[0]
    surface = next(g for g in grids if g.name == "surface")
    ids = next(g for g in grids if g.name == "rock_id")
    assert surface.gridClass == vdb.GridClass.LEVEL_SET
    # Rock ids are instance indices 0..placed-1, all present.
    seen = {int(it.value) for it in ids.citerOnValues()}
    assert seen == set(range(placed))
    # The rocks' inside voxels lie mostly inside the support (faces off the voxel centres).
    dx = surface.transform.voxelSize()[0]
    inside = np.array([it.min for it in surface.citerOnValues() if it.value < 0]) * dx
    assert np.mean(np.all(np.abs(inside) < 0.87, axis=1)) > 0.9
    # The instances as a VDB points grid, read by OpenVDB's own vdb_print.
    printed = run(["vdb_print", str(pts)])
    assert printed.returncode == 0 and "rocks" in str(printed.stdout) + str(printed.stderr)


def test_pile_supports_agree(tmp_path, tile_set):
    """The same cube as a mesh (OBJ, ASCII STL) and as an expression places nearly the same rocks."""
    obj = tmp_path / "cube.obj"
    obj.write_text(CUBE_OBJ)
    verts = [tuple(map(float, l.split()[1:])) for l in CUBE_OBJ.splitlines() if l.startswith("v ")]
    faces = [[int(i) - 1 for i in l.split()[1:]] for l in CUBE_OBJ.splitlines() if l.startswith("f ")]
    stl = tmp_path / "cube.stl"
    lines = ["solid cube"]
    for f in faces:
        for tri in ((f[0], f[1], f[2]), (f[0], f[2], f[3])):
            lines += ["facet normal 0 0 0", "outer loop"]
            lines += ["vertex %g %g %g" % verts[i] for i in tri]
            lines += ["endloop", "endfacet"]
    lines.append("endsolid cube")
    stl.write_text("\n".join(lines))
    expr = tmp_path / "cube.json"
    expr.write_text(json.dumps({"type": "box", "center": [0, 0, 0], "size": [1.74, 1.74, 1.74]}))
    counts = []
    for support in (obj, stl, expr):
        r = pile(tile_set, support, tmp_path / (support.suffix[1:] + ".vdb"))
        assert r.returncode == 0, r.stderr
        counts.append(int(re.search(r"placed (\d+) rocks", r.stderr).group(1)))
    assert max(counts) - min(counts) <= 0.05 * max(counts), counts


@pytest.mark.parametrize("case,code,needle", [
    ("open", 2, "not closed"),
    ("missing_tiles", 1, "none.tiles.vdb"),
    ("extension", 2, "support must be a .vdb"),
    ("threshold", 2, "threshold must be in (0, 1]"),
])
def test_pile_bad_input(tmp_path, tile_set, case, code, needle):
    mesh = tmp_path / "cube.obj"
    mesh.write_text(CUBE_OBJ if case != "open" else CUBE_OBJ.rsplit("f ", 1)[0])
    out = tmp_path / "o.vdb"
    args, tiles_path, support = [], tile_set, mesh
    if case == "missing_tiles":
        tiles_path = tmp_path / "none.tiles.vdb"
    if case == "extension":
        support = tmp_path / "cube.txt"
        support.write_text("x")
    if case == "threshold":
        args = ["--threshold", "0"]
    one_line_error(pile(tiles_path, support, out, *args), code, needle)
    assert not out.exists()


def test_sample_06_periodic_bed_repeats_and_aperiodic_does_not(tmp_path):
    """samples/06_riverbed.sh: the same pebbles from a periodic tile and from corner cubes in
    one river bed. Read back with pyopenvdb, the bed's top surface (highest inside voxel per
    column) correlates with itself one tile period (1.2 m = 50 voxels) along x when periodic,
    and not when aperiodic."""
    import os
    from conftest import BUILD
    sample = os.path.join(os.path.dirname(__file__), "..", "..", "samples", "06_riverbed.sh")
    p = run(["bash", sample, BUILD, str(tmp_path)])
    assert p.returncode == 0, p.stderr
    corr = {}
    for t in ("periodic", "aperiodic"):
        assert (tmp_path / f"riverbed_{t}.png").stat().st_size > 10000
        g = vdb.read(str(tmp_path / f"riverbed_{t}.vdb"), "surface")
        assert g.gridClass == vdb.GridClass.LEVEL_SET
        lo, hi = g.evalActiveVoxelBoundingBox()
        a = np.zeros(tuple(h - l + 1 for l, h in zip(lo, hi)), dtype=np.float32)
        g.copyToArray(a, ijk=lo)
        inside = a < 0
        top = np.where(inside.any(axis=2), inside.shape[2] - 1 - np.argmax(inside[:, :, ::-1], axis=2), -1)
        # Columns well inside the bed (10 voxels off its sides), compared 50 voxels apart.
        h0, h1 = top[10:-60, 10:-10].astype(float), top[60:-10, 10:-10].astype(float)
        both = (h0 >= 0) & (h1 >= 0)
        assert both.sum() > 10000
        corr[t] = np.corrcoef(h0[both], h1[both])[0, 1]
    assert corr["periodic"] > 0.9, corr
    assert corr["aperiodic"] < 0.5, corr
