# SPDX-License-Identifier: Apache-2.0
"""What a new user trips on in the first hour (issue 13): quiet means quiet, level-set supports
from any tool, a Gabor amplitude alone, provenance of what was used, vdb_tool's defaults, CSG
that carries id grids, samples that keep their own outputs, y-up meshes from Blender."""
import json
import os
import re
import shutil
import subprocess

import numpy as np
import pyopenvdb as vdb
import pytest

from conftest import dense, run, tool

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLES = os.path.join(HERE, "..", "..", "samples")


@pytest.fixture(scope="module")
def rocks(tmp_path_factory):
    d = tmp_path_factory.mktemp("rocks")
    run([tool("vdb_rockpile"), "-q", "tiles", "--n", "4", "--voxels-per-cell", "4",
         "-o", str(d / "rocks.tiles.vdb")], check=True)
    return d / "rocks.tiles.vdb"


def test_quiet_prints_nothing_on_success(tmp_path, rocks, heightfield_png):
    s = tmp_path / "s.vdb"
    runs = [
        ["vdb_primitive", "-q", "--voxel-size", "0.1", "-o", str(s), "sphere", "--radius", "1"],
        ["vdb_blocks", "-q", "--type", "tabular", "--tile-size", "6", "--point-radius", "0.4",
         "--voxel-size", "0.1", "-o", str(tmp_path / "b.vdb"), "--tile", str(tmp_path / "b.tile")],
        ["vdb_heightfield", "-q", str(heightfield_png), "--cell-size", "0.1", "--voxel-size",
         "0.05", "-o", str(tmp_path / "h.vdb")],
        ["vdb_csg", "-q", "union", str(s), str(s), "-o", str(tmp_path / "c.vdb")],
        ["vdb_mesh", "-q", str(s), "-o", str(tmp_path / "s.obj")],
        ["vdb_preview", "-q", str(s), "--width", "32", "--height", "24", "-o",
         str(tmp_path / "s.png")],
        ["vdb_detail", "-q", str(s), "--warp-amplitude", "0.05", "-o", str(tmp_path / "d.vdb")],
        ["vdb_amplify", "-q", "--terrain", str(heightfield_png), "--cell-size", "0.25",
         "--height-scale", "6", "--tiles", str(tmp_path / "b.tile"), "--voxel-size", "0.1",
         "-o", str(tmp_path / "a.vdb")],
        ["vdb_rockpile", "-q", "pile", "--tiles", str(rocks), "--support", str(s),
         "-o", str(tmp_path / "p.vdb")],
        ["vdb_merge", "-q", str(tmp_path / "a.vdb"), "-o", str(tmp_path / "m.vdb")],
    ]
    for args in runs:
        p = run([tool(args[0])] + args[1:])
        assert p.returncode == 0, (args[0], p.stderr)
        assert p.stderr == "", (args[0], p.stderr)


def test_pile_support_from_vdb_primitive_and_named_grids(tmp_path, rocks):
    ball = tmp_path / "sphere.vdb"
    run([tool("vdb_primitive"), "-q", "--voxel-size", "0.05", "-o", str(ball), "sphere",
         "--radius", "0.8"], check=True)
    out = tmp_path / "pile.vdb"
    p = run([tool("vdb_rockpile"), "pile", "--tiles", str(rocks), "--support", str(ball),
             "--material", "3", "-o", str(out)])
    assert p.returncode == 0, p.stderr
    g = {x.name: x for x in vdb.readAll(str(out))[0]}
    assert set(g) == {"surface", "rock_id", "material"}
    assert {it.value for it in g["material"].citerOnValues()} == {3.0}
    assert g["material"].activeVoxelCount() == g["rock_id"].activeVoxelCount() > 1000
    # A file whose only level set is not 'surface' works too; --support-grid names one.
    blob = vdb.createLevelSetSphere(0.8, voxelSize=0.05)
    blob.name = "blob"
    vdb.write(str(tmp_path / "blob.vdb"), [blob])
    p2 = run([tool("vdb_rockpile"), "-q", "pile", "--tiles", str(rocks), "--support",
              str(tmp_path / "blob.vdb"), "-o", str(tmp_path / "p2.vdb")])
    assert p2.returncode == 0, p2.stderr
    p3 = run([tool("vdb_rockpile"), "-q", "pile", "--tiles", str(rocks), "--support",
              str(tmp_path / "blob.vdb"), "--support-grid", "nope", "-o", str(tmp_path / "p3.vdb")])
    assert p3.returncode != 0 and "no grid 'nope'" in p3.stderr and "'blob'" in p3.stderr


