# SPDX-License-Identifier: Apache-2.0
"""cmake --install puts the tools and the Python package where the README says: the tools in
PREFIX/bin, the package where /usr/bin/python3 finds it with PYTHONPATH=PREFIX/lib/python3.X/
dist-packages (already on sys.path for the default prefix, /usr/local)."""
import os
import shutil
import subprocess
import sys

import pytest

from conftest import BUILD


def test_install_prefix_tools_and_python_package(tmp_path):
    prefix = tmp_path / "prefix"
    p = subprocess.run(["cmake", "--install", BUILD, "--prefix", str(prefix)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    for t in ("vdb_primitive", "vdb_blocks", "vdb_amplify", "vdb_detail", "vdb_rockpile",
              "vdb_csg", "vdb_mesh", "vdb_preview", "vdb_info", "vdb_heightfield", "vdb_merge",
              "vdb_fractal_rock"):
        assert os.access(prefix / "bin" / t, os.X_OK), t
    out = tmp_path / "s.vdb"
    subprocess.run([str(prefix / "bin" / "vdb_primitive"), "-q", "--voxel-size", "0.1", "-o",
                    str(out), "sphere", "--radius", "1"], check=True, timeout=120)
    assert_documents_installed(prefix)
    site = prefix / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / "dist-packages"
    assert (site / "rockvdb" / "__init__.py").exists()
    # The one documented line, from a folder that is not the build tree.
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(site)
    code = ("import rockvdb, pyopenvdb; g = rockvdb.read(r'%s'); "
            "print(rockvdb.__file__); print(g.activeVoxelCount())" % out)
    r = subprocess.run(["/usr/bin/python3", "-c", code], cwd=str(tmp_path), env=env,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    where, count = r.stdout.split()
    assert where.startswith(str(site)) and int(count) > 1000
    # Debian's /usr/bin/python3 already searches the default prefix's folder.
    r = subprocess.run(["/usr/bin/python3", "-c", "import sys; print(sys.path)"], env=env,
                       capture_output=True, text=True, check=True)
    assert f"/usr/local/lib/python{sys.version_info[0]}.{sys.version_info[1]}/dist-packages" in r.stdout


BLENDER_RUN = """
import bpy, addon_utils, json, sys
prefs = bpy.context.preferences
{setup}
mod = addon_utils.enable("rockvdb_blender", default_set=True, handle_error=None)
import rockvdb
bpy.ops.object.select_all(action="DESELECT")
bpy.context.view_layer.objects.active = None
r = bpy.ops.rockvdb.fractal_rock(seed=4)
obj = bpy.context.active_object
json.dump({{"addon": mod.__file__ if mod else None, "rockvdb": rockvdb.__file__,
           "result": list(r), "stage": obj.get("rockvdb_stage") if obj else None}},
          open(sys.argv[-1], "w"))
"""


def assert_documents_installed(prefix):
    """The license and the tour beside the tools: README, docs and the samples with their data
    (the tour's commands read samples/data)."""
    doc = prefix / "share" / "doc" / "rockvdb"
    assert "Apache License" in (doc / "LICENSE").read_text()
    assert (doc / "NOTICE").exists() and (doc / "README.md").exists()
    assert (doc / "docs" / "blocks.md").exists() and (doc / "docs" / "blocks_authored.png").exists()
    samples = prefix / "share" / "rockvdb" / "samples"
    assert (samples / "data" / "boulder.json").exists() and (samples / "data" / "relief.exr").exists()
    assert os.access(samples / "01_demo.sh", os.X_OK)


def _blender(tmp_path, setup, env_extra=None):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env.update(env_extra or {})
    report = tmp_path / "blender.json"
    p = subprocess.run(["blender", "-b", "--factory-startup", "--python-expr",
                        BLENDER_RUN.format(setup=setup), "--", str(report)],
                       cwd=str(tmp_path), env=env, capture_output=True, text=True, timeout=600)
    assert report.exists(), p.stdout[-3000:] + p.stderr[-3000:]
    import json
    return json.loads(report.read_text())


@pytest.mark.skipif(not shutil.which("blender"), reason="blender not installed")
def test_install_blender_addon_with_the_one_documented_setting(tmp_path):
    """cmake --install, then Blender with Preferences > File Paths > Scripts set to
    PREFIX/share/rockvdb/blender (nothing else: no PYTHONPATH) enables the add-on, which finds
    the installed rockvdb package, and runs an operator. The zip installs through Blender's
    Install Add-on (into a scratch user folder) and works the same."""
    prefix = tmp_path / "prefix"
    p = subprocess.run(["cmake", "--install", BUILD, "--prefix", str(prefix)],
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stdout + p.stderr
    scripts = prefix / "share" / "rockvdb" / "blender"
    assert_documents_installed(prefix)
    site = prefix / "lib" / f"python{sys.version_info[0]}.{sys.version_info[1]}" / "dist-packages"
    r = _blender(tmp_path, f"prefs.filepaths.script_directory = r'{scripts}'\n"
                           "bpy.utils.refresh_script_paths()")
    assert r["addon"].startswith(str(scripts / "addons" / "rockvdb_blender"))
    assert r["rockvdb"].startswith(str(site))
    assert r["result"] == ["FINISHED"] and r["stage"] == "fractal_rock"
    user = tmp_path / "user"
    zipped = scripts / "rockvdb_blender.zip"
    r = _blender(tmp_path, f"bpy.ops.preferences.addon_install(filepath=r'{zipped}')",
                 {"BLENDER_USER_SCRIPTS": str(user / "scripts"),
                  "BLENDER_USER_CONFIG": str(user / "config")})
    assert r["addon"].startswith(str(user / "scripts" / "addons" / "rockvdb_blender"))
    assert r["rockvdb"].startswith(str(site))
    assert r["result"] == ["FINISHED"] and r["stage"] == "fractal_rock"
