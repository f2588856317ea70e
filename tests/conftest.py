# SPDX-License-Identifier: Apache-2.0
"""Shared fixtures: where the built tools are, and a helper to run them."""
import os
import subprocess

import pytest

BUILD = os.environ.get("ROCKVDB_BUILD", os.path.join(os.path.dirname(__file__), "..", "build"))
TOOLS = os.path.join(BUILD, "vdbtools")


def tool(name):
    return os.path.join(TOOLS, name)


def run(args, stdin=None, check=False):
    """Run a command; return CompletedProcess with bytes stdout and text stderr."""
    p = subprocess.run(args, input=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       timeout=600)
    p.stderr = p.stderr.decode(errors="replace")
    if check and p.returncode != 0:
        raise AssertionError(f"{args} failed ({p.returncode}): {p.stderr}")
    return p


def run_sample(script, out, *args):
    """Run samples/<script> as its usage line says (BUILD_DIR OUT_DIR [...]) from the
    repository root; assert it succeeded."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    p = subprocess.run(["bash", os.path.join(root, "samples", script), os.path.abspath(BUILD), str(out),
                        *[str(a) for a in args]], cwd=root, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr


def around(grid, lo, hi):
    """The dense values of @a grid over the index box [lo, hi] (background outside its band)."""
    import numpy as np
    a = np.zeros(tuple(hi[k] - lo[k] + 1 for k in range(3)), np.float32)
    grid.copyToArray(a, ijk=tuple(lo))
    return a


def arches_small_scene(tmp_path, **extra):
    """samples/data/arches_strata.json cut to 40 x 30 stacks (extra keys on top), as
    tmp_path/scene.json: the material-stack tests' quick scene."""
    import json
    sample = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "samples", "data", "arches_strata.json")
    scene = json.load(open(sample))
    scene["terrain"]["samples"] = [40, 30]
    scene.update(extra)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return path


def dense(grid):
    """(active bounding box, dense float32 array over it) of a pyopenvdb grid."""
    import numpy as np
    bb = grid.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(bb[1][k] - bb[0][k] + 1 for k in range(3)), dtype=np.float32)
    grid.copyToArray(a, ijk=bb[0])
    return bb, a


def assert_bitwise_equal(a, b):
    """Two pyopenvdb grids hold the same active voxels with bit-identical values."""
    import numpy as np
    assert a.activeVoxelCount() == b.activeVoxelCount()
    (ba, da), (bb, db) = dense(a), dense(b)
    assert ba == bb
    assert np.array_equal(da.view(np.uint32), db.view(np.uint32))


def one_line_error(p, code, *needles):
    """A failed run: exit code, exactly one stderr line saying "error:", with each needle."""
    assert p.returncode == code, (p.returncode, p.stderr)
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1, p.stderr
    assert "error:" in lines[0]
    for n in needles:
        assert n in lines[0], lines[0]


@pytest.fixture
def sphere_vdb(tmp_path):
    out = tmp_path / "sphere.vdb"
    run([tool("vdb_primitive"), "--voxel-size", "0.05", "-q", "-o", str(out), "sphere",
         "--radius", "1"], check=True)
    return out


def write_png16(path, rows):
    """Write a 16-bit greyscale PNG from rows of ints in 0..65535 (stdlib only)."""
    import struct
    import zlib

    h, w = len(rows), len(rows[0])
    raw = b"".join(b"\x00" + struct.pack(f">{w}H", *r) for r in rows)

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


@pytest.fixture
def heightfield_png(tmp_path):
    """A 33x33 ramp rising along x: value(i, j) = i/32."""
    path = tmp_path / "ramp.png"
    write_png16(path, [[round(65535 * i / 32) for i in range(33)] for _ in range(33)])
    return path