def test_gabor_amplitude_alone_uses_the_stated_default_frequency(tmp_path, sphere_vdb):
    h = run([tool("vdb_detail"), "--help"]).stdout.decode()
    assert re.search(r"0 = 1/\(10 x\s+amplitude\)", h), h
    assert re.search(r"--voxel-size.*default: the input's", h), h
    a = tmp_path / "a.vdb"
    p = run([tool("vdb_detail"), "-q", str(sphere_vdb), "--gabor-amplitude", "0.05",
             "--direction-axis", "0,0,1", "-o", str(a)])
    assert p.returncode == 0, p.stderr
    # The same as asking for F0 = 1/(10 * 0.05) = 2 cycles/m explicitly.
    b = tmp_path / "b.vdb"
    run([tool("vdb_detail"), "-q", str(sphere_vdb), "--gabor-amplitude", "0.05",
         "--gabor-frequency", "2", "--direction-axis", "0,0,1", "-o", str(b)], check=True)
    ga, gb = vdb.read(str(a), "surface"), vdb.read(str(b), "surface")
    (la, da), (lb, db) = dense(ga), dense(gb)
    assert la == lb and np.array_equal(da, db)
    # Provenance records the voxel size and band that were used (the input's), not the
    # 0.05 that --voxel-size would default to elsewhere.
    run([tool("vdb_primitive"), "-q", "--voxel-size", "0.04", "-o", str(tmp_path / "s04.vdb"),
         "sphere", "--radius", "1"], check=True)
    run([tool("vdb_detail"), "-q", str(tmp_path / "s04.vdb"), "--warp-amplitude", "0.03",
         "-o", str(tmp_path / "d04.vdb")], check=True)
    d = vdb.read(str(tmp_path / "d04.vdb"), "surface")
    params = json.loads(d["rockvdb:params"])
    assert params["voxel-size"] == pytest.approx(0.04) == d.transform.voxelSize()[0]
    assert params["half-width"] == pytest.approx(3.0)


