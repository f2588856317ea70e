# SPDX-License-Identifier: Apache-2.0
"""The public Python API as a user meets it: what help() lists, docstrings, clean TypeErrors,
grids without names, the up axis of meshes, and material grids of rock piles."""
import inspect
import json
import pydoc
import re

import pyopenvdb as vdb
import pytest

import rockvdb


def public_names():
    return sorted(n for n, v in vars(rockvdb).items()
                  if not n.startswith("_") and (inspect.isfunction(v) or inspect.isclass(v))
                  and getattr(v, "__module__", "").startswith("rockvdb"))


def test_all_lists_every_public_function_and_class():
    assert sorted(n for n in rockvdb.__all__ if n != "__version__") == public_names()
    for name in ("rock_tiles", "rock_pile", "rock_library", "detail", "amplify", "read_image"):
        assert name in rockvdb.__all__
    text = pydoc.render_doc(rockvdb, renderer=pydoc.plaintext)
    for name in public_names():
        assert re.search(rf"\b{name}\b", text), name


def test_every_docstring_gives_units_or_defaults():
    for name in public_names():
        obj = getattr(rockvdb, name)
        doc = inspect.getdoc(obj) or ""
        assert len(doc) > 40, name
        if inspect.isfunction(obj):
            params = [p for p in inspect.signature(obj).parameters.values()
                      if p.default is not inspect.Parameter.empty and p.name != "stats"]
            if params:
                # Every function with defaults says what they are (or what units they take).
                assert re.search(r"default|\(m\b|metres|degrees|voxels", doc), name


@pytest.mark.parametrize("call, needles", [
    (lambda: rockvdb.write("/tmp/x.vdb", [None]), ["write()", "grids[0]", "pyopenvdb.FloatGrid",
                                               "NoneType"]),
    (lambda: rockvdb.write("/tmp/x.vdb", None), ["write()", "grids", "list"]),
    (lambda: rockvdb.sphere("1"), ["sphere()", "radius", "number", "str"]),
    (lambda: rockvdb.sphere(1, center=(0, 0)), ["sphere()", "center", "3 numbers"]),
    (lambda: rockvdb.detail(None), ["detail()", "grid", "pyopenvdb.FloatGrid"]),
    (lambda: rockvdb.mesh(None, "/tmp/x.obj"), ["mesh()", "grid"]),
    (lambda: rockvdb.csg("union", [1]), ["csg()", "grids[0]"]),
    (lambda: rockvdb.sphere(1).bake(voxel_size="fine"), ["Field.bake()", "voxel_size", "number"]),
    (lambda: rockvdb.sphere(1) | 3, ["Field.union()", "other", "rockvdb.Field"]),
    (lambda: rockvdb.rock_pile(None, rockvdb.sphere(1)), ["rock_pile()", "tiles"]),
    (lambda: rockvdb.amplify(None, []), ["amplify()", "terrain"]),
    (lambda: rockvdb.preview(rockvdb.sphere(1).bake(voxel_size=0.2), "/tmp/x.png", width=1.5),
     ["preview()", "width", "integer"]),
])
def test_wrong_types_name_the_parameter_and_the_type(call, needles):
    with pytest.raises(TypeError) as e:
        call()
    msg = str(e.value)
    for n in needles:
        assert n in msg, msg
    assert "incompatible function arguments" not in msg and "options" not in msg


def test_detail_on_a_grid_without_a_name():
    g = vdb.createLevelSetSphere(1.0, voxelSize=0.05)
    assert g.name == ""
    d = rockvdb.detail(g, gabor_amplitude=0.03)  # the Gabor frequency takes its default
    assert d.name == "surface" and d.gridClass == vdb.GridClass.LEVEL_SET
    assert d.activeVoxelCount() > 0.5 * g.activeVoxelCount()
    p = json.loads(rockvdb.provenance(d)[2])
    assert p["gabor-frequency"] == 0  # "auto": 1 / (10 A); replays the same


