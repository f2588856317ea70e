# SPDX-License-Identifier: Apache-2.0
"""The numbered Python samples (samples/py/NN_*.py), each run as a user runs it (a fresh
/usr/bin/python3, PYTHONPATH on the build, from the repository root), and what each wrote
checked: the grids a wrong stage would get wrong, and round trips through the CLI."""
import json
import os
import sys

import numpy as np
import pyopenvdb as vdb
import pytest

from conftest import BUILD, assert_bitwise_equal, run, tool

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
SAMPLES = os.path.join(ROOT, "samples", "py")


def sample(name, out):
    env = dict(os.environ, PYTHONPATH=os.path.join(BUILD, "python"))
    import subprocess
    p = subprocess.run(["/usr/bin/python3", os.path.join(SAMPLES, name), str(out)], cwd=ROOT,
                       env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return p.stdout


def grids(path):
    return {g.name: g for g in vdb.readAll(str(path))[0]}


def ids(grid):
    return {it.value for it in grid.citerOnValues()}


def test_every_sample_is_tested():
    names = sorted(f for f in os.listdir(SAMPLES) if f.endswith(".py"))
    assert names == ["01_block_tile.py", "02_fractal_boulders.py", "03_cliff.py",
                     "04_rock_pile.py", "05_arches_edits.py"]


def test_01_block_tile(tmp_path):
    said = sample("01_block_tile.py", tmp_path)
    g = grids(tmp_path / "py_blocks.vdb")
    s, b = g["surface"], g["block_id"]
    assert s.gridClass == vdb.GridClass.LEVEL_SET and s.activeVoxelCount() == b.activeVoxelCount()
    blocks = int(said.split()[0])
    assert blocks > 10 and ids(b) <= set(float(i) for i in range(blocks))
    lo, hi = s.evalActiveVoxelBoundingBox()
    # Two 10 m periods along x, one along y (whole blocks overhang each end alike).
    assert ((hi[0] - lo[0]) - (hi[1] - lo[1])) * 0.2 == pytest.approx(10, abs=1.5)
    # The saved tile bakes again through the CLI to the very same grids.
    run([tool("vdb_blocks"), "-q", "--from-tile", str(tmp_path / "py_blocks.tile"), "--voxel-size",
         "0.2", "--periods", "2,1,1", "-o", str(tmp_path / "cli.vdb")], check=True)
    assert_bitwise_equal(grids(tmp_path / "cli.vdb")["surface"], s)
    assert (tmp_path / "py_blocks.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_02_fractal_boulders(tmp_path):
    said = sample("02_fractal_boulders.py", tmp_path)
    rock = grids(tmp_path / "py_rock.vdb")["surface"]
    lo, hi = rock.evalActiveVoxelBoundingBox()
    ext = [(h - l) * 0.02 for l, h in zip(lo, hi)]
    assert ext[0] > ext[1] > ext[2] and ext[0] < 1.6  # the 1 x 0.8 x 0.5 rock, displaced
    g = grids(tmp_path / "py_boulders.vdb")
    placed = int(said.split()[0])
    assert placed >= 20 and ids(g["rock_id"]) == set(float(i) for i in range(placed))
    carved = grids(tmp_path / "py_carved.vdb")
    assert carved["cave"].activeVoxelCount() > 0
    # The cave chain starts at x = -3 inside the 8 m block: the carve leaves the block's
    # outer faces (|x| = 4) in place.
    c = carved["surface"].getConstAccessor()
    assert c.getValue((-40, 0, 0)) == pytest.approx(0, abs=0.15)


def test_03_cliff(tmp_path):
    sample("03_cliff.py", tmp_path)
    g = grids(tmp_path / "py_cliff.vdb")
    assert ids(g["material"]) == {0.0, 1.0}  # terrain and the one tile's blocks
    assert min(ids(g["block_id"])) == -1.0 and max(ids(g["block_id"])) >= 0
    prov = json.loads(g["surface"].metadata["rockvdb:params"])
    assert g["surface"].metadata["rockvdb:generator"] == "vdb_detail"
    assert prov["warp-amplitude"] == 0.1 and prov["gabor-frequency"] == 1


def test_04_rock_pile(tmp_path):
    said = sample("04_rock_pile.py", tmp_path)
    g = grids(tmp_path / "py_pile.vdb")
    placed = int(said.split()[0])
    assert placed > 50 and len(ids(g["rock_id"])) == placed
    lo, hi = g["surface"].evalActiveVoxelBoundingBox()
    vs = g["surface"].transform.voxelSize()[0]
    # Inside the dome (0 <= z <= 0.9 m), give or take the 3-voxel band.
    assert lo[2] * vs > -0.3 and hi[2] * vs < 1.2


def test_05_arches_edits_replay_through_the_cli(tmp_path):
    said = sample("05_arches_edits.py", tmp_path)
    assert said.splitlines()[0].startswith("sculpt ")
    g = grids(tmp_path / "py_arches.vdb")
    assert {"surface", "material", "sand", "bedrock", "rocks"} <= set(g)
    prov = json.loads(g["surface"].metadata["rockvdb:params"])
    assert [e["tool"] for e in prov["edits"]] == ["sculpt", "deposit", "erode", "crack", "tunnel"]
    (tmp_path / "p.json").write_text(json.dumps(prov))
    run([tool("vdb_arches"), "-q", "--params", str(tmp_path / "p.json"), "-o",
         str(tmp_path / "cli.vdb")], check=True)
    cli = grids(tmp_path / "cli.vdb")
    for name in ("surface", "material"):
        assert_bitwise_equal(cli[name], g[name])