@pytest.mark.skipif(not shutil.which("vdb_tool"), reason="libopenvdb-tools not installed")
def test_vdb_tool_default_actions_mesh_files_with_id_grids(tmp_path, rocks):
    """vdb_tool acts on the most recently read grid (age 0): the level set is written last."""
    b = tmp_path / "b.vdb"
    run([tool("vdb_blocks"), "-q", "--type", "tabular", "--tile-size", "6", "--point-radius",
         "0.4", "--voxel-size", "0.1", "-o", str(b)], check=True)
    pile = tmp_path / "p.vdb"
    (tmp_path / "ball.json").write_text(json.dumps({"type": "sphere", "radius": 0.8}))
    run([tool("vdb_rockpile"), "-q", "pile", "--tiles", str(rocks), "--support",
         str(tmp_path / "ball.json"), "--material", "1", "-o", str(pile)], check=True)
    c = tmp_path / "c.vdb"
    run([tool("vdb_csg"), "-q", "union", str(b), str(pile), "-o", str(c)], check=True)
    for f in (b, pile, c):
        obj = tmp_path / (f.stem + ".obj")
        p = subprocess.run(["vdb_tool", "-read", str(f), "-ls2mesh", "-write", str(obj)],
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0 and "Fatal" not in p.stderr, (f, p.stderr)
        verts = sum(1 for l in obj.read_text().splitlines() if l.startswith("v "))
        s = vdb.read(str(f), "surface")
        ours = tmp_path / (f.stem + "_ours.obj")
        run([tool("vdb_mesh"), "-q", str(f), "-o", str(ours)], check=True)
        mine = sum(1 for l in ours.read_text().splitlines() if l.startswith("v "))
        assert verts > 1000 and abs(verts - mine) <= 0.02 * mine, (f, verts, mine)
        assert s.gridClass == vdb.GridClass.LEVEL_SET


def test_csg_carries_id_grids_from_the_input_the_surface_follows(tmp_path):
    """Two spheres tagged 1 and 2 (block_id), the second also with rock_id 7: each voxel of
    the union takes the id of the sphere it is nearer the surface of; a difference keeps the
    first input's ids."""
    def ball(name, cx, ids):
        e = {"type": "sphere", "center": [cx, 0, 0], "radius": 1.0, "id": ids}
        (tmp_path / f"{name}.json").write_text(json.dumps(e))
        run([tool("vdb_primitive"), "-q", "--voxel-size", "0.05", "-o", str(tmp_path / f"{name}.vdb"),
             "expr", str(tmp_path / f"{name}.json"), "--attribute", "block_id"], check=True)
    ball("a", -0.6, 1)
    ball("b", 0.6, 2)
    # b also carries a rock_id grid (7 everywhere on its band).
    gb = {g.name: g for g in vdb.readAll(str(tmp_path / "b.vdb"))[0]}
    rid = gb["block_id"].deepCopy()
    rid.name = "rock_id"
    rid.mapOn(lambda v: 7.0)
    vdb.write(str(tmp_path / "b2.vdb"), [gb["surface"], gb["block_id"], rid])
    u = tmp_path / "u.vdb"
    run([tool("vdb_csg"), "-q", "union", str(tmp_path / "a.vdb"), str(tmp_path / "b2.vdb"),
         "-o", str(u)], check=True)
    g = {x.name: x for x in vdb.readAll(str(u))[0]}
    assert set(g) == {"surface", "block_id", "rock_id"}
    assert g["block_id"].activeVoxelCount() == g["surface"].activeVoxelCount()
    acc, racc = g["block_id"].getConstAccessor(), g["rock_id"].getConstAccessor()
    dx, checked = 0.05, 0
    for it in g["surface"].citerOnValues():
        if it.count != 1:
            continue
        x, y, z = (c * dx for c in it.min)
        da = np.sqrt((x + 0.6) ** 2 + y * y + z * z) - 1
        db = np.sqrt((x - 0.6) ** 2 + y * y + z * z) - 1
        if abs(da - db) < 0.02:
            continue  # the seam, where both are within rounding
        want = 1.0 if da < db else 2.0
        assert acc.getValue(it.min) == want, (it.min, da, db)
        assert racc.getValue(it.min) == (7.0 if want == 2.0 else -1.0)
        checked += 1
    assert checked > 5000
    d = tmp_path / "d.vdb"
    run([tool("vdb_csg"), "-q", "difference", str(tmp_path / "a.vdb"), str(tmp_path / "b2.vdb"),
         "-o", str(d)], check=True)
    gd = {x.name: x for x in vdb.readAll(str(d))[0]}
    assert {it.value for it in gd["block_id"].citerOnValues()} <= {1.0, -1.0}
    assert {it.value for it in gd["rock_id"].citerOnValues()} == {-1.0}
    n = tmp_path / "n.vdb"
    run([tool("vdb_csg"), "-q", "union", "--no-ids", str(tmp_path / "a.vdb"),
         str(tmp_path / "b2.vdb"), "-o", str(n)], check=True)
    assert [x.name for x in vdb.readAll(str(n))[0]] == ["surface"]


def test_samples_write_their_own_outputs():
    """No two samples write the same file name into a shared OUT_DIR."""
    owners = {}
    for name in sorted(os.listdir(SAMPLES)):
        if not name.endswith(".sh"):
            continue
        text = open(os.path.join(SAMPLES, name)).read()
        for out in set(re.findall(r'\$OUT/([\w.\-]+)', text)):
            assert out not in owners, f"{out}: written by {owners.get(out)} and {name}"
            owners[out] = name
    assert len(owners) > 10


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_pile_support_exported_from_blender_with_its_default_obj_axes(tmp_path, rocks):
    """Blender exports a box standing 2..3.2 m above its ground with the OBJ exporter's defaults
    (y up); with --up y the pile stands where the box stood, with the default (z) it lies on
    its side. vdb_mesh --up y writes what Blender's importer puts back in place."""
    script = tmp_path / "export.py"
    script.write_text(
        "import bpy, sys\n"
        "bpy.ops.object.select_all(action='SELECT'); bpy.ops.object.delete()\n"
        "bpy.ops.mesh.primitive_cube_add(size=1, location=(0.2, -0.4, 2.6))\n"
        "bpy.context.active_object.scale = (1.0, 1.2, 1.2)\n"
        "bpy.ops.object.transform_apply(scale=True)\n"
        f"bpy.ops.wm.obj_export(filepath=r'{tmp_path / 'box.obj'}', export_materials=False)\n")
    p = subprocess.run(["blender", "-b", "--factory-startup", "--python", str(script)],
                       capture_output=True, text=True, timeout=300)
    assert (tmp_path / "box.obj").exists(), p.stdout[-2000:] + p.stderr[-2000:]
    stats = {}
    for up in ("y", "z"):
        out = tmp_path / f"pile_{up}.vdb"
        args = [tool("vdb_rockpile"), "-q", "pile", "--tiles", str(rocks), "--support",
                str(tmp_path / "box.obj"), "--up", up, "-o", str(out)]
        run(args, check=True)
        s = vdb.read(str(out), "surface")
        lo, hi = s.evalActiveVoxelBoundingBox()
        dx = s.transform.voxelSize()[0]
        stats[up] = [(lo[a] * dx, hi[a] * dx) for a in range(3)]
    # The box spans x -0.3..0.7, y -1.0..0.2, z 2.0..3.2: the pile is centred on it (rocks
    # reach up to a rock radius, ~0.35 m here, past its faces).
    for a, (lo, hi) in enumerate([(-0.3, 0.7), (-1.0, 0.2), (2.0, 3.2)]):
        got = stats["y"][a]
        assert abs((got[0] + got[1]) / 2 - (lo + hi) / 2) < 0.15, (a, stats)
        assert lo - 0.45 < got[0] < lo + 0.1 and hi - 0.1 < got[1] < hi + 0.45, (a, stats)
    # Read as z up, the file's y (Blender's z) is our y: the box lies on its side.
    assert sum(stats["z"][1]) / 2 > 2.3 and sum(stats["z"][2]) / 2 < 1.0, stats
    # vdb_mesh --up y round trip: Blender imports it where our level set is.
    ball = tmp_path / "ball.vdb"
    run([tool("vdb_primitive"), "-q", "--voxel-size", "0.05", "-o", str(ball), "box",
         "--size", "1,2,0.5", "--center", "0.5,1,3"], check=True)
    run([tool("vdb_mesh"), "-q", str(ball), "--up", "y", "-o", str(tmp_path / "m.obj")],
        check=True)
    imp = tmp_path / "import.py"
    imp.write_text(
        "import bpy, json\n"
        "bpy.ops.object.select_all(action='SELECT'); bpy.ops.object.delete()\n"
        f"bpy.ops.wm.obj_import(filepath=r'{tmp_path / 'm.obj'}')\n"
        "o = bpy.context.selected_objects[0]\n"
        "co = [o.matrix_world @ v.co for v in o.data.vertices]\n"
        f"json.dump([[min(c[a] for c in co) for a in range(3)], [max(c[a] for c in co) for a in range(3)]], open(r'{tmp_path / 'b.json'}', 'w'))\n")
    p = subprocess.run(["blender", "-b", "--factory-startup", "--python", str(imp)],
                       capture_output=True, text=True, timeout=300)
    lo, hi = json.loads((tmp_path / "b.json").read_text())
    for a, (want_lo, want_hi) in enumerate([(0, 1), (0, 2), (2.75, 3.25)]):
        assert abs(lo[a] - want_lo) < 0.06 and abs(hi[a] - want_hi) < 0.06, (lo, hi)
