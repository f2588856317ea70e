# SPDX-License-Identifier: Apache-2.0
"""The flagship demo (samples/01_demo.sh) at draft quality: every method's part is in the one
file, where the scene puts it, with consistent id grids, visible in the preview, summarised."""
import os
import re
import shutil
import subprocess

import numpy as np
import pyopenvdb as vdb
import pytest

from conftest import BUILD, run

DEMO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "samples",
                    "01_demo.sh")
TERRAIN, EQUI, TABULAR, ROCKS, BOULDERS = 0.0, 1.0, 2.0, 3.0, 4.0
ARCH, ARCH_SAND, ARCH_ROCKS = 5.0, 6.0, 7.0  # the sea arch's bedrock, sand and rocks
ALL = (TERRAIN, EQUI, TABULAR, ROCKS, BOULDERS, ARCH, ARCH_SAND, ARCH_ROCKS)


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    p = run(["bash", DEMO, BUILD, str(out), "--quality", "draft"])
    assert p.returncode == 0, p.stderr
    return out, p.stderr


def test_one_file_with_every_part_and_consistent_ids(demo):
    out, _ = demo
    grids = {g.name: g for g in vdb.readAll(str(out / "demo.vdb"))[0]}
    assert set(grids) == {"surface", "material", "block_id", "rock_id"}
    s = grids["surface"]
    assert s.gridClass == vdb.GridClass.LEVEL_SET and s.transform.voxelSize()[0] == 0.25
    for g in grids.values():
        assert g.activeVoxelCount() == s.activeVoxelCount()
    mat, bid, rid = (grids[n].getConstAccessor() for n in ("material", "block_id", "rock_id"))
    where = {m: [] for m in ALL}
    for it in s.citerOnValues():
        if it.count != 1 or abs(it.value) > 0.25:
            continue  # voxels next to the surface only
        m, b, r = mat.getValue(it.min), bid.getValue(it.min), rid.getValue(it.min)
        assert m in where, m
        # Block ids exactly on block materials, rock ids exactly on rocks.
        assert (b >= 0) == (m in (EQUI, TABULAR)), (it.min, m, b)
        assert (r >= 0) == (m in (ROCKS, BOULDERS, ARCH_ROCKS)), (it.min, m, r)
        where[m].append([c * 0.25 for c in it.min])
    for m, pts in where.items():
        assert len(pts) > (100 if m in (BOULDERS, ARCH_SAND) else 500), (m, len(pts))
    p = {m: np.array(v) for m, v in where.items()}
    # Strata: tabular blocks above the equidimensional ones (boundary near 15 m, tilted).
    e = {m: p[m][:, 2] + 0.15 * p[m][:, 0] for m in (EQUI, TABULAR)}
    assert np.median(e[EQUI]) + 4 < np.median(e[TABULAR])
    # Blocks only on the cliff face (the coast at x = 36 +- 5 m, the face 9 m wide).
    for m in (EQUI, TABULAR):
        assert 24 < p[m][:, 0].min() and p[m][:, 0].max() < 48
    # The scree lies at the cliff foot, inside the wedge: 28 < x < 53, 9 < y < 53, low.
    r = p[ROCKS]
    assert 27 < r[:, 0].min() and r[:, 0].max() < 54 and 8 < r[:, 1].min() and r[:, 1].max() < 54
    assert r[:, 2].max() < 13 and np.median(r[:, 2]) < 6
    # The fractal boulders rest on the plateau (28 m; its edge ~31 m from the coast's waves).
    b = p[BOULDERS]
    assert b[:, 0].max() < 33 and 24 < b[:, 2].min() and b[:, 2].max() < 33
    # The sea arch stands on the sea floor beyond the scree (its wall 17 x 5 x 14 m around
    # (68, 33)); its collapsed top's rocks lie at its foot on the broken side, its sand on that
    # side too, no higher than the collapse (a sphere of 3.5 m at 11 m).
    a = p[ARCH]
    assert 58 < a[:, 0].min() and a[:, 0].max() < 78 and 22 < a[:, 1].min() and a[:, 1].max() < 44
    assert a[:, 2].min() < 1 and 10 < a[:, 2].max() < 14
    for m in (ARCH_SAND, ARCH_ROCKS):
        d = p[m]
        assert np.median(d[:, 0]) > 68 and np.median(d[:, 1]) > 33, m  # the broken corner's side
        assert d[:, 2].max() < 14.5, m
    assert np.median(p[ARCH_ROCKS][:, 2]) < 4  # fallen: mostly near the floor


