# SPDX-License-Identifier: Apache-2.0
"""rockvdb inside hosts that loaded OpenVDB first (DESIGN: "Hosts that already loaded OpenVDB").

The extension used to crash (SIGSEGV) on any grid call in such a host: the static ops library
exported OpenVDB's template statics with default visibility, so Tree::treeType()'s call_once
flag bound to the host's copy while sTreeTypeName stayed the module's (never set). Each test
runs every grid call of host_calls.py in a fresh process and compares its report with a plain
interpreter's: same voxel counts, same hashes of the grids' values."""
import json
import os
import shutil
import subprocess

import pytest

from conftest import BUILD

HERE = os.path.dirname(os.path.abspath(__file__))
PYDIR = os.path.join(BUILD, "python")
LIBOPENVDB = "/usr/lib/x86_64-linux-gnu/libopenvdb.so.10.0"


def run_calls(out, env_extra=None):
    env = dict(os.environ, PYTHONPATH=PYDIR)
    env.update(env_extra or {})
    p = subprocess.run(["/usr/bin/python3", os.path.join(HERE, "host_calls.py"), str(out)],
                       env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, (p.returncode, p.stderr[-3000:])
    return json.loads((out / "host.json").read_text())


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    return run_calls(tmp_path_factory.mktemp("plain"))


def test_module_exports_only_its_init_function():
    so = [f for f in os.listdir(os.path.join(PYDIR, "rockvdb")) if f.startswith("_rockvdb")]
    assert len(so) == 1
    p = subprocess.run(["nm", "-D", "--defined-only", os.path.join(PYDIR, "rockvdb", so[0])],
                       capture_output=True, text=True, check=True)
    names = [l.split()[-1] for l in p.stdout.splitlines() if l.strip()]
    assert names == ["PyInit__rockvdb"], names[:20]


@pytest.mark.skipif(not os.path.exists(LIBOPENVDB), reason="libopenvdb 10.0 not installed")
def test_every_grid_call_works_with_openvdb_preloaded(tmp_path, plain):
    preloaded = run_calls(tmp_path, {"LD_PRELOAD": LIBOPENVDB})
    assert preloaded == plain
    assert plain["detail_voxels"] > 10000 and plain["pile_voxels"] > 1000
    assert plain["stacks_equal"] and plain["stacks_layers"] > 100


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_rockvdb_inside_blender_bakes_writes_imports_and_meshes(tmp_path, plain):
    p = subprocess.run(["blender", "--background", "--factory-startup", "--python",
                        os.path.join(HERE, "blender_rockvdb.py"), "--", PYDIR, str(tmp_path)],
                       capture_output=True, text=True, timeout=600)
    report = tmp_path / "host.json"
    assert report.exists(), p.stdout[-3000:] + p.stderr[-3000:]
    r = json.loads(report.read_text())
    assert "blender_vertices" in r, p.stdout[-3000:]
    # Inside Blender every call gives exactly what a plain interpreter gives.
    assert {k: v for k, v in r.items() if not k.startswith("blender_")} == plain
    assert r["blender_grids"] == ["block_id", "surface"]
    assert r["blender_vertices"] > 1000
    # Blender's mesh of 'surface' spans what our own zero isosurface spans (within 2 voxels).
    import pyopenvdb as vdb
    import rockvdb
    s = vdb.read(str(tmp_path / "host.vdb"), "surface")
    obj = tmp_path / "ours.obj"
    rockvdb.mesh(s, str(obj))
    pts = [list(map(float, l.split()[1:4])) for l in obj.read_text().splitlines()
           if l.startswith("v ")]
    dx = s.transform.voxelSize()[0]
    for a in range(3):
        assert abs(r["blender_min"][a] - min(q[a] for q in pts)) <= 2 * dx + 1e-6
        assert abs(r["blender_max"][a] - max(q[a] for q in pts)) <= 2 * dx + 1e-6
