# SPDX-License-Identifier: Apache-2.0
"""vdb_asset: a level set as a GLB that Blender's own glTF importer loads (LOD objects, their
triangles, uvs, normal and occlusion maps, the collision hull, y up converted back to Blender's
z up), with its provenance in the asset's extras, the same bytes at any thread count; one block
cut out of a tile by --id and every one by --each-id, each replayed by its own provenance;
Python's rockvdb.asset gives the CLI's bytes; one-line errors that write nothing. A rock pile's
points as one GLB of instanced unique rocks (EXT_mesh_gpu_instancing) whose copies stand on the
pile's surface; an id mask texture holding the ids where they are."""
import json
import os
import shutil
import struct
import subprocess

import pytest

from conftest import one_line_error, run, tool

HERE = os.path.dirname(os.path.abspath(__file__))


def glb_json(path):
    """The JSON chunk of a GLB (header: magic, version, length; then chunk length, type)."""
    data = open(path, "rb").read()
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data)
    n, kind = struct.unpack_from("<I4s", data, 12)
    assert kind == b"JSON"
    return json.loads(data[20:20 + n])


def blender_import(glb, tmp_path):
    """What Blender's own glTF importer makes of a GLB, headless (blender_gltf.py's report)."""
    report = tmp_path / "import.json"
    p = subprocess.run(["blender", "-b", "--factory-startup", "--python",
                        os.path.join(HERE, "blender_gltf.py"), "--", str(glb), str(report)],
                       capture_output=True, text=True, timeout=600)
    assert report.exists(), p.stdout[-3000:] + p.stderr[-3000:]
    return json.loads(report.read_text())


@pytest.fixture(scope="module")
def rock(tmp_path_factory):
    d = tmp_path_factory.mktemp("asset")
    run([tool("vdb_fractal_rock"), "-q", "--levels", "3", "--voxel-size", "0.01", "--seed", "5",
         "-o", str(d / "rock.vdb")], check=True)
    run([tool("vdb_asset"), "-q", str(d / "rock.vdb"), "--lods", "2000,600,150",
         "--texture-size", "256", "--name", "boulder", "--collision", "-o", str(d / "rock.glb"),
         "--stats", str(d / "stats.json")], check=True)
    return d


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_imports_every_lod_with_uvs_normal_maps_and_z_up(rock, tmp_path):
    r = blender_import(rock / "rock.glb", tmp_path)
    stats = json.loads((rock / "stats.json").read_text())
    assert sorted(r) == ["UCX_boulder_00", "boulder_LOD0", "boulder_LOD1", "boulder_LOD2"]
    import pyopenvdb
    g = pyopenvdb.read(str(rock / "rock.vdb"), "surface")
    (i0, j0, k0), (i1, j1, k1) = g.evalActiveVoxelBoundingBox()
    dx = g.transform.voxelSize()[0]
    for l, (name, want) in enumerate(zip(sorted(r)[1:], (2000, 600, 150))):
        o = r[name]
        assert o["triangles"] == stats["lods"][l]["triangles"] <= want
        assert o["triangles"] >= 0.8 * want
        assert 0 <= o["uv"][0] and o["uv"][1] <= 1 and 0 <= o["uv"][2] and o["uv"][3] <= 1
        assert o["images"] == [f"boulder_LOD{l}_normal", f"boulder_LOD{l}_occlusion"]
        assert all(size == [256, 256] for size in o["image_sizes"].values())
        assert o["normal_map_nodes"] == 1 and o["occlusion_linked"] == 1
        assert 0.3 < stats["lods"][l]["occlusion_mean"] < 1.0
        # the rock's top stays on top: Blender's z is rockvdb's z (the band is 3 voxels wide)
        assert (k0 + 2) * dx < o["z"][0] < (k0 + 4) * dx + 0.02
        assert (k1 - 4) * dx - 0.02 < o["z"][1] < (k1 - 2) * dx
        assert (j0 + 2) * dx < o["y"][0] and o["y"][1] < (j1 - 2) * dx
    # the collision hull: no material, no uvs, encloses the coarsest LOD, extras as custom props
    c = r["UCX_boulder_00"]
    assert c["material"] is None and c["uv_layers"] == 0 and c["images"] == []
    assert c["triangles"] == stats["collision"]["triangles"] == 2 * c["vertices"] - 4
    assert c["custom"] == {"rockvdb_collision": "convex"}
    lod2 = r["boulder_LOD2"]
    assert c["z"] == pytest.approx(lod2["z"], abs=1e-6) and c["y"] == pytest.approx(lod2["y"], abs=1e-6)