def test_the_sea_arch_is_pierced_through(demo):
    """§4.2: the tunnel swept through the wall leaves an opening: along its axis the level set
    is air at every height under the arch's roof; beside it (through a pillar) and above (the
    roof) it is rock."""
    out, _ = demo
    acc = vdb.read(str(out / "demo.vdb"), "surface").getConstAccessor()

    def inside(p):
        return acc.getValue(tuple(int(round(c / 0.25)) for c in p)) < 0

    a, b = np.array([72.7, 29.3]), np.array([63.3, 36.7])  # the tunnel's nodes, across the wall
    along = np.array([0.62, 0.79]) * 6  # along the wall, into a pillar
    line = [a + (b - a) * t for t in np.linspace(0, 1, 41)]
    for z in (1.0, 3.0, 5.0):
        assert not any(inside((*q, z)) for q in line), z
    assert sum(inside((*q, 9.0)) for q in line) >= 10  # the roof
    assert sum(inside((*(q + along), 3.0)) for q in line) >= 10  # a pillar


def test_preview_shows_each_part_and_the_summary_reports_each_stage(demo):
    out, err = demo
    png = (out / "demo.png").read_bytes()
    assert png[:4] == b"\x89PNG" and int.from_bytes(png[16:20], "big") == 1280
    shown = re.search(r"by material: (.*) \(material ids\)", err)
    assert shown, err
    share = {float(a): float(b) for a, b in re.findall(r"(\d+) ([\d.]+)%", shown[1])}
    assert set(share) == set(ALL), share
    low = {BOULDERS: 0.2, ARCH_SAND: 0.05, ARCH_ROCKS: 0.1}
    assert all(v >= low.get(m, 0.8) for m, v in share.items()), share
    for stage in ("block tiles", "cliff (vdb_amplify | detail)", "rock tiles", "scree", "boulders",
                  "sea arch (vdb_arches | csg)", "preview", "total"):
        assert re.search(re.escape(stage) + r".*\d+\.\d s", err), (stage, err)
    assert re.search(r"demo\.vdb\s+[\d.]+ MB\s+surface \d+", err), err
    # A pipeline people copy: tools joined by pipes.
    assert len(re.findall(r"-o -\s*\|", open(DEMO).read())) >= 3


@pytest.mark.skipif(not shutil.which("vdb_tool"), reason="libopenvdb-tools not installed")
def test_vdb_tool_meshes_the_demo_with_its_defaults(demo, tmp_path):
    out, _ = demo
    p = subprocess.run(["vdb_tool", "-read", str(out / "demo.vdb"), "-ls2mesh", "-write",
                        str(tmp_path / "demo.obj")], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert (tmp_path / "demo.obj").stat().st_size > 1_000_000


def test_preview_quality_has_the_drafts_look(demo, tmp_path):
    """--quality preview (look-dev, issue 35): 30 cm voxels and the cliff without its detail
    step give the scene the draft gives: the same surface, the same blocks and materials at
    each surface point, the same material shares in the picture."""
    p = run(["bash", DEMO, BUILD, str(tmp_path), "--quality", "preview"])
    assert p.returncode == 0, p.stderr
    assert re.search(r"cliff \(vdb_amplify\)\s+\d+\.\d s", p.stderr), p.stderr
    draft_dir, draft_err = demo
    pv = {g.name: g for g in vdb.readAll(str(tmp_path / "demo.vdb"))[0]}
    dr = {g.name: g for g in vdb.readAll(str(draft_dir / "demo.vdb"))[0]}
    assert pv["surface"].transform.voxelSize()[0] == pytest.approx(0.3)
    d_surf, d_block, d_mat = (dr[n].getConstAccessor() for n in ("surface", "block_id", "material"))
    p_block, p_mat = pv["block_id"].getConstAccessor(), pv["material"].getConstAccessor()
    n = near = same_block = same_mat = 0
    for it in pv["surface"].citerOnValues():
        if it.count != 1 or abs(it.value) > 0.15:
            continue
        q = tuple(int(round(c * 0.3 / 0.25)) for c in it.min)  # the draft's nearest voxel
        n += 1
        near += abs(d_surf.getValue(q)) < 0.25
        same_block += p_block.getValue(it.min) == d_block.getValue(q)
        same_mat += p_mat.getValue(it.min) == d_mat.getValue(q)
    # Measured: 95 %, 95 %, 97 % of 242 k surface voxels.
    assert n > 100_000
    assert near / n > 0.9 and same_block / n > 0.9 and same_mat / n > 0.95, (n, near, same_block, same_mat)

    def shares(err):
        shown = re.search(r"by material: (.*) \(material ids\)", err)
        return {float(a): float(b) for a, b in re.findall(r"(\d+) ([\d.]+)%", shown[1])}

    a, b = shares(p.stderr), shares(draft_err)
    assert set(a) == set(b) == set(ALL)
    assert all(abs(a[m] - b[m]) <= 0.5 for m in ALL), (a, b)


def test_bad_quality_is_a_usage_error(tmp_path):
    p = run(["bash", DEMO, BUILD, str(tmp_path), "--quality", "ultra"])
    assert p.returncode == 2 and "draft, default or high" in p.stderr
    assert not (tmp_path / "demo.vdb").exists()
