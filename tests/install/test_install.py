"""cmake --install puts the tools and the Python package where the README says: the tools in
PREFIX/bin, the package where /usr/bin/python3 finds it with PYTHONPATH=PREFIX/lib/python3.X/
dist-packages (already on sys.path for the default prefix, /usr/local)."""
import os
import subprocess
import sys

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