def test_provenance_in_extras_and_the_same_bytes_at_any_thread_count(rock, tmp_path):
    j = glb_json(rock / "rock.glb")
    prov = j["asset"]["extras"]["rockvdb"]
    assert prov["generator"] == "vdb_asset"
    assert prov["params"]["lods"] == "2000,600,150" and prov["params"]["texture-size"] == 256
    assert prov["params"]["sources"][0]["generator"] == "vdb_fractal_rock"
    assert [n["name"] for n in j["nodes"]] == ["boulder_LOD0", "boulder_LOD1", "boulder_LOD2",
                                               "UCX_boulder_00"]
    again = tmp_path / "one.glb"
    run([tool("vdb_asset"), "-q", "--threads", "1", str(rock / "rock.vdb"), "--lods",
         "2000,600,150", "--texture-size", "256", "--name", "boulder", "--collision", "-o", str(again)],
        check=True)
    assert again.read_bytes() == (rock / "rock.glb").read_bytes()


@pytest.mark.parametrize("args, message", [
    (["--lods", "99999999"], "more than the"),
    (["--lods", "100,300"], "must decrease"),
    (["--lods", "many"], "lods must be triangle counts"),
    (["--texture-size", "0"], "texture-size must be in [8, 16384]"),
    (["--texture-size", "1000000"], "texture-size must be in [8, 16384]"),
    (["--grid", "nope"], "no grid 'nope'"),
])
def test_bad_input_is_one_line_and_writes_nothing(rock, tmp_path, args, message):
    out = tmp_path / "bad.glb"
    one_line_error(run([tool("vdb_asset"), str(rock / "rock.vdb"), *args, "-o", str(out)]), 2, message)
    assert not out.exists()


def test_the_output_must_be_a_glb(rock, tmp_path):
    one_line_error(run([tool("vdb_asset"), str(rock / "rock.vdb"), "-o", str(tmp_path / "x.obj")]),
                   2, "but this writes .glb")
    assert not (tmp_path / "x.obj").exists()


def glb_chunks(path_or_bytes):
    """(JSON dict, BIN bytes) of a GLB."""
    data = path_or_bytes if isinstance(path_or_bytes, bytes) else open(path_or_bytes, "rb").read()
    n, _ = struct.unpack_from("<I4s", data, 12)
    m, kind = struct.unpack_from("<I4s", data, 20 + n)
    assert kind == b"BIN\0"
    return json.loads(data[20:20 + n]), data[28 + n:28 + n + m]


def test_python_gives_the_clis_asset(rock):
    import pyopenvdb
    import rockvdb
    g = pyopenvdb.read(str(rock / "rock.vdb"), "surface")
    stats = {}
    data = rockvdb.asset(g, lods="2000,600,150", texture_size=256, name="boulder", collision=True,
                         stats=stats)
    j, b = glb_chunks(data)
    cj, cb = glb_chunks(rock / "rock.glb")
    assert b == cb
    # the same but for the inputs' names: the CLI records its input file, Python cannot
    pp, cp = j["asset"].pop("extras")["rockvdb"]["params"], cj["asset"].pop("extras")["rockvdb"]["params"]
    assert j == cj
    assert cp.pop("input") == str(rock / "rock.vdb") and pp == cp
    assert stats["lods"] == json.loads((rock / "stats.json").read_text())["lods"]


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    d = tmp_path_factory.mktemp("asset_blocks")
    run([tool("vdb_blocks"), "-q", "--type", "tabular", "--tile-size", "6", "--point-radius", "0.5",
         "--voxel-size", "0.1", "--seed", "3", "-o", str(d / "t.vdb")], check=True)
    return d


