# SPDX-License-Identifier: Apache-2.0
"""rockvdb.rock_tiles / rock_library / rock_pile (issue 6): the same tile sets and piles as
vdb_rockpile, supports given as Fields, grids or paths, and bad input as Python errors."""
import json

import numpy as np
import pyopenvdb as vdb
import pytest

import rockvdb
from conftest import run, tool


def dense(grid):
    lo, hi = grid.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(np.array(hi) - np.array(lo) + 1), np.float32)
    grid.copyToArray(a, ijk=lo)
    return lo, a


@pytest.fixture(scope="module")
def tiles():
    return rockvdb.rock_tiles(n=4, voxels_per_cell=5, seed=3)


def test_python_tiles_equal_the_cli(tmp_path, tiles):
    out = tmp_path / "cli.tiles.vdb"
    r = run([tool("vdb_rockpile"), "tiles", "--n", "4", "--voxels-per-cell", "5", "--seed", "3",
             "-o", str(out)])
    assert r.returncode == 0, r.stderr
    cli = vdb.read(str(out), "rho")
    # Through a file both ways (the tile set is saved as half floats).
    rockvdb.rock_tiles(n=4, voxels_per_cell=5, seed=3, path=tmp_path / "py.tiles.vdb")
    tiles = vdb.read(str(tmp_path / "py.tiles.vdb"), "rho")
    a, b = json.loads(tiles.metadata["rockvdb:tiles"]), json.loads(cli.metadata["rockvdb:tiles"])
    assert a["rocks"] == b["rocks"] and a["params"] == b["params"]
    la, da = dense(tiles)
    lb, db = dense(cli)
    assert la == lb and np.array_equal(da, db)


def test_pile_from_field_grid_and_path_agree(tmp_path, tiles):
    expr = {"type": "sphere", "center": [0.1, 0, 0], "radius": 0.83}
    path = tmp_path / "ball.json"
    path.write_text(json.dumps(expr))
    stats = {}
    s1, ids1 = rockvdb.rock_pile(tiles, rockvdb.expression(json.dumps(expr)), stats=stats)
    s2, ids2 = rockvdb.rock_pile(tiles, path)
    assert stats["placed"] > 20 and len(stats["rocks"]) == stats["placed"]
    assert np.array_equal(dense(s1)[1], dense(s2)[1])
    assert np.array_equal(dense(ids1)[1], dense(ids2)[1])
    # A level-set support (the ball baked) places nearly the same rocks.
    ball = rockvdb.sphere(0.83, (0.1, 0, 0)).bake(voxel_size=0.02)
    stats3 = {}
    rockvdb.rock_pile(tiles, ball, stats=stats3)
    assert abs(stats3["placed"] - stats["placed"]) <= 0.05 * stats["placed"]
    # The library holds every rock: as many slots as rocks.
    lib = rockvdb.rock_library(tiles)
    assert lib.gridClass == vdb.GridClass.LEVEL_SET
    assert len(json.loads(lib.metadata["rockvdb:library_offsets"])) == \
        len(json.loads(tiles.metadata["rockvdb:tiles"])["rocks"])


def test_bad_input(tiles):
    with pytest.raises(TypeError):
        rockvdb.rock_pile(tiles, None)
    with pytest.raises(TypeError):
        rockvdb.rock_pile(None, rockvdb.sphere(1.0))
    with pytest.raises(ValueError, match="support must be"):
        rockvdb.rock_pile(tiles, "ball.txt")
    with pytest.raises(ValueError, match=r"n must be in \[3, 64\] \(got 1\)"):
        rockvdb.rock_tiles(n=1)
    with pytest.raises(ValueError, match="a < b"):
        rockvdb.rock_tiles(contact_radii=(0.4, 0.1))
    with pytest.raises(ValueError, match=r"threshold must be in \(0, 1\]"):
        rockvdb.rock_pile(tiles, rockvdb.sphere(1.0), threshold=1.5)
    fog = vdb.FloatGrid()
    with pytest.raises(ValueError, match="no tile set"):
        rockvdb.rock_pile(fog, rockvdb.sphere(1.0))
