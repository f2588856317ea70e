# SPDX-License-Identifier: Apache-2.0
"""Real consumers read what we write: pyopenvdb, Debian's vdb_print / vdb_render, Blender."""
import json
import math
import os
import re
import shutil
import subprocess

import pytest

from conftest import run, tool

HERE = os.path.dirname(os.path.abspath(__file__))


def blender_json(script, args, report):
    """Run tests/clients/@a script in headless Blender with @a args after '--'; the JSON it
    wrote to @a report (one of the args)."""
    p = subprocess.run(["blender", "--background", "--factory-startup", "--python",
                        os.path.join(HERE, script), "--", *map(str, args)],
                       capture_output=True, text=True, timeout=600)
    assert report.exists(), p.stdout[-2000:] + p.stderr[-2000:]
    return json.loads(report.read_text())


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """A small scene with a block_id grid (the demo's structure, smaller voxels budget)."""
    d = tmp_path_factory.mktemp("scene")
    expr = d / "scene.json"
    expr.write_text(json.dumps({"type": "union", "smooth": 0.2, "children": [
        {"type": "box", "id": 1, "size": [4, 4, 0.6], "center": [0, 0, -0.3], "rounding": 0.1},
        {"type": "warp", "id": 2, "amplitude": 0.08, "frequency": 1.5, "seed": 2,
         "child": {"type": "sphere", "center": [0.5, 0.2, 0.3], "radius": 0.7}}]}))
    out = d / "scene.vdb"
    run([tool("vdb_primitive"), "-q", "--voxel-size", "0.05", "-o", str(out), "expr", str(expr),
         "--attribute", "block_id"], check=True)
    return out


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    """A small fractured block tile from vdb_blocks (surface + block_id + tile metadata)."""
    out = tmp_path_factory.mktemp("blocks") / "tile.vdb"
    run([tool("vdb_blocks"), "-q", "--type", "rhombohedral", "--tile-size", "6",
         "--point-radius", "0.35", "--voxel-size", "0.05", "--seed", "5", "-o", str(out)],
        check=True)
    return out


@pytest.fixture(scope="module")
def amplified(tmp_path_factory, blocks):
    """vdb_amplify on a ramp heightfield steep enough to qualify (surface, block_id, material)."""
    from conftest import write_png16
    d = tmp_path_factory.mktemp("amplified")
    png = d / "ramp.png"
    write_png16(png, [[round(65535 * min(1.0, max(0.0, (i - 10) / 12))) for i in range(33)]
                      for _ in range(33)])
    out = d / "amp.vdb"
    run([tool("vdb_amplify"), "-q", "--terrain", str(png), "--cell-size", "0.25",
         "--height-scale", "6", "--tiles", str(blocks), "--voxel-size", "0.05",
         "--distance-range=-0.5,0.5", "-o", str(out)], check=True)
    return out


@pytest.fixture(scope="module")
def detailed(tmp_path_factory, blocks):
    """vdb_detail on the block tile: warp and Gabor details with curvature frames."""
    out = tmp_path_factory.mktemp("detailed") / "detail.vdb"
    run([tool("vdb_detail"), "-q", str(blocks), "--warp-amplitude", "0.03",
         "--gabor-amplitude", "0.03", "--gabor-frequency", "4", "--direction-curvature",
         "-o", str(out)], check=True)
    return out


@pytest.fixture(scope="module")
def piled(tmp_path_factory):
    """vdb_rockpile: a corner-cube tile set (5 cm voxels) piled into a ball."""
    d = tmp_path_factory.mktemp("piled")
    run([tool("vdb_rockpile"), "-q", "tiles", "--n", "4", "--voxels-per-cell", "5",
         "-o", str(d / "rocks.tiles.vdb")], check=True)
    (d / "ball.json").write_text(json.dumps({"type": "sphere", "center": [0.2, 0, 0],
                                             "radius": 1.1}))
    out = d / "pile.vdb"
    run([tool("vdb_rockpile"), "-q", "pile", "--tiles", str(d / "rocks.tiles.vdb"), "--support",
         str(d / "ball.json"), "-o", str(out)], check=True)
    return out