SMALL_ASSET = ["--lods", "300,80", "--texture-size", "64", "--padding", "2"]


def test_one_block_by_id_and_every_block_by_each_id_replayed_by_provenance(blocks, tmp_path):
    import numpy as np
    import pyopenvdb
    import rockvdb
    surface = pyopenvdb.read(str(blocks / "t.vdb"), "surface")
    block_id = pyopenvdb.read(str(blocks / "t.vdb"), "block_id")
    ids = rockvdb.asset_ids(surface, block_id)
    assert len(ids) >= 3 and ids == sorted(set(ids))
    pick = ids[len(ids) // 2]
    one = tmp_path / "one.glb"
    run([tool("vdb_asset"), "-q", str(blocks / "t.vdb"), *SMALL_ASSET, "--id", str(pick),
         "--stats", str(tmp_path / "one.json"), "-o", str(one)], check=True)
    assert json.loads((tmp_path / "one.json").read_text())["cut"]["id"] == pick
    # the asset lies where block `pick` is (its id voxels' box, rockvdb z up = glTF y up)
    (i0, j0, k0), (i1, j1, k1) = block_id.evalActiveVoxelBoundingBox()
    a = np.full((i1 - i0 + 1, j1 - j0 + 1, k1 - k0 + 1), -1.0, dtype=np.float32)
    block_id.copyToArray(a, ijk=(i0, j0, k0))
    inside = np.zeros(a.shape, dtype=np.float32)
    surface.copyToArray(inside, ijk=(i0, j0, k0))
    where = np.argwhere((np.rint(a) == pick) & (inside <= 0))
    dx = surface.transform.voxelSize()[0]
    lo = (where.min(axis=0) + (i0, j0, k0)) * dx
    hi = (where.max(axis=0) + (i0, j0, k0)) * dx
    j, _ = glb_chunks(one)
    pos = j["accessors"][j["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    gmin = np.array([pos["min"][0], -pos["max"][2], pos["min"][1]])
    gmax = np.array([pos["max"][0], -pos["min"][2], pos["max"][1]])
    assert np.all(gmin > lo - 2 * dx) and np.all(gmax < hi + 2 * dx), (gmin, gmax, lo, hi)
    assert np.all(gmax - gmin > 0.5 * (hi - lo))

    each = tmp_path / "each"
    each.mkdir()
    run([tool("vdb_asset"), "-q", str(blocks / "t.vdb"), *SMALL_ASSET, "--each-id", "--name", "blk",
         "-o", str(each / "blk_{id}.glb")], check=True)
    assert sorted(os.listdir(each)) == sorted(f"blk_{i}.glb" for i in ids)
    mine = each / f"blk_{pick}.glb"
    mj, mb = glb_chunks(mine)
    assert mb == glb_chunks(one)[1]  # the same block, only its name differs
    assert mj["nodes"][0]["name"] == f"blk_{pick}_LOD0"
    # each file replays from its own provenance, bit for bit
    params = mj["asset"]["extras"]["rockvdb"]["params"]
    assert params["id"] == pick and params["id-grid"] == "block_id"
    (tmp_path / "p.json").write_text(json.dumps(params))
    run([tool("vdb_asset"), "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "again.glb")],
        check=True)
    assert (tmp_path / "again.glb").read_bytes() == mine.read_bytes()
    # and Python makes the same set
    from_python = rockvdb.asset_each(surface, block_id, lods="300,80", texture_size=64, padding=2,
                                     name="blk")
    assert sorted(from_python) == ids
    assert glb_chunks(from_python[pick])[1] == mb


@pytest.mark.parametrize("args, message", [
    (["--id", "99999"], "id 99999 is not in 'block_id'"),
    (["--each-id"], "must hold '{id}'"),
    (["--id-grid", "surface", "--id", "1"], "is a level set, not an id grid"),
    (["--id-grid", "nope", "--id", "1"], "has no id grid 'nope'"),
])
def test_bad_ids_are_one_line_and_write_nothing(blocks, tmp_path, args, message):
    out = tmp_path / "bad.glb"
    one_line_error(run([tool("vdb_asset"), str(blocks / "t.vdb"), *SMALL_ASSET, *args, "-o", str(out)]),
                   2, message)
    assert not out.exists()


def test_ids_need_an_id_grid_and_a_slot(rock, tmp_path):
    one_line_error(run([tool("vdb_asset"), str(rock / "rock.vdb"), "--id", "3", "-o", str(tmp_path / "a.glb")]),
                   2, "has no id grid 'block_id' or 'rock_id'")
    one_line_error(run([tool("vdb_asset"), str(rock / "rock.vdb"), "-o", str(tmp_path / "a_{id}.glb")]),
                   2, "--each-id is not given")
    one_line_error(run([tool("vdb_asset"), str(rock / "rock.vdb"), "--each-id", "--id", "1",
                        "-o", str(tmp_path / "a_{id}.glb")]), 2, "exclude each other")
    assert os.listdir(tmp_path) == []


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    d = tmp_path_factory.mktemp("asset_pile")
    run([tool("vdb_rockpile"), "-q", "tiles", "--tiling", "periodic", "--n", "3", "--cube-size", "0.5",
         "--seed", "2", "-o", str(d / "rocks.tiles.vdb")], check=True)
    (d / "ball.json").write_text(json.dumps({"type": "sphere", "radius": 0.6}))
    run([tool("vdb_rockpile"), "-q", "pile", "--tiles", str(d / "rocks.tiles.vdb"), "--support",
         str(d / "ball.json"), "--points", str(d / "points.vdb"), "--stats", str(d / "pile.json"),
         "-o", str(d / "pile.vdb")], check=True)
    run([tool("vdb_asset"), "-q", str(d / "points.vdb"), "--tiles", str(d / "rocks.tiles.vdb"),
         *SMALL_ASSET, "--name", "pebble", "--collision", "--stats", str(d / "asset.json"),
         "-o", str(d / "pile.glb")], check=True)
    return d


def accessor(j, b, i):
    import numpy as np
    a = j["accessors"][i]
    v = j["bufferViews"][a["bufferView"]]
    n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
    dtype = np.float32 if a["componentType"] == 5126 else np.uint32
    return np.frombuffer(b, dtype, a["count"] * n, v.get("byteOffset", 0) + a.get("byteOffset", 0)).reshape(-1, n)


def test_a_pile_as_instanced_unique_rocks_that_stand_on_the_piles_surface(pile):
    import numpy as np
    import pyopenvdb
    j, b = glb_chunks(pile / "pile.glb")
    assert j["extensionsUsed"] == ["EXT_mesh_gpu_instancing"]
    assert "extensionsRequired" not in j  # a reader without it still draws every rock once
    stats = json.loads((pile / "asset.json").read_text())
    placed = json.loads((pile / "pile.json").read_text())["placed"]
    # a periodic set: every cube holds copies of the same rocks
    assert stats["instances"] == placed and 10 <= stats["unique_rocks"] and 4 * stats["unique_rocks"] < placed
    names = [n["name"] for n in j["nodes"]]
    lod0 = [n for n in j["nodes"] if n["name"].endswith("_LOD0")]
    assert len(lod0) == stats["unique_rocks"]
    surface = pyopenvdb.read(str(pile / "pile.vdb"), "surface")
    dx = surface.transform.voxelSize()[0]
    (i0, j0, k0), (i1, j1, k1) = surface.evalActiveVoxelBoundingBox()
    phi = np.full((i1 - i0 + 3, j1 - j0 + 3, k1 - k0 + 3), surface.background, dtype=np.float32)
    surface.copyToArray(phi, ijk=(i0 - 1, j0 - 1, k0 - 1))

    def trilinear(p):  # rockvdb world (n, 3) -> phi, voxel centres at index * dx
        u = p / dx - (i0 - 1, j0 - 1, k0 - 1)
        f = np.floor(u).astype(int)
        t = u - f
        out = 0.0
        for c in range(8):
            o = ((c >> 2) & 1, (c >> 1) & 1, c & 1)
            w = np.prod(np.where(o, t, 1 - t), axis=1)
            out = out + w * phi[f[:, 0] + o[0], f[:, 1] + o[1], f[:, 2] + o[2]]
        return out

    count, near, worst, counted = 0, 0, -1.0, 0
    for node in lod0:
        rock = node["name"][len("pebble_"):-len("_LOD0")]
        assert node["extras"]["rockvdb_rock"] == int(rock)
        # every node of the rock (its LODs, its hull) is drawn at the same instances
        mine = [n for n in j["nodes"] if n["name"].startswith(f"pebble_{rock}_LOD") or
                n["name"] == f"UCX_pebble_{rock}_00"]
        assert len(mine) == 3 and f"UCX_pebble_{rock}_00" in names
        t = {n["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"] for n in mine}
        assert len(t) == 1
        seeds = accessor(j, b, t.pop())
        count += len(seeds)
        pos = accessor(j, b, j["meshes"][node["mesh"]]["primitives"][0]["attributes"]["POSITION"])
        # centred on its seed: the mesh's pivot is inside the rock
        assert np.all(np.abs(pos).max(axis=0) < 0.5)
        for s in seeds:
            w = pos + s  # glTF y up -> rockvdb z up: (x, y, z) = (x, -z, y)
            d = trilinear(np.stack([w[:, 0], -w[:, 2], w[:, 1]], axis=1))
            worst = max(worst, float(d.max()))
            near += int(np.count_nonzero(np.abs(d) < 0.5 * dx))
            counted += len(d)
    total = sum(len(accessor(j, b, n["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"]))
                for n in lod0)
    assert count == total == placed
    # every instanced vertex lies on the pile's surface, within the LOD's simplification
    # error, none outside it (a vertex inside a neighbour rock may lie deeper: fused rocks)
    assert worst < 0.5 * dx, worst
    assert near >= 0.9 * counted, near / counted


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_without_the_instancing_extension_imports_each_rock_once(pile, tmp_path):
    r = blender_import(pile / "pile.glb", tmp_path)
    stats = json.loads((pile / "asset.json").read_text())
    rocks = [s["rock"] for s in stats["rocks"]]
    want = {f"pebble_{k}_LOD{l}" for k in rocks for l in (0, 1)} | {f"UCX_pebble_{k}_00" for k in rocks}
    assert set(r) == want
    for k, s in zip(rocks, stats["rocks"]):
        assert r[f"pebble_{k}_LOD0"]["triangles"] == s["lods"][0]["triangles"]
        # drawn once, at its pivot (its seed): centred near the origin
        assert -0.5 < r[f"pebble_{k}_LOD0"]["z"][0] < 0 < r[f"pebble_{k}_LOD0"]["z"][1] < 0.5


def test_a_pile_replays_from_its_provenance_and_python_gives_the_same_bytes(pile, tmp_path):
    import rockvdb
    j, _ = glb_chunks(pile / "pile.glb")
    params = j["asset"]["extras"]["rockvdb"]["params"]
    assert params["input"] == str(pile / "points.vdb") and params["tiles"] == str(pile / "rocks.tiles.vdb")
    (tmp_path / "p.json").write_text(json.dumps(params))
    run([tool("vdb_asset"), "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "again.glb")],
        check=True)
    assert (tmp_path / "again.glb").read_bytes() == (pile / "pile.glb").read_bytes()
    data = rockvdb.asset_instances(str(pile / "points.vdb"), str(pile / "rocks.tiles.vdb"), lods="300,80",
                                   texture_size=64, padding=2, name="pebble", collision=True)
    assert data == (pile / "pile.glb").read_bytes()


def test_bad_pile_inputs_are_one_line_and_write_nothing(pile, tmp_path):
    out = tmp_path / "bad.glb"
    pts, tiles = str(pile / "points.vdb"), str(pile / "rocks.tiles.vdb")
    # points of another tile set: not on its rocks' lattice
    run([tool("vdb_rockpile"), "-q", "tiles", "--tiling", "periodic", "--n", "3", "--cube-size", "0.5",
         "--seed", "9", "-o", str(tmp_path / "other.tiles.vdb")], check=True)
    one_line_error(run([tool("vdb_asset"), pts, "--tiles", str(tmp_path / "other.tiles.vdb"), "-o", str(out)]),
                   2, "do not belong together")
    one_line_error(run([tool("vdb_asset"), str(pile / "pile.vdb"), "--tiles", tiles, "-o", str(out)]),
                   2, "has no points grid")
    one_line_error(run([tool("vdb_asset"), pts, "--tiles", pts, "-o", str(out)]), 2, "holds no tile set")
    one_line_error(run([tool("vdb_asset"), pts, "--tiles", tiles, "--id", "3", "-o", str(out)]),
                   2, "do not apply")
    assert not out.exists()


def png_grey(data):
    """Pixels of a grey 8-bit PNG (rows top down), decoded with zlib and the five row filters."""
    import zlib
    import numpy as np
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        n, kind = struct.unpack_from(">I4s", data, pos)
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            width, height, depth, colour = struct.unpack_from(">IIBB", body)
            assert depth == 8 and colour == 0
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw = zlib.decompress(idat)
    out = np.zeros((height, width), dtype=np.int32)
    prev = np.zeros(width, dtype=np.int32)
    for y in range(height):
        f, row = raw[y * (width + 1)], np.frombuffer(raw, np.uint8, width, y * (width + 1) + 1).astype(np.int32)
        cur = np.zeros(width, dtype=np.int32)
        for x in range(width):
            a = cur[x - 1] if x else 0
            b, c = prev[x], (prev[x - 1] if x else 0)
            if f == 0: p = 0
            elif f == 1: p = a
            elif f == 2: p = b
            elif f == 3: p = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (row[x] + p) & 255
        out[y], prev = cur, cur
    return out


def test_a_mask_texture_holds_the_ids_where_they_are_and_replays(blocks, tmp_path):
    import numpy as np
    import pyopenvdb
    import rockvdb
    surface = pyopenvdb.read(str(blocks / "t.vdb"), "surface")
    block_id = pyopenvdb.read(str(blocks / "t.vdb"), "block_id")
    ids = set(rockvdb.asset_ids(surface, block_id))
    out = tmp_path / "tile.glb"
    run([tool("vdb_asset"), "-q", str(blocks / "t.vdb"), "--lods", "3000", "--texture-size", "256",
         "--mask-grid", "block_id", "--stats", str(tmp_path / "s.json"), "-o", str(out)], check=True)
    stats = json.loads((tmp_path / "s.json").read_text())
    assert stats["mask"]["grid"] == "block_id" and set(stats["mask"]["ids"]) <= ids
    assert len(stats["mask"]["ids"]) >= 0.8 * len(ids) and stats["mask"]["texels_without_id"] < 0.01
    j, b = glb_chunks(out)
    mask = j["materials"][0]["extras"]["rockvdb_mask"]
    assert mask["grid"] == "block_id" and mask["none"] == 255
    image = j["images"][j["textures"][mask["index"]]["source"]]
    assert image["name"] == "rock_LOD0_block_id"
    view = j["bufferViews"][image["bufferView"]]
    pixels = png_grey(b[view.get("byteOffset", 0):view.get("byteOffset", 0) + view["byteLength"]])
    assert pixels.shape == (256, 256)
    values = set(np.unique(pixels).tolist())
    assert values - {255} == set(stats["mask"]["ids"])
    # the provenance names the mask grid: it replays bit for bit; Python gives the same bytes
    (tmp_path / "p.json").write_text(json.dumps(j["asset"]["extras"]["rockvdb"]["params"]))
    run([tool("vdb_asset"), "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "again.glb")],
        check=True)
    assert (tmp_path / "again.glb").read_bytes() == out.read_bytes()
    data = rockvdb.asset(surface, lods="3000", texture_size=256, mask=block_id)
    assert glb_chunks(data)[1] == b
    one_line_error(run([tool("vdb_asset"), str(blocks / "t.vdb"), "--mask-grid", "surface",
                        "-o", str(tmp_path / "bad.glb")]), 2, "is a level set, not an id grid")
    one_line_error(run([tool("vdb_asset"), str(blocks / "t.vdb"), "--mask-grid", "nope",
                        "-o", str(tmp_path / "bad.glb")]), 2, "has no id grid 'nope'")
    assert not (tmp_path / "bad.glb").exists()
