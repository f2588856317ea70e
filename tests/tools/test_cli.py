# SPDX-License-Identifier: Apache-2.0
"""Every vdb_* tool: conventions, pipelines, provenance and bad input (one line, right exit
code, nothing left behind)."""
import json
import re
import math
import os
import struct
import subprocess

import pytest

from conftest import assert_bitwise_equal, one_line_error, run, tool

ALL_TOOLS = ["vdb_primitive", "vdb_heightfield", "vdb_csg", "vdb_mesh", "vdb_preview", "vdb_info",
             "vdb_blocks", "vdb_amplify", "vdb_merge", "vdb_rockpile", "vdb_fractal_rock", "vdb_asset"]



def leftovers(folder):
    return sorted(os.listdir(folder))


@pytest.mark.parametrize("name", ALL_TOOLS)
def test_help_and_version(name):
    h = run([tool(name), "--help"])
    assert h.returncode == 0
    assert b"--threads" in h.stdout and b"--params" in h.stdout
    v = run([tool(name), "--version"])
    assert v.returncode == 0 and b"rockvdb" in v.stdout


@pytest.mark.parametrize("name,look", [("vdb_amplify", "--max-slope"),
                                       ("vdb_detail", "--warp-amplitude"),
                                       ("vdb_blocks", "--seed")])
def test_help_sets_the_resolution_options_apart_from_the_look(name, look):
    # An artist tuning the look at a coarse voxel reads which options only resample the
    # same shape: the bake's rows under their own heading, the stage's look options above it.
    h = run([tool(name), "--help"]).stdout.decode()
    head = h.find("Resolution and extent (the same shape at any value")
    assert head > 0, h
    rows = h[head:]
    for opt in ("--voxel-size", "--half-width", "--region", "--chunks"):
        assert re.search(r"\n\s+" + opt + r"\b", rows), (opt, rows)
    assert look in h[:head] and look not in rows


@pytest.mark.parametrize("name", ALL_TOOLS)
def test_unknown_option_is_usage_error(name):
    one_line_error(run([tool(name), "--no-such-option"]), 2)


def test_primitive_provenance_is_complete(tmp_path):
    out = tmp_path / "box.vdb"
    run([tool("vdb_primitive"), "-q", "--seed", "7", "--voxel-size", "0.04", "-o", str(out),
         "box", "--size", "1,2,3", "--rounding", "0.1"], check=True)
    info = json.loads(run([tool("vdb_info"), "--json", str(out)], check=True).stdout)
    g = info[0]["grids"][0]
    assert g["name"] == "surface" and g["class"] == "level set"
    params = g["rockvdb"]["params"]
    assert g["rockvdb"]["generator"] == "vdb_primitive"
    assert params["seed"] == 7 and params["voxel-size"] == 0.04
    assert params["box"]["size"] == [1, 2, 3] and params["box"]["rounding"] == 0.1
    # The bounding box is the box plus the band.
    lo, hi = g["bbox_world"]
    assert abs(hi[2] - lo[2] - (3 + 2 * 3 * 0.04)) < 0.05


def test_params_json_sets_options_and_cli_wins(tmp_path):
    p = tmp_path / "p.json"
    p.write_text(json.dumps({"voxel-size": 0.1, "sphere": {"radius": 0.5}}))
    a = tmp_path / "a.vdb"
    run([tool("vdb_primitive"), "-q", "--params", str(p), "-o", str(a), "sphere"], check=True)
    b = tmp_path / "b.vdb"
    run([tool("vdb_primitive"), "-q", "--params", str(p), "--voxel-size", "0.05", "-o", str(b),
         "sphere"], check=True)
    ga = json.loads(run([tool("vdb_info"), "--json", str(a)]).stdout)[0]["grids"][0]
    gb = json.loads(run([tool("vdb_info"), "--json", str(b)]).stdout)[0]["grids"][0]
    assert ga["voxel_size"] == pytest.approx(0.1) and gb["voxel_size"] == pytest.approx(0.05)
    assert ga["rockvdb"]["params"]["sphere"]["radius"] == 0.5
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    one_line_error(run([tool("vdb_primitive"), "--params", str(bad), "-o", str(tmp_path / "x.vdb"),
                        "sphere"]), 2)
    assert not (tmp_path / "x.vdb").exists()