@pytest.fixture(scope="module")
def fractal(tmp_path_factory):
    """vdb_fractal_rock: one rock (level set, y-up OBJ, normal map) and a scatter."""
    d = tmp_path_factory.mktemp("fractal")
    run([tool("vdb_fractal_rock"), "-q", "--levels", "2", "--seed", "5", "--voxel-size", "0.05",
         "--size", "3,2.4,1.5", "-o", str(d / "rock.vdb"), "--mesh", str(d / "rock.obj"),
         "--mesh-up", "y", "--normal-map", str(d / "rock_n.exr"), "--normal-map-size", "32"],
        check=True)
    # The same rock's tangent-space map.
    run([tool("vdb_fractal_rock"), "-q", "--levels", "2", "--seed", "5", "--voxel-size", "0.05",
         "--size", "3,2.4,1.5", "-o", str(d / "rock_t.vdb"), "--normal-map", str(d / "rock_t.exr"),
         "--normal-map-size", "32", "--normal-space", "tangent"], check=True)
    run([tool("vdb_fractal_rock"), "-q", "--count", "12", "--levels", "1", "--size", "1,0.8,0.6",
         "--area", "-3,-3,3,3", "--voxel-size", "0.05", "-o", str(d / "scatter.vdb"),
         "--points", str(d / "points.vdb")], check=True)
    return d


@pytest.fixture(scope="module")
def arches(tmp_path_factory):
    """vdb_arches: a small strata terrain with a band of overhangs (5 cm stacks and voxels)."""
    d = tmp_path_factory.mktemp("arches")
    layers = [["bedrock", 0.3], ["sand", 0.05], ["bedrock", 0.1], ["air", 0.2], ["bedrock", 2.0]]
    scene = {"terrain": {"type": "strata", "samples": [60, 40], "base": 0.8, "amplitude": 0.3,
                         "frequency": 0.5, "warp": 0.05, "warp_frequency": 1.0,
                         "layers": [{"material": m, "thickness": t} for m, t in layers]},
             "cell-size": 0.05, "quantum": 0.001}
    (d / "scene.json").write_text(json.dumps(scene))
    run([tool("vdb_arches"), "-q", str(d / "scene.json"), "-o", str(d / "arches.vdb")], check=True)
    return d / "arches.vdb"


def every_output(tmp_path, scene, heightfield_png, blocks, amplified=None, detailed=None,
                 piled=None):
    files = [scene, blocks] + ([amplified] if amplified else []) + ([detailed] if detailed else [])
    files += [piled] if piled else []
    h = tmp_path / "hf.vdb"
    run([tool("vdb_heightfield"), "-q", str(heightfield_png), "--cell-size", "0.1",
         "--voxel-size", "0.05", "-o", str(h)], check=True)
    c = tmp_path / "csg.vdb"
    run([tool("vdb_csg"), "-q", "difference", str(scene), str(h), "-o", str(c)], check=True)
    return files + [h, c]


