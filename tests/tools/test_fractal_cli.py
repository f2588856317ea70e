"""vdb_fractal_rock and rockvdb.fractal_rock (issue 16): the CLI and Python give the same grid
and mesh, a file replays from its own provenance, the mesh and the normal map files are what
they claim (closed OBJ with normals and UVs in the stated layout, PLY with normals, RGB EXR),
bad input is one clean line and no file."""
import json
import os
import struct

import numpy as np
import pyopenvdb as vdb
import pytest

import rockvdb
from conftest import assert_bitwise_equal, one_line_error, run, tool

FR = tool("vdb_fractal_rock")


def read_obj(path):
    v, vt, vn, faces = [], [], [], []
    for line in open(path):
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            v.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vt":
            vt.append([float(x) for x in parts[1:3]])
        elif parts[0] == "vn":
            vn.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            faces.append([[int(i) if i else 0 for i in c.split("/")] for c in parts[1:]])
    return np.array(v), np.array(vt), np.array(vn), faces


def test_cli_and_python_give_the_same_grid_and_mesh(tmp_path):
    args = ["--levels", "2", "--size", "1.0,0.8,0.5", "--h-up", "0.4", "--h-down", "0.9",
            "--seed", "5", "--voxel-size", "0.02", "--method", "approximating"]
    run([FR, "-q", *args, "-o", str(tmp_path / "cli.vdb"), "--mesh", str(tmp_path / "cli.obj")],
        check=True)
    surface, mesh = rockvdb.fractal_rock(levels=2, size=(1.0, 0.8, 0.5), h_up=0.4, h_down=0.9,
                                         seed=5, voxel_size=0.02, method="approximating",
                                         mesh_path=tmp_path / "py.obj")
    cli = vdb.read(str(tmp_path / "cli.vdb"), "surface")
    assert_bitwise_equal(cli, surface)
    assert cli.metadata["rockvdb:params"] == surface.metadata["rockvdb:params"]
    assert (tmp_path / "cli.obj").read_bytes() == (tmp_path / "py.obj").read_bytes()
    v, _, vn, faces = read_obj(tmp_path / "cli.obj")
    assert np.allclose(v, mesh["points"], atol=1e-6)
    assert len(faces) == 20 * 16 ** 2 == len(mesh["triangles"])


def test_defaults_are_the_same_on_both_interfaces(tmp_path):
    run([FR, "-q", "--voxel-size", "0.03", "-o", str(tmp_path / "cli.vdb")], check=True)
    surface, _ = rockvdb.fractal_rock(voxel_size=0.03)
    assert_bitwise_equal(vdb.read(str(tmp_path / "cli.vdb"), "surface"), surface)


def test_a_file_replays_from_its_own_provenance(tmp_path):
    first = tmp_path / "first.vdb"
    run([FR, "-q", "--seed", "9", "--levels", "3", "--method", "midpoint", "--tilt", "180",
         "--voxel-size", "0.02", "-o", str(first)], check=True)
    prov = json.loads(vdb.read(str(first), "surface").metadata["rockvdb:params"])
    assert prov["method"] == "midpoint" and prov["seed"] == 9
    (tmp_path / "p.json").write_text(json.dumps(prov))
    run([FR, "-q", "--params", str(tmp_path / "p.json"), "-o", str(tmp_path / "again.vdb")],
        check=True)
    assert_bitwise_equal(vdb.read(str(first), "surface"), vdb.read(str(tmp_path / "again.vdb"), "surface"))


