"""vdb_asset: a level set as a GLB that Blender's own glTF importer loads (LOD objects, their
triangles, uvs, normal maps, y up converted back to Blender's z up), with its provenance in the
asset's extras, the same bytes at any thread count, and one-line errors that write nothing."""
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


@pytest.fixture(scope="module")
def rock(tmp_path_factory):
    d = tmp_path_factory.mktemp("asset")
    run([tool("vdb_fractal_rock"), "-q", "--levels", "3", "--voxel-size", "0.01", "--seed", "5",
         "-o", str(d / "rock.vdb")], check=True)
    run([tool("vdb_asset"), "-q", str(d / "rock.vdb"), "--lods", "2000,600,150",
         "--texture-size", "256", "--name", "boulder", "-o", str(d / "rock.glb"),
         "--stats", str(d / "stats.json")], check=True)
    return d


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_blender_imports_every_lod_with_uvs_normal_maps_and_z_up(rock, tmp_path):
    report = tmp_path / "import.json"
    p = subprocess.run(["blender", "-b", "--factory-startup", "--python",
                        os.path.join(HERE, "blender_gltf.py"), "--", str(rock / "rock.glb"),
                        str(report)], capture_output=True, text=True, timeout=600)
    assert report.exists(), p.stdout[-3000:] + p.stderr[-3000:]
    r = json.loads(report.read_text())
    stats = json.loads((rock / "stats.json").read_text())
    assert sorted(r) == ["boulder_LOD0", "boulder_LOD1", "boulder_LOD2"]
    import pyopenvdb
    g = pyopenvdb.read(str(rock / "rock.vdb"), "surface")
    (i0, j0, k0), (i1, j1, k1) = g.evalActiveVoxelBoundingBox()
    dx = g.transform.voxelSize()[0]
    for l, (name, want) in enumerate(zip(sorted(r), (2000, 600, 150))):
        o = r[name]
        assert o["triangles"] == stats["lods"][l]["triangles"] <= want
        assert o["triangles"] >= 0.8 * want
        assert 0 <= o["uv"][0] and o["uv"][1] <= 1 and 0 <= o["uv"][2] and o["uv"][3] <= 1
        assert o["images"] == [f"boulder_LOD{l}_normal"] and o["image_size"] == [256, 256]
        assert o["normal_map_nodes"] == 1
        # the rock's top stays on top: Blender's z is rockvdb's z (the band is 3 voxels wide)
        assert (k0 + 2) * dx < o["z"][0] < (k0 + 4) * dx + 0.02
        assert (k1 - 4) * dx - 0.02 < o["z"][1] < (k1 - 2) * dx
        assert (j0 + 2) * dx < o["y"][0] and o["y"][1] < (j1 - 2) * dx


def test_provenance_in_extras_and_the_same_bytes_at_any_thread_count(rock, tmp_path):
    j = glb_json(rock / "rock.glb")
    prov = j["asset"]["extras"]["rockvdb"]
    assert prov["generator"] == "vdb_asset"
    assert prov["params"]["lods"] == "2000,600,150" and prov["params"]["texture-size"] == 256
    assert prov["params"]["source"]["generator"] == "vdb_fractal_rock"
    assert [n["name"] for n in j["nodes"]] == ["boulder_LOD0", "boulder_LOD1", "boulder_LOD2"]
    again = tmp_path / "one.glb"
    run([tool("vdb_asset"), "-q", "--threads", "1", str(rock / "rock.vdb"), "--lods",
         "2000,600,150", "--texture-size", "256", "--name", "boulder", "-o", str(again)], check=True)
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
                   2, "must be a .glb")
    assert not (tmp_path / "x.obj").exists()