def test_pipeline_through_stdin_stdout(tmp_path, sphere_vdb):
    box = run([tool("vdb_primitive"), "-q", "--voxel-size", "0.05", "-o", "-", "box",
               "--size", "2,0.5,0.5"], check=True).stdout
    assert box[:4] == b" BDV"
    out = tmp_path / "u.vdb"
    run([tool("vdb_csg"), "-q", "union", "-", str(sphere_vdb), "-o", str(out)], stdin=box, check=True)
    g = json.loads(run([tool("vdb_info"), "--json", str(out)]).stdout)[0]["grids"][0]
    lo, hi = g["bbox_world"]
    assert hi[0] - lo[0] == pytest.approx(2 + 0.3, abs=0.11)   # the box's length wins along x
    assert g["rockvdb"]["params"]["sources"][1]["generator"] == "vdb_primitive"
    obj = run([tool("vdb_mesh"), "-q", str(out), "-o", "-"], check=True).stdout.decode()
    assert obj.count("\nv ") > 100 and "\nf " in obj


def test_bake_is_deterministic_across_threads(tmp_path):
    files = []
    for t in ("1", "2"):
        f = tmp_path / f"t{t}.vdb"
        run([tool("vdb_primitive"), "-q", "--threads", t, "--voxel-size", "0.05", "-o", str(f),
             "expr", "/dev/stdin"], stdin=json.dumps({"type": "warp", "amplitude": 0.1,
             "seed": 3, "child": {"type": "sphere", "radius": 1}}).encode(), check=True)
        files.append(f)
    # Same grids; only the "threads" parameter in the metadata differs.
    import pyopenvdb as vdb
    assert_bitwise_equal(*(vdb.read(str(f), "surface") for f in files))


# ---- bad input, for every tool ----------------------------------------------------------

