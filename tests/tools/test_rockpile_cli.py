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
    out, lib = tmp_path / "rocks.tiles", tmp_path / "library.vdb"
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
    out = tmp_path / "p.tiles"
    r = tiles(out, "--tiling", "periodic", n=3)
    assert r.returncode == 0, r.stderr
    _, meta = read(out)
    assert len(meta["regions"]) == 1 and meta["params"]["tiling"] == "periodic"
    assert meta["stats"]["stones"] > 10


def test_tile_sets_are_deterministic_across_threads(tmp_path):
    a, b = tmp_path / "a.tiles", tmp_path / "b.tiles"
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
    (["--n", "3"], "n (cells per cube edge)"),
    (["--n", "1"], "n (cells per cube edge)"),
    (["--seeds-per-cell", "0,2"], "seeds per cell"),
    (["--contact-radii", "0.5,0.2"], "a < b"),
    (["--g-max", "0.5"], "g_max"),
    (["--tiling", "hexagonal"], "tiling"),
])
def test_bad_parameters(tmp_path, args, needle):
    out = tmp_path / "o.tiles"
    one_line_error(run([tool("vdb_rockpile"), "tiles", *args, "-o", str(out)]), 2, needle)
    assert not out.exists()