def test_mesh_up_axis_y_is_blenders_obj_convention(tmp_path):
    # A box standing on z = 2..4: in a y-up file its height runs along +y, and (x, y) -> (x, -z).
    g = rockvdb.box((1, 2, 2), center=(0, 3, 3)).bake(voxel_size=0.1)
    rockvdb.mesh(g, str(tmp_path / "z.obj"))
    rockvdb.mesh(g, str(tmp_path / "y.obj"), up="y")

    def bounds(path):
        pts = [list(map(float, l.split()[1:4])) for l in path.read_text().splitlines()
               if l.startswith("v ")]
        return [min(p[a] for p in pts) for a in range(3)], [max(p[a] for p in pts) for a in range(3)]
    (zlo, zhi), (ylo, yhi) = bounds(tmp_path / "z.obj"), bounds(tmp_path / "y.obj")
    assert zlo[2] == pytest.approx(2, abs=0.06) and zhi[2] == pytest.approx(4, abs=0.06)
    assert ylo[1] == pytest.approx(zlo[2], abs=1e-5) and yhi[1] == pytest.approx(zhi[2], abs=1e-5)
    assert ylo[2] == pytest.approx(-zhi[1], abs=1e-5) and yhi[2] == pytest.approx(-zlo[1], abs=1e-5)
    with pytest.raises(ValueError, match="up must be one of z, y"):
        rockvdb.mesh(g, str(tmp_path / "x.obj"), up="x")


def test_rock_pile_material_grid_and_default_support_grid(tmp_path):
    tiles = rockvdb.rock_tiles(n=4, voxels_per_cell=4)
    ball = vdb.createLevelSetSphere(0.8, voxelSize=0.05)
    ball.name = "blob"  # not 'surface': the file's only level set is taken
    rockvdb.write(str(tmp_path / "ball.vdb"), [ball])
    surface, rock_id, material = rockvdb.rock_pile(tiles, tmp_path / "ball.vdb", material=3)
    assert material.name == "material" and material.activeVoxelCount() == rock_id.activeVoxelCount()
    assert {it.value for it in material.citerOnValues()} == {3.0}
    assert len(rockvdb.rock_pile(tiles, tmp_path / "ball.vdb")) == 2
    with pytest.raises(ValueError, match="material must be in"):
        rockvdb.rock_pile(tiles, rockvdb.sphere(0.8), material=-5)


def test_preview_palette_and_what_the_image_shows(tmp_path):
    f = rockvdb.sphere(0.6, (-0.7, 0, 0)).tag(1) | rockvdb.sphere(0.6, (0.7, 0, 0)).tag(2)
    surface, ids = f.bake(voxel_size=0.05, attribute="material")
    shown = rockvdb.preview(surface, tmp_path / "p.png", width=160, height=90, ids=ids,
                            palette={1: "#ff0000", 2: "#0000ff"})
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    assert set(shown["ids"]) == {1, 2}
    # Two equal spheres side by side, seen from the default azimuth: similar shares.
    a, b = shown["ids"][1], shown["ids"][2]
    assert a > 0.02 and b > 0.02 and 0.5 < a / b < 2
    assert a + b == pytest.approx(shown["surface"], abs=1e-9)
    with pytest.raises(ValueError, match="ID=#rrggbb"):
        rockvdb.preview(surface, tmp_path / "q.png", ids=ids, palette={1: "red"})


def test_csg_carries_ids_like_the_cli(tmp_path):
    import numpy as np
    from conftest import dense, run, tool
    a = rockvdb.sphere(1.0, (-0.6, 0, 0)).tag(1)
    b = rockvdb.sphere(1.0, (0.6, 0, 0)).tag(2)
    sa, ia = a.bake(voxel_size=0.05, attribute="block_id")
    sb, ib = b.bake(voxel_size=0.05, attribute="block_id")
    surface, (ids,) = rockvdb.csg("union", [sa, sb], ids=[[ia], [ib]])
    assert ids.name == "block_id" and {it.value for it in ids.citerOnValues()} == {1.0, 2.0}
    rockvdb.write(str(tmp_path / "a.vdb"), [sa, ia])
    rockvdb.write(str(tmp_path / "b.vdb"), [sb, ib])
    run([tool("vdb_csg"), "-q", "union", str(tmp_path / "a.vdb"), str(tmp_path / "b.vdb"),
         "-o", str(tmp_path / "u.vdb")], check=True)
    cli = {g.name: g for g in vdb.readAll(str(tmp_path / "u.vdb"))[0]}
    for ours, theirs in ((surface, cli["surface"]), (ids, cli["block_id"])):
        (la, da), (lb, db) = dense(ours), dense(theirs)
        assert la == lb and np.array_equal(da, db)
    assert isinstance(rockvdb.csg("union", [sa, sb]), vdb.FloatGrid)
    with pytest.raises(ValueError, match="one list of id grids per input"):
        rockvdb.csg("union", [sa, sb], ids=[[ia]])