def test_pyopenvdb_reads_every_file(tmp_path, scene, heightfield_png, blocks, amplified,
                                    detailed, piled, fractal, arches):
    import pyopenvdb as vdb
    for f in every_output(tmp_path, scene, heightfield_png, blocks, amplified, detailed, piled) + [
            fractal / "rock.vdb", fractal / "scatter.vdb", arches]:
        grids, meta = vdb.readAll(str(f))
        names = [g.name for g in grids]
        assert "surface" in names
        s = [g for g in grids if g.name == "surface"][0]
        assert s.gridClass == vdb.GridClass.LEVEL_SET
        assert s.background == pytest.approx(3 * 0.05)
        assert s["rockvdb:generator"].startswith("vdb_")
        json.loads(s["rockvdb:params"])
    grids, _ = vdb.readAll(str(amplified))
    assert {g.name for g in grids} == {"surface", "block_id", "material"}
    amp_ids = [g for g in grids if g.name == "block_id"][0]
    assert any(it.value >= 0 for it in amp_ids.citerOnValues()), "no replicated block"
    grids, _ = vdb.readAll(str(piled))
    assert {g.name for g in grids} == {"surface", "rock_id"}
    rock_ids = [g for g in grids if g.name == "rock_id"][0]
    assert rock_ids.activeVoxelCount() == [g for g in grids if g.name == "surface"][0].activeVoxelCount()
    grids, _ = vdb.readAll(str(scene))
    ids = [g for g in grids if g.name == "block_id"][0]
    assert ids.activeVoxelCount() == [g for g in grids if g.name == "surface"][0].activeVoxelCount()
    vals = set()
    for it in ids.citerOnValues():
        vals.add(it.value)
    assert vals <= {1.0, 2.0} and vals == {1.0, 2.0}


@pytest.mark.skipif(not shutil.which("vdb_print"), reason="libopenvdb-tools not installed")
def test_vdb_print_lists_surface(scene, blocks):
    for f in (scene, blocks):
        p = subprocess.run(["vdb_print", "-l", str(f)], capture_output=True, text=True, check=True)
        assert "surface" in p.stdout and "block_id" in p.stdout
        assert "level set" in p.stdout or "level_set" in p.stdout


@pytest.mark.skipif(not shutil.which("vdb_render"), reason="libopenvdb-tools not installed")
def test_vdb_render_renders(scene, tmp_path):
    out = tmp_path / "r.ppm"
    subprocess.run(["vdb_render", str(scene), str(out), "-res", "160x120", "-name", "surface",
                    "-lookat", "0,0,0", "-translate", "0,-8,4", "-up", "0,0,1", "-shader",
                    "diffuse"], capture_output=True, text=True, check=True, timeout=300)
    data = out.read_bytes()
    assert data.startswith(b"P6")
    # The render is not blank: some pixels differ from the first one.
    body = data[data.index(b"255\n") + 4:]
    assert len(set(body[i:i + 3] for i in range(0, len(body), 3))) > 20


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
@pytest.mark.parametrize("which", ["scene", "blocks", "amplified", "detailed", "piled",
                                   "fractal", "scatter", "arches"])
def test_blender_imports_and_meshes_surface(which, scene, blocks, amplified, detailed, piled,
                                            fractal, arches, tmp_path):
    import pyopenvdb as vdb
    scene = {"scene": scene, "blocks": blocks, "amplified": amplified, "detailed": detailed,
             "piled": piled, "fractal": fractal / "rock.vdb",
             "scatter": fractal / "scatter.vdb", "arches": arches}[which]
    report = tmp_path / "blender.json"
    r = blender_json("blender_mesh.py", [scene, report], report)
    assert r["grids"] and "surface" in r["grids"]
    assert r["vertices"] > 1000
    s = vdb.read(str(scene), "surface")
    dx = s.transform.voxelSize()[0]
    # Our own zero isosurface (tools::volumeToMesh through rockvdb.mesh) bounds Blender's.
    import rockvdb
    obj = tmp_path / "ours.obj"
    rockvdb.mesh(s, str(obj))
    pts = [list(map(float, l.split()[1:4])) for l in obj.read_text().splitlines()
           if l.startswith("v ")]
    ours_lo = [min(p[a] for p in pts) for a in range(3)]
    ours_hi = [max(p[a] for p in pts) for a in range(3)]
    for a in range(3):
        assert abs(r["min"][a] - ours_lo[a]) <= 2 * dx + 1e-6, (a, r, ours_lo)
        assert abs(r["max"][a] - ours_hi[a]) <= 2 * dx + 1e-6, (a, r, ours_hi)