def test_obj_is_closed_with_normals_and_uvs_in_the_stated_layout(tmp_path):
    obj, exr = tmp_path / "r.obj", tmp_path / "r.exr"
    run([FR, "-q", "--levels", "1", "--voxel-size", "0.05", "-o", str(tmp_path / "r.vdb"),
         "--mesh", str(obj), "--normal-map", str(exr), "--normal-map-size", "32"], check=True)
    v, vt, vn, faces = read_obj(obj)
    assert len(faces) == 320 and len(vn) == len(v)
    # Every corner is v/vt/vn with vn = v; every undirected edge in exactly two faces.
    edges = {}
    for f in faces:
        assert len(f) == 3 and all(len(c) == 3 and c[0] == c[2] for c in f)
        for a, b in ((f[0][0], f[1][0]), (f[1][0], f[2][0]), (f[2][0], f[0][0])):
            edges[(a, b)] = edges.get((a, b), 0) + 1
    assert all(n == 1 for n in edges.values()) and all((b, a) in edges for a, b in edges)
    assert np.allclose(np.linalg.norm(vn, axis=1), 1, atol=1e-5)
    # Normals point outwards (away from the centroid) for most vertices.
    c = v.mean(axis=0)
    assert np.mean(np.sum((v - c) * vn, axis=1) > 0) > 0.95
    # UVs inside [0,1]²; the 16 sub-triangles of one base face stay in one half-cell.
    assert vt.min() >= 0 and vt.max() <= 1
    for k in range(20):
        uv = np.array([vt[c[1] - 1] for f in faces[16 * k:16 * k + 16] for c in f])
        col, row = np.floor(uv[:, 0] * 5), np.floor(uv[:, 1] * 2)
        assert len(set(col)) == 1 and len(set(row)) == 1, k
    # The normal map: an RGB float EXR of 5n x 2n pixels.
    data = exr.read_bytes()
    assert data[:4] == b"\x76\x2f\x31\x01"
    for ch in (b"R\x00", b"G\x00", b"B\x00"):
        assert ch in data[:400]
    assert b"dataWindow" in data[:400]


def test_ply_has_normals_and_y_up_rotates(tmp_path):
    run([FR, "-q", "--levels", "1", "--voxel-size", "0.05", "-o", str(tmp_path / "r.vdb"),
         "--mesh", str(tmp_path / "r.ply")], check=True)
    head = (tmp_path / "r.ply").read_bytes().split(b"end_header\n")[0].decode()
    assert "property float nx" in head and "element face 320" in head
    run([FR, "-q", "--levels", "1", "--voxel-size", "0.05", "-o", str(tmp_path / "r2.vdb"),
         "--mesh", str(tmp_path / "z.obj")], check=True)
    run([FR, "-q", "--levels", "1", "--voxel-size", "0.05", "-o", str(tmp_path / "r3.vdb"),
         "--mesh", str(tmp_path / "y.obj"), "--mesh-up", "y"], check=True)
    vz, vy = read_obj(tmp_path / "z.obj")[0], read_obj(tmp_path / "y.obj")[0]
    assert np.allclose(vy, np.stack([vz[:, 0], vz[:, 2], -vz[:, 1]], axis=1), atol=1e-6)


def test_python_returns_the_mesh_and_the_normal_map(tmp_path):
    surface, mesh = rockvdb.fractal_rock(levels=1, normal_map=True, normal_map_size=16,
                                         level_set=False)
    assert surface is None
    assert mesh["points"].shape[1] == 3 and mesh["triangles"].shape == (320, 3)
    assert mesh["normal_map"].shape == (32, 80, 3)
    n = mesh["normal_map"] * 2 - 1
    assert np.allclose(np.linalg.norm(n, axis=2), 1, atol=1e-3)
    assert mesh["uvs"].min() >= 0 and mesh["triangle_uvs"].shape == (320, 3)
    with pytest.raises(TypeError, match="levels"):
        rockvdb.fractal_rock(levels="2")
    with pytest.raises(TypeError, match="did you mean 'levels'"):
        rockvdb.fractal_rock(level=2)
    with pytest.raises(ValueError, match="h-up"):
        rockvdb.fractal_rock(h_up=1.5)


@pytest.mark.parametrize("args,needles", [
    (["--levels", "-1"], ["levels"]),
    (["--size", "1,0,1"], ["size"]),
    (["--size", "1,nan,1"], ["size"]),
    (["--h-up", "1.2"], ["h-up"]),
    (["--h-down", "0"], ["h-down"]),
    (["--levels", "8"], ["--levels", "GB"]),
    (["--voxel-size", "0.00001"], ["--voxel-size"]),
    (["--method", "cubic"], ["method"]),
])
def test_bad_input_is_one_line_and_no_file(tmp_path, args, needles):
    out = tmp_path / "o.vdb"
    p = run([FR, "-q", *args, "-o", str(out), "--mesh", str(tmp_path / "o.obj")])
    one_line_error(p, 2, *needles)
    assert not out.exists() and not (tmp_path / "o.obj").exists()
    assert not [f for f in os.listdir(tmp_path) if ".tmp-" in f]