@pytest.fixture
def bad_files(tmp_path, sphere_vdb):
    text = tmp_path / "text.vdb"
    text.write_text("this is not a vdb")
    data = sphere_vdb.read_bytes()
    trunc = tmp_path / "trunc.vdb"
    trunc.write_bytes(data[: len(data) // 2])
    fog = tmp_path / "fog.vdb"
    import pyopenvdb as vdb
    g = vdb.read(str(sphere_vdb), "surface")
    g.gridClass = vdb.GridClass.FOG_VOLUME
    vdb.write(str(fog), grids=[g])
    return {"missing": tmp_path / "missing.vdb", "text": text, "trunc": trunc, "fog": fog,
            "good": sphere_vdb}


READERS = {
    "vdb_csg": lambda f, o: [tool("vdb_csg"), "union", str(f), "-o", str(o)],
    "vdb_mesh": lambda f, o: [tool("vdb_mesh"), str(f), "-o", str(o) + ".obj"],
    "vdb_preview": lambda f, o: [tool("vdb_preview"), str(f), "-o", str(o) + ".png"],
    "vdb_info": lambda f, o: [tool("vdb_info"), str(f)],
    "vdb_merge": lambda f, o: [tool("vdb_merge"), str(f), "-o", str(o) + ".vdb"],
}


@pytest.mark.parametrize("name", sorted(READERS))
@pytest.mark.parametrize("kind,code,needle", [
    ("missing", 1, "no such file"), ("text", 1, "not a VDB"), ("trunc", 1, "truncated"),
    ("fog", 2, "fog volume")])
def test_readers_reject_bad_files(tmp_path, bad_files, name, kind, code, needle):
    if name in ("vdb_info", "vdb_merge") and kind == "fog":
        pytest.skip(f"{name} takes any float grid")
    out = tmp_path / "out"
    before = leftovers(tmp_path)
    one_line_error(run(READERS[name](bad_files[kind], out)), code, needle)
    assert leftovers(tmp_path) == before


@pytest.mark.parametrize("name", ["vdb_csg", "vdb_mesh", "vdb_preview"])
def test_wrong_grid_name(tmp_path, bad_files, name):
    args = READERS[name](bad_files["good"], tmp_path / "out") + ["--grid", "density"]
    one_line_error(run(args), 2, "no grid 'density'", "'surface'")


@pytest.mark.parametrize("vs", ["0", "-0.1", "nan"])
def test_bad_voxel_size(tmp_path, vs, heightfield_png):
    for args in ([tool("vdb_primitive"), "sphere"],
                 [tool("vdb_heightfield"), str(heightfield_png)]):
        out = tmp_path / "o.vdb"
        one_line_error(run(args + ["--voxel-size", vs, "-o", str(out)]), 2, "voxel-size must be in")
        assert not out.exists()


def test_huge_resolution_refused_before_allocating(tmp_path, heightfield_png):
    for args in ([tool("vdb_primitive"), "sphere", "--radius", "100"],
                 [tool("vdb_heightfield"), str(heightfield_png), "--cell-size", "1000"]):
        out = tmp_path / "o.vdb"
        p = run(args + ["--voxel-size", "0.0001", "-o", str(out)])
        one_line_error(p, 2, "refusing", "needed")
        assert not out.exists()


def test_unwritable_output(tmp_path, sphere_vdb, heightfield_png):
    cases = [
        [tool("vdb_primitive"), "sphere", "-o", "/nonexistent/dir/x.vdb"],
        [tool("vdb_heightfield"), str(heightfield_png), "-o", "/nonexistent/dir/x.vdb"],
        [tool("vdb_csg"), "union", str(sphere_vdb), "-o", "/nonexistent/dir/x.vdb"],
        [tool("vdb_mesh"), str(sphere_vdb), "-o", "/nonexistent/dir/x.obj"],
        [tool("vdb_preview"), str(sphere_vdb), "-o", "/nonexistent/dir/x.png"],
        [tool("vdb_merge"), str(sphere_vdb), "-o", "/nonexistent/dir/x.vdb"],
    ]
    for args in cases:
        one_line_error(run(args), 1, "does not exist")


def test_output_folder_as_file(tmp_path):
    one_line_error(run([tool("vdb_primitive"), "sphere", "-o", str(tmp_path)]), 1, "folder")


def test_missing_output_is_usage_error(tmp_path):
    one_line_error(run([tool("vdb_primitive"), "sphere"]), 2, "output")


def test_primitive_bad_parameters(tmp_path):
    out = tmp_path / "o.vdb"
    one_line_error(run([tool("vdb_primitive"), "-o", str(out), "sphere", "--radius", "-1"]), 2,
                   "sphere: radius must be > 0 (got -1)")
    one_line_error(run([tool("vdb_primitive"), "-o", str(out), "box", "--size", "1,0,1"]), 2, "box")
    one_line_error(run([tool("vdb_primitive"), "-o", str(out), "plane"]), 2, "region")
    one_line_error(run([tool("vdb_primitive"), "-o", str(out), "polytope", "--planes", "1,0,0"]), 2,
                   "nx,ny,nz,d")
    expr = tmp_path / "e.json"
    expr.write_text(json.dumps({"type": "union", "children": [{"type": "sphre", "radius": 1}]}))
    one_line_error(run([tool("vdb_primitive"), "-o", str(out), "expr", str(expr)]), 2,
                   "/children/0/type", "sphre")
    expr.write_text('{"type": "sphere", "radius": }')
    one_line_error(run([tool("vdb_primitive"), "-o", str(out), "expr", str(expr)]), 2, "malformed")
    assert not out.exists()


def test_heightfield_bad_images(tmp_path):
    out = tmp_path / "o.vdb"
    one_line_error(run([tool("vdb_heightfield"), str(tmp_path / "none.exr"), "-o", str(out)]), 1,
                   "no such file")
    junk = tmp_path / "junk.png"
    junk.write_text("nope")
    one_line_error(run([tool("vdb_heightfield"), str(junk), "-o", str(out)]), 1, "not an EXR or PNG")
    assert not out.exists()


def test_csg_resamples_and_smooths(tmp_path, sphere_vdb):
    other = tmp_path / "b.vdb"
    run([tool("vdb_primitive"), "-q", "--voxel-size", "0.04", "-o", str(other), "sphere",
         "--center", "1.2,0,0", "--radius", "0.8"], check=True)
    hard, soft = tmp_path / "h.vdb", tmp_path / "s.vdb"
    run([tool("vdb_csg"), "-q", "union", str(sphere_vdb), str(other), "-o", str(hard)], check=True)
    run([tool("vdb_csg"), "-q", "union", str(sphere_vdb), str(other), "--smooth", "0.3",
         "-o", str(soft)], check=True)
    import pyopenvdb as vdb
    h, s = vdb.read(str(hard), "surface"), vdb.read(str(soft), "surface")
    assert h.transform.voxelSize()[0] == pytest.approx(0.05)
    # The fillet fills the neck between the spheres: a point in the neck is inside only smoothly.
    ijk = h.transform.worldToIndexCellCentered((0.75, 0.70, 0.0))  # on a voxel, 0.03 outside both
    assert h.getConstAccessor().getValue(ijk) > 0 > s.getConstAccessor().getValue(ijk)
    # A smooth radius whose band widening cannot fit in memory is refused, nothing written.
    big = tmp_path / "big.vdb"
    one_line_error(run([tool("vdb_csg"), "union", str(sphere_vdb), str(other), "--smooth", "1e5",
                        "-o", str(big)]), 2, "refusing smooth radius")
    assert not big.exists()


@pytest.mark.parametrize("params, message", [
    ({"voxle-size": 0.2}, "unknown --params key 'voxle-size' (did you mean 'voxel-size'?)"),
    ({"voxel_size": 0.2}, "unknown --params key 'voxel_size' (did you mean 'voxel-size'?)"),
    ({"sphere": {"radius": 1, "radus": 2}}, "unknown --params key 'sphere.radus' (did you mean 'sphere.radius'?)"),
    ({"spher": {"radius": 1}}, "unknown --params key 'spher' (did you mean 'sphere'?)"),
    ({"zzzzzz": 1}, "unknown --params key 'zzzzzz'"),
])
def test_misspelt_params_keys_are_errors_naming_the_key(tmp_path, params, message):
    """A --params key that names no option (or subcommand) is an error suggesting the
    closest name, not silently ignored; nothing is written."""
    p = tmp_path / "p.json"
    p.write_text(json.dumps(params))
    out = tmp_path / "x.vdb"
    r = run([tool("vdb_primitive"), "--params", str(p), "-o", str(out), "sphere"])
    one_line_error(r, 2, message)
    if "did you mean" not in message:
        assert "did you mean" not in r.stderr
    assert not out.exists()


def test_a_csg_file_replays_from_its_own_provenance(tmp_path, sphere_vdb):
    """vdb_csg's rockvdb:params (with its inputs' provenance under "sources", which a replay
    skips) fed back as --params makes the same grid, bit for bit."""
    import pyopenvdb as vdb
    out, again = tmp_path / "u.vdb", tmp_path / "again.vdb"
    run([tool("vdb_csg"), "-q", "union", str(sphere_vdb), str(sphere_vdb), "--smooth", "0.1",
         "-o", str(out)], check=True)
    meta = vdb.readAllGridMetadata(str(out))[0]
    params = json.loads(meta["rockvdb:params"])
    assert params["sources"] and params["smooth"] == 0.1
    params["output"] = str(again)
    p = tmp_path / "replay.json"
    p.write_text(json.dumps(params))
    run([tool("vdb_csg"), "--params", str(p)], check=True)
    assert_bitwise_equal(vdb.read(str(out), "surface"), vdb.read(str(again), "surface"))


# (tool and arguments around the output option, the option, a wrong name, the right name)
WRONG_EXTENSIONS = [
    (["vdb_primitive", "sphere"], "-o", "rock.obj", "ROCK.VDB"),
    (["vdb_blocks", "--tile-size", "6", "--point-radius", "0.5"], "-o", "tile.ply", "tile.vdb"),
    (["vdb_blocks", "--tile-size", "6", "--point-radius", "0.5", "-o", "t.vdb"], "--meshes", "m.stl", "m.ply"),
    (["vdb_blocks", "--tile-size", "6", "--point-radius", "0.5", "-o", "t.vdb"], "--tile", "t2.vdb", "t.tile"),
    (["vdb_mesh", "SPHERE"], "-o", "s.vdb", "s.obj"),
    (["vdb_preview", "SPHERE", "--width", "32", "--height", "24"], "-o", "s.jpg", "s.png"),
    (["vdb_fractal_rock", "--levels", "1", "--voxel-size", "0.05", "-o", "f.vdb"], "--mesh", "f.glb", "f.obj"),
    (["vdb_fractal_rock", "--levels", "1", "--voxel-size", "0.05", "-o", "f.vdb", "--mesh", "f.obj"],
     "--normal-map", "n.png", "n.exr"),
    (["vdb_rockpile", "tiles", "--tiling", "periodic", "--n", "3", "--voxels-per-cell", "4"], "-o", "r.obj", "r.vdb"),
]


@pytest.mark.parametrize("before, option, wrong, right", WRONG_EXTENSIONS,
                         ids=[f"{w[0][0]} {w[1]} {w[2]}" for w in WRONG_EXTENSIONS])
def test_an_output_name_that_promises_another_format_is_refused(tmp_path, sphere_vdb, before,
                                                                 option, wrong, right):
    """`-o rock.obj` on a tool that writes a .vdb wrote a VDB by that name (Blender then
    imported a 2-vertex mesh): every output path's extension is checked before any work: one
    line naming the path and what the option writes, exit 2, nothing written. The right
    extension, in any case, runs."""
    work = tmp_path / "work"
    work.mkdir()
    args = [tool(before[0])] + [str(sphere_vdb) if a == "SPHERE" else a for a in before[1:]]

    def go(name):
        p = subprocess.run(args + ["-q", option, name], cwd=work, capture_output=True,
                           text=True, timeout=600)
        return p

    one_line_error(go(wrong), 2, wrong, "this writes")
    assert os.listdir(work) == []
    p = go(right)
    assert p.returncode == 0, p.stderr
    assert (work / right).exists()