def overhang_columns(grid, count=4):
    """World (x, y) of columns where the level set crosses 0 exactly 4 times, each run of
    inside or outside at least 3 voxels long (robust to meshing), spread over the grid."""
    import numpy as np
    lo, hi = grid.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(h - l + 1 for l, h in zip(lo, hi)), np.float32)
    grid.copyToArray(a, ijk=lo)
    inside = a < 0
    found = []
    for i in range(1, a.shape[0] - 1, 2):
        for j in range(1, a.shape[1] - 1, 2):
            col = inside[i, j]
            flips = np.flatnonzero(col[1:] != col[:-1])
            if len(flips) == 4 and np.all(np.diff(flips) >= 3):
                found.append((i, j))
    assert len(found) >= count, "no overhang in the fixture"
    dx = grid.transform.voxelSize()[0]
    pick = [found[k * len(found) // count] for k in range(count)]
    # Off the voxel centres (Blender's mesh vertices sit on them).
    return [((lo[0] + i + 0.31) * dx, (lo[1] + j + 0.27) * dx) for i, j in pick]


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_meshes_the_arches_overhangs(arches, tmp_path):
    """A vertical line through the overhang band crosses Blender's mesh of the ground 4 times
    (bedrock top, the overhang's underside and top... as our level set does)."""
    import pyopenvdb as vdb
    columns = overhang_columns(vdb.read(str(arches), "surface"))
    report = tmp_path / "blender.json"
    r = blender_json("blender_mesh.py", [arches, report] + [f"{x},{y}" for x, y in columns],
                     report)
    assert r["crossings"] == [4] * len(columns), (r["crossings"], columns)


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_meshes_an_edited_terrain_a_tunnel_makes_it_a_torus(tmp_path):
    """Arches §4.2 through a real client: a ridge on a slab (a sphere's topology) with a tunnel
    swept through it by a vdb_arches edit. Blender's mesh of the ground has Euler characteristic
    2 before and 0 after (genus 1), and a vertical line through the ridge above the tunnel
    crosses it 4 times (top, roof, tunnel floor, bottom) where it crossed twice."""
    s2 = 0.7071067811865476
    ridge = {"type": "union", "children": [
        {"type": "box", "size": [30, 20, 5], "center": [15, 10, 2.5]},
        {"type": "polytope", "planes": [[s2, 0, s2, 26 * s2], [-s2, 0, s2, -4 * s2], [0, 1, 0, 20],
                                        [0, -1, 0, 0], [0, 0, -1, 0]]}]}
    circle = [[1.2 * math.cos(k * math.pi / 4), 1.2 * math.sin(k * math.pi / 4)] for k in range(8)]
    tunnel = {"tool": "tunnel", "nodes": [[6, 10, 7.5], [24, 10, 7.5]], "profile": circle}
    reports = []
    for name, edits in (("ridge", []), ("tunnel", [tunnel])):
        scene = tmp_path / f"{name}.json"
        scene.write_text(json.dumps({"terrain": ridge, "extent": [0, 0, 30, 20], "cell-size": 0.5,
                                     "voxel-size": 0.25, "weights": False, "edits": edits}))
        out = tmp_path / f"{name}.vdb"
        run([tool("vdb_arches"), "-q", str(scene), "-o", str(out)], check=True)
        report = tmp_path / f"{name}.report.json"
        reports.append(blender_json("blender_mesh.py",
                                    [out, report, "15.13,10.07", "15.13,4.07"], report))
    before, after = reports
    assert before["euler"] == 2 and after["euler"] == 0, (before["euler"], after["euler"])
    assert before["crossings"] == [2, 2] and after["crossings"] == [4, 2], \
        (before["crossings"], after["crossings"])


@pytest.mark.skipif(not shutil.which("vdb_tool"), reason="libopenvdb-tools not installed")
def test_vdb_tool_and_vdb_print_read_the_arches_terrain(arches, tmp_path):
    """vdb_tool's default actions mesh the ground (written last); vdb_print lists every grid."""
    obj = tmp_path / "a.obj"
    p = subprocess.run(["vdb_tool", "-read", str(arches), "-ls2mesh", "-write", str(obj)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and "Fatal" not in p.stderr, p.stderr
    theirs = sum(1 for l in obj.read_text().splitlines() if l.startswith("v "))
    ours = tmp_path / "ours.obj"
    run([tool("vdb_mesh"), "-q", str(arches), "-o", str(ours)], check=True)
    mine = sum(1 for l in ours.read_text().splitlines() if l.startswith("v "))
    assert theirs > 1000 and abs(theirs - mine) <= 0.02 * mine, (theirs, mine)
    p = subprocess.run(["vdb_print", "-l", str(arches)], capture_output=True, text=True, check=True)
    for name in ("surface", "sand", "bedrock", "material"):
        assert f"Name: {name}" in p.stdout
    assert p.stdout.count("class: level set") >= 3


@pytest.mark.skipif(not shutil.which("vdb_render"), reason="libopenvdb-tools not installed")
def test_vdb_render_renders_the_arches_ground(arches, tmp_path):
    out = tmp_path / "r.ppm"
    subprocess.run(["vdb_render", str(arches), str(out), "-res", "160x120", "-name", "surface",
                    "-lookat", "1.5,1,0.5", "-translate", "1.5,-3,3", "-up", "0,0,1", "-shader",
                    "diffuse"], capture_output=True, text=True, check=True, timeout=300)
    data = out.read_bytes()
    body = data[data.index(b"255\n") + 4:]
    assert data.startswith(b"P6") and len(set(body[i:i + 3] for i in range(0, len(body), 3))) > 20


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_imports_the_fractal_rock_mesh_with_uvs_and_normals(fractal, tmp_path):
    """Blender's own OBJ importer (default axes) puts the y-up OBJ where the level set is."""
    report = tmp_path / "obj.json"
    r = blender_json("blender_obj.py", [fractal / "rock.obj", report], report)
    assert r["vertices"] == 2562 and r["faces"] == 5120
    assert r["uv_layers"] and r["custom_normals"]
    # One smoothing group (OBJ "s 1"): smooth faces, and a glTF export that splits vertices
    # only along the UV seams (without it: 15 360, every triangle's own three).
    assert r["smooth"] == 1.0, r
    assert r["gltf_vertices"] < 1.3 * r["vertices"], r
    import pyopenvdb as vdb
    s = vdb.read(str(fractal / "rock.vdb"), "surface")
    lo, hi = s.evalActiveVoxelBoundingBox()
    dx = s.transform.voxelSize()[0]
    # The level set's band reaches 3 voxels past the mesh on every side.
    for a in range(3):
        assert abs(r["min"][a] - (lo[a] + 3) * dx) <= 1.5 * dx, (a, r, lo)
        assert abs(r["max"][a] - (hi[a] - 3) * dx) <= 1.5 * dx, (a, r, hi)


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_reads_both_normal_maps_in_their_spaces(fractal, tmp_path):
    """The object-space map of a y-up OBJ is turned with it (Blender keeps the file's frame as
    the object's: 0.22 agreement before), and the tangent-space map decoded with Blender's own
    MikkTSpace tangents gives the same normals; each EXR names its space in its header."""
    report = tmp_path / "nm.json"
    r = blender_json("blender_normal_map.py", [fractal / "rock.obj", fractal / "rock_n.exr",
                                               fractal / "rock_t.exr", report], report)
    assert r["triangles"] == 5120
    # A finer model's normals lean off the coarse mesh's, but not far: a wrong frame (the map
    # in z up under a y-up object) drops this to ~0.2.
    assert r["object"] > 0.8, r
    assert r["tangent"] > 0.8, r
    assert r["same"] > 0.97, r
    assert b"rockvdb:normal_space" in (fractal / "rock_n.exr").read_bytes()[:4096]
    assert b"object, y up" in (fractal / "rock_n.exr").read_bytes()[:4096]
    assert b"tangent" in (fractal / "rock_t.exr").read_bytes()[:4096]


@pytest.mark.skipif(not shutil.which("vdb_print"), reason="libopenvdb-tools not installed")
def test_vdb_print_reads_the_fractal_outputs(fractal):
    p = subprocess.run(["vdb_print", "-l", str(fractal / "scatter.vdb")], capture_output=True,
                       text=True, check=True)
    assert "surface" in p.stdout and "rock_id" in p.stdout
    p = subprocess.run(["vdb_print", "-l", str(fractal / "points.vdb")], capture_output=True,
                       text=True, check=True)
    assert "Name: rocks" in p.stdout and "Number of active voxels" in p.stdout


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_block_ids_reach_blender_and_ply_from_vdb_mesh(tmp_path):
    """Ids on meshes (issue 41): vdb_mesh writes block_id per vertex — a PLY vertex property,
    and in the OBJ each face under `usemtl block_id_<id>` — so Blender's importer gives every
    face a material slot named by its block. Checked against the .vdb's own block_id grid at
    the faces' centres."""
    import numpy as np
    import pyopenvdb as vdb
    src = tmp_path / "b.vdb"
    subprocess.run([tool("vdb_blocks"), "-q", "--tile-size", "8", "--point-radius", "0.5",
                    "--voxel-size", "0.1", "-o", str(src)], check=True)
    subprocess.run([tool("vdb_mesh"), "-q", str(src), "--up", "y", "-o", str(tmp_path / "b.obj")],
                   check=True)
    subprocess.run([tool("vdb_mesh"), "-q", str(src), "-o", str(tmp_path / "b.ply")], check=True)
    report = tmp_path / "ids.json"
    r = blender_json("blender_ids.py", [tmp_path / "b.obj", report], report)
    surface, ids = vdb.read(str(src), "surface"), vdb.read(str(src), "block_id")
    sa, ia = surface.getConstAccessor(), ids.getConstAccessor()
    dx = surface.transform.voxelSize()[0]
    present = set()
    for it in ids.citerOnValues():
        if it.value >= 0:
            present.add(int(it.value))
    assert {f"block_id_{i}" for i in present} == set(r["slots"])
    agree = wrong = 0
    for x, y, z, name in r["polygons"]:
        # The voxel nearest the surface among the 8 around the face's centre holds its block;
        # where two blocks' surfaces meet within a voxel (gaps of w < dx) either may.
        base = [int(np.floor(v / dx)) for v in (x, y, z)]
        best, got = 1e9, None
        for k in range(8):
            c = (base[0] + (k & 1), base[1] + (k >> 1 & 1), base[2] + (k >> 2 & 1))
            if ia.getValue(c) >= 0 and abs(sa.getValue(c)) < best:
                best, got = abs(sa.getValue(c)), int(ia.getValue(c))
        agree += name == f"block_id_{got}"
        near = {f"block_id_{int(ia.getValue((base[0] + i, base[1] + j, base[2] + k)))}"
                for i in range(-1, 3) for j in range(-1, 3) for k in range(-1, 3)}
        wrong += name not in near
    n = len(r["polygons"])
    assert n > 1000 and agree / n > 0.9 and wrong / n < 0.002, (agree / n, wrong / n)
    # The PLY: a vertex property block_id holding the same ids.
    data = (tmp_path / "b.ply").read_bytes()
    header = data[:data.index(b"end_header\n")].decode()
    assert "property int block_id" in header
    n = int(header.split("element vertex ")[1].split()[0])
    start = data.index(b"end_header\n") + len(b"end_header\n")
    verts = np.frombuffer(data[start:start + n * 16], dtype=np.dtype(
        [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("block_id", "<i4")]))
    assert set(np.unique(verts["block_id"]).tolist()) <= present | {-1}
    assert (verts["block_id"] >= 0).mean() > 0.99


@pytest.mark.skipif(not (shutil.which("vdb_tool") and shutil.which("vdb_render")),
                    reason="libopenvdb-tools not installed")
def test_the_grid_order_and_names_serve_vdb_tool_and_vdb_render(blocks, piled, tmp_path):
    """Files with ids hold them before the level set: vdb_tool's default (the last grid read)
    meshes `surface`; vdb_render's default is the first float grid, an id grid, so the docs
    give it `-name surface`, which renders the blocks. A rock tile set is named `.tiles.vdb`:
    vdb_tool refuses any other extension ('invalid extension' for the `.tiles` of old)."""
    obj = tmp_path / "b.obj"
    p = subprocess.run(["vdb_tool", "-read", str(blocks), "-ls2mesh", "-write", str(obj)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and "Fatal" not in p.stderr, p.stderr
    theirs = sum(1 for l in obj.read_text().splitlines() if l.startswith("v "))
    run([tool("vdb_mesh"), "-q", str(blocks), "-o", str(tmp_path / "ours.obj")], check=True)
    mine = sum(1 for l in (tmp_path / "ours.obj").read_text().splitlines() if l.startswith("v "))
    assert theirs > 1000 and abs(theirs - mine) <= 0.02 * mine, (theirs, mine)
    out = tmp_path / "r.ppm"
    subprocess.run(["vdb_render", str(blocks), str(out), "-res", "120x90", "-name", "surface",
                    "-lookat", "3,3,3", "-translate", "14,-10,12", "-up", "0,0,1"],
                   capture_output=True, text=True, check=True, timeout=300)
    body = out.read_bytes()
    body = body[body.index(b"255\n") + 4:]
    assert len(set(body[i:i + 3] for i in range(0, len(body), 3))) > 20  # shaded, not blank
    tiles = piled.parent / "rocks.tiles.vdb"
    p = subprocess.run(["vdb_tool", "-read", str(tiles), "-print"], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0 and 'name = "rho"' in p.stdout + p.stderr, p.stdout + p.stderr
    shutil.copy(tiles, tmp_path / "rocks.tiles")
    p = subprocess.run(["vdb_tool", "-read", str(tmp_path / "rocks.tiles"), "-print"],
                       capture_output=True, text=True, timeout=300)
    assert "invalid extension" in p.stdout + p.stderr


def test_points_files_hold_houdinis_attributes_and_blender_refuses_them(piled, tmp_path):
    """docs/tools.md: Blender's OpenVDB import cancels on a points file, naming the reason; the
    file is a points grid to OpenVDB's vdb_print, its attribute descriptor names what Houdini's
    Copy to Points reads (values: RockPile.InstancePointsCopyTheLibraryOntoThePile)."""
    d = piled.parent
    pts = tmp_path / "pts.vdb"
    run([tool("vdb_rockpile"), "-q", "pile", "--tiles", str(d / "rocks.tiles.vdb"), "--support",
         str(d / "ball.json"), "--points", str(pts), "-o", str(tmp_path / "pile.vdb")], check=True)
    listing = run(["vdb_print", str(pts)], check=True).stdout.decode()
    assert re.search(r"rocks\s+ptdataidx32", listing), listing
    data = pts.read_bytes()  # (the descriptor's names are stored uncompressed)
    for attr in (b"orient", b"pscale", b"pivot", b"variant", b"rock", b"tile"):
        assert attr in data, attr
    assert b"instance" not in data
    script = ("import bpy, sys\n"
              "r = bpy.ops.object.volume_import(filepath=sys.argv[-1])\n"
              "print('RESULT', sorted(r), len([o for o in bpy.data.objects if o.type == 'VOLUME']))\n")
    p = subprocess.run(["blender", "--background", "--factory-startup", "--python-expr", script,
                        "--", str(pts)], capture_output=True, text=True, timeout=300)
    assert "RESULT ['CANCELLED'] 0" in p.stdout, p.stdout[-2000:] + p.stderr[-2000:]
    assert "contains points, only voxel grids are supported" in p.stdout + p.stderr
