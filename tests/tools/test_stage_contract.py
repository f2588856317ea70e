# SPDX-License-Identifier: Apache-2.0
"""The stage contract (issue 15): one parameter table per stage drives the CLI and Python, so
both give the same grids for the same call (and for no call at all beyond the required
inputs); a file's own rockvdb:params replays it bit for bit; unknown keys are errors naming
the key; Ctrl-C / SIGTERM stop a tool within a second with exit 130 and nothing written, and
raise KeyboardInterrupt in Python; the progress bar only goes up and ends at 100%."""
import json
import os
import pty
import re
import signal
import subprocess
import sys
import time

import pyopenvdb as vdb
import pytest

import rockvdb
from conftest import assert_bitwise_equal, one_line_error, run, tool


def grids(path):
    """{name: grid} of a .vdb (every grid, metadata included)."""
    return {g.name: g for g in vdb.readAll(str(path))[0]}


def assert_same_file(a, b, skip_meta=()):
    """Two .vdb files hold the same grids: names, classes, bit-identical voxels and the same
    rockvdb metadata (provenance included)."""
    ga, gb = grids(a), grids(b)
    assert sorted(ga) == sorted(gb)
    for name in ga:
        x, y = ga[name], gb[name]
        assert x.gridClass == y.gridClass and x.background == y.background
        if hasattr(x, "copyToArray") and x.activeVoxelCount() > 0:
            assert_bitwise_equal(x, y)
        else:
            assert x.activeVoxelCount() == y.activeVoxelCount()
        for key in x.metadata.keys():
            if key.startswith("rockvdb:") and key not in skip_meta:
                assert x.metadata[key] == y.metadata[key], (name, key)


def params_of(path, grid):
    return json.loads(vdb.read(str(path), grid).metadata["rockvdb:params"])


# ---- rock piles ------------------------------------------------------------------------------

TILES = {"n": 4, "voxels-per-cell": 5, "seed": 3, "anisotropy": [2.0, 1.0, 1.0]}


@pytest.fixture(scope="module")
def tile_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("tiles") / "t.vdb"
    args = []
    for k, v in TILES.items():
        args += [f"--{k}", ",".join(map(str, v)) if isinstance(v, list) else str(v)]
    run([tool("vdb_rockpile"), "tiles", "-q", *args, "-o", str(out)], check=True)
    return out


def test_rock_tiles_cli_and_python_give_the_same_file(tmp_path, tile_file):
    kwargs = {k.replace("-", "_"): v for k, v in TILES.items()}
    rockvdb.rock_tiles(**kwargs, path=tmp_path / "py.vdb")
    assert_same_file(tile_file, tmp_path / "py.vdb")


def test_rock_tiles_defaults_are_the_same_on_both_interfaces(tmp_path):
    """Nothing but the output: the CLI's defaults and Python's are the table's."""
    run([tool("vdb_rockpile"), "tiles", "-q", "--tiling", "periodic", "--n", "3",
         "-o", str(tmp_path / "cli.vdb")], check=True)
    rockvdb.rock_tiles(tiling="periodic", n=3, path=tmp_path / "py.vdb")
    assert_same_file(tmp_path / "cli.vdb", tmp_path / "py.vdb")
    p = params_of(tmp_path / "cli.vdb", "rho")["tiles"]
    # Every row of the table is recorded, at the table's default where not given.
    table = json.loads(rockvdb._rockvdb.schema("rock_tiles"))["params"]
    assert sorted(p) == sorted(r["name"] for r in table)
    for r in table:
        if r["name"] not in ("tiling", "n"):
            assert p[r["name"]] == r["default"], r["name"]


def test_rock_pile_cli_and_python_give_the_same_file(tmp_path, tile_file):
    support = tmp_path / "ball.json"
    support.write_text(json.dumps({"type": "sphere", "center": [0.1, 0, 0], "radius": 0.83}))
    run([tool("vdb_rockpile"), "pile", "-q", "--tiles", str(tile_file), "--support", str(support),
         "--material", "4", "-o", str(tmp_path / "cli.vdb")], check=True)
    surface, rock_id, material = rockvdb.rock_pile(str(tile_file), str(support), material=4)
    rockvdb.write(str(tmp_path / "py.vdb"), [surface, rock_id, material])
    assert_same_file(tmp_path / "cli.vdb", tmp_path / "py.vdb")
    assert params_of(tmp_path / "py.vdb", "surface")["pile"]["support"] == str(support)


@pytest.mark.parametrize("sub, grid", [("tiles", "rho"), ("pile", "surface")])
def test_a_file_replays_from_its_own_provenance(tmp_path, tile_file, sub, grid):
    if sub == "tiles":
        first = tile_file
    else:
        support = tmp_path / "ball.json"
        support.write_text(json.dumps({"type": "sphere", "radius": 0.7}))
        first = tmp_path / "pile.vdb"
        run([tool("vdb_rockpile"), "pile", "-q", "--tiles", str(tile_file), "--support",
             str(support), "--threshold", "0.4", "--keep-deep", "-o", str(first)], check=True)
    prov = tmp_path / "prov.json"
    prov.write_text(vdb.read(str(first), grid).metadata["rockvdb:params"])
    again = tmp_path / "again.vdb"
    # The subcommand comes from the file too.
    run([tool("vdb_rockpile"), "-q", "--params", str(prov), "-o", str(again)], check=True)
    assert_same_file(first, again)


@pytest.mark.parametrize("params, message", [
    ({"tiles": {"voxels_per_cell": 5}},
     "unknown --params key 'tiles.voxels_per_cell' (did you mean 'tiles.voxels-per-cell'?)"),
    ({"tiles": {"n": 4, "erosion-step": 2}},
     "unknown --params key 'tiles.erosion-step' (did you mean 'tiles.erosion-steps'?)"),
    ({"tiles": {"n": "four"}}, 'rockpile: n must be an integer (got "four")'),
    ({"pile": {"treshold": 0.3}}, "unknown --params key 'pile.treshold' (did you mean 'pile.threshold'?)"),
])
def test_misspelt_params_keys_name_the_key(tmp_path, params, message):
    p = tmp_path / "p.json"
    p.write_text(json.dumps(params))
    out = tmp_path / "o.vdb"
    one_line_error(run([tool("vdb_rockpile"), "--params", str(p), "-o", str(out)]), 2, message)
    assert not out.exists()


def test_python_keywords_are_the_tables_and_misspellings_name_the_key():
    import inspect
    sig = inspect.signature(rockvdb.rock_tiles)
    table = json.loads(rockvdb._rockvdb.schema("rock_tiles"))["params"]
    for r in table:
        d = sig.parameters[r["python"]].default
        assert (list(d) if isinstance(d, tuple) else d) == r["default"]
        assert r["python"] in rockvdb.rock_tiles.__doc__
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'voxel_per_cell' "
                                        r"\(did you mean 'voxels_per_cell'\?\)"):
        rockvdb.rock_tiles(voxel_per_cell=4)
    with pytest.raises(TypeError, match=r"rock_tiles\(\): n must be an integer, got str"):
        rockvdb.rock_tiles(n="5")
    with pytest.raises(ValueError, match=r"rockpile: erosion_rate must be in \(0, 1\] \(got 0.0\)"):
        rockvdb.rock_tiles(erosion_rate=0.0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'treshold'"):
        rockvdb.rock_pile("t.vdb", rockvdb.sphere(1), treshold=0.4)


# ---- surface detail ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def ball_vdb(tmp_path_factory):
    out = tmp_path_factory.mktemp("detail") / "ball.vdb"
    run([tool("vdb_primitive"), "-q", "--voxel-size", "0.04", "-o", str(out), "sphere",
         "--radius", "1"], check=True)
    return out


@pytest.mark.parametrize("args", [
    [],  # defaults only: a plain renormalised re-bake
    ["--warp-amplitude", "0.05", "--gabor-amplitude", "0.03", "--direction-curvature",
     "--seed", "5", "--half-width", "4"],
])
def test_detail_cli_and_python_give_the_same_grid(tmp_path, ball_vdb, args):
    run([tool("vdb_detail"), "-q", str(ball_vdb), *args, "-o", str(tmp_path / "cli.vdb")],
        check=True)
    kwargs, i = {}, 0
    while i < len(args):
        key = args[i][2:].replace("-", "_")
        if i + 1 < len(args) and not args[i + 1].startswith("--"):
            kwargs[key] = float(args[i + 1]) if "." in args[i + 1] else int(args[i + 1])
            i += 2
        else:
            kwargs[key] = True
            i += 1
    py = rockvdb.detail(vdb.read(str(ball_vdb), "surface"), **kwargs)
    cli = vdb.read(str(tmp_path / "cli.vdb"), "surface")
    assert_bitwise_equal(py, cli)
    pa, pc = (json.loads(g.metadata["rockvdb:params"]) for g in (py, cli))
    # The same record but for the CLI's file names.
    assert {k: v for k, v in pc.items() if k not in ("input", "grid")} == pa


def test_detail_replays_from_its_own_provenance(tmp_path, ball_vdb):
    first = tmp_path / "d.vdb"
    run([tool("vdb_detail"), "-q", str(ball_vdb), "--gabor-amplitude", "0.03",
         "--direction-axis", "1,0,0", "--seed", "2", "-o", str(first)], check=True)
    prov = tmp_path / "prov.json"
    prov.write_text(vdb.read(str(first), "surface").metadata["rockvdb:params"])
    run([tool("vdb_detail"), "-q", "--params", str(prov), "-o", str(tmp_path / "again.vdb")],
        check=True)
    assert_same_file(first, tmp_path / "again.vdb")


def test_detail_records_a_skeleton_file_by_content(tmp_path, ball_vdb):
    skeleton = tmp_path / "skel.json"
    skeleton.write_text(json.dumps({"segments": [{"a": [0, 0, -1], "b": [0, 0, 1], "radius": 2}]}))
    first = tmp_path / "d.vdb"
    run([tool("vdb_detail"), "-q", str(ball_vdb), "--gabor-amplitude", "0.03",
         "--direction-skeleton", str(skeleton), "-o", str(first)], check=True)
    prov = json.loads(vdb.read(str(first), "surface").metadata["rockvdb:params"])
    assert prov["direction-skeleton"]["segments"][0]["radius"] == 2
    skeleton.unlink()  # the replay needs only the file's own provenance (and its input)
    (tmp_path / "prov.json").write_text(json.dumps(prov))
    run([tool("vdb_detail"), "-q", "--params", str(tmp_path / "prov.json"), "-o",
         str(tmp_path / "again.vdb")], check=True)
    assert_same_file(first, tmp_path / "again.vdb")


def test_detail_keywords_are_the_tables():
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'gabor_amplitde' "
                                        r"\(did you mean 'gabor_amplitude'\?\)"):
        rockvdb.detail(vdb.FloatGrid(), gabor_amplitde=0.1)
    with pytest.raises(ValueError, match="give one of direction_axis"):
        rockvdb.detail(rockvdb.sphere(1).bake(voxel_size=0.1), direction_axis=(1, 0, 0),
                       direction_curvature=True)


# ---- block tiles -----------------------------------------------------------------------------

def test_block_tile_defaults_are_the_same_on_both_interfaces(tmp_path):
    """No parameter at all: a 20 m equidimensional tile at 5 cm, seed 0, on both interfaces
    (Python's seed used to default to 1 and the CLI's to 0)."""
    run([tool("vdb_blocks"), "-q", "-o", str(tmp_path / "cli.vdb")], check=True)
    t = rockvdb.block_tile()
    rockvdb.write(str(tmp_path / "py.vdb"), [t.surface, t.block_id])
    assert_same_file(tmp_path / "cli.vdb", tmp_path / "py.vdb")


SMALL_BLOCKS = ["--type", "tabular", "--tile-size", "8", "--point-radius", "0.4", "--seed", "4",
                "--warp-amplitude", "0.03", "--voxel-size", "0.08", "--periods", "2,1,1"]


def test_block_tile_cli_and_python_give_the_same_file(tmp_path):
    run([tool("vdb_blocks"), "-q", *SMALL_BLOCKS, "-o", str(tmp_path / "cli.vdb")], check=True)
    t = rockvdb.block_tile(type="tabular", tile_size=8, point_radius=0.4, seed=4,
                           warp_amplitude=0.03, voxel_size=0.08, periods=(2, 1, 1))
    rockvdb.write(str(tmp_path / "py.vdb"), [t.surface, t.block_id])
    assert_same_file(tmp_path / "cli.vdb", tmp_path / "py.vdb")
    # A saved tile baked again from Python (BlockTile.bake) and from the CLI (--from-tile).
    t.save(str(tmp_path / "t.tile"))
    u = rockvdb.load_tile(str(tmp_path / "t.tile"))
    s, ids = u.bake(voxel_size=0.08, periods=(2, 1, 1))
    assert_bitwise_equal(s, t.surface)
    with pytest.raises(ValueError, match="too coarse"):
        u.bake(voxel_size=0.6)  # the guard holds on every interface


def test_block_tile_replays_from_its_own_provenance(tmp_path):
    first = tmp_path / "b.vdb"
    fractures = tmp_path / "f.json"
    fractures.write_text(json.dumps([{"center": [4, 4, 4], "normal": [1, 1, 0], "radius": 3}]))
    run([tool("vdb_blocks"), "-q", *SMALL_BLOCKS, "--fractures", str(fractures), "-o",
         str(first)], check=True)
    prov = json.loads(vdb.read(str(first), "surface").metadata["rockvdb:params"])
    assert prov["fractures"][0]["radius"] == 3  # the content, not the path: replays anywhere
    fractures.unlink()
    (tmp_path / "prov.json").write_text(json.dumps(prov))
    run([tool("vdb_blocks"), "-q", "--params", str(tmp_path / "prov.json"), "-o",
         str(tmp_path / "again.vdb")], check=True)
    assert_same_file(first, tmp_path / "again.vdb")


# ---- terrain amplification -----------------------------------------------------------------

@pytest.fixture(scope="module")
def cliff(tmp_path_factory):
    """A 10 m cliff (EXR heights in metres, 1 m cells) and a 10 m block tile."""
    import numpy as np
    d = tmp_path_factory.mktemp("cliff")
    x = np.arange(41, dtype=np.float32)
    h = 10 * np.clip((20 - x) / 4 + 0.5, 0, 1)
    rockvdb.write_heightfield(str(d / "cliff.exr"), np.tile(h, (41, 1)))
    run([tool("vdb_blocks"), "-q", "--tile-size", "10", "--point-radius", "0.5",
         "--voxel-size", "0.25", "--seed", "3", "-o", str(d / "eq.vdb"), "--tile",
         str(d / "eq.tile")], check=True)
    return d


@pytest.mark.parametrize("args, kwargs", [
    ([], {}),  # nothing but the required inputs
    (["--max-slope", "0.7", "--distance-range=-2,2", "--carve", "0.1", "--voxel-size", "0.1",
      "--roi", "0,0,-5,30,40,20"],
     {"max_slope": 0.7, "distance_range": (-2, 2), "carve": 0.1, "voxel_size": 0.1,
      "roi": (0, 0, -5, 30, 40, 20)}),
])
def test_amplify_cli_and_python_give_the_same_file(tmp_path, cliff, args, kwargs):
    terrain, tile = str(cliff / "cliff.exr"), str(cliff / "eq.tile")
    run([tool("vdb_amplify"), "-q", "--terrain", terrain, "--tiles", tile, *args, "-o",
         str(tmp_path / "cli.vdb")], check=True)
    stats = {}
    grids = rockvdb.amplify(terrain, [tile], stats=stats, **kwargs)
    assert stats["replicated"] > 20
    rockvdb.write(str(tmp_path / "py.vdb"), list(grids))
    assert_same_file(tmp_path / "cli.vdb", tmp_path / "py.vdb")


def test_amplify_replays_from_its_own_provenance(tmp_path, cliff):
    first = tmp_path / "a.vdb"
    strata = tmp_path / "strata.json"
    strata.write_text(json.dumps({"layers": [{"tile": "eq", "top": 4}, {"tile": "eq"}]}))
    run([tool("vdb_amplify"), "-q", "--terrain", str(cliff / "cliff.exr"), "--tiles",
         str(cliff / "eq.tile"), "--strata", str(strata), "--voxel-size", "0.1", "-o",
         str(first)], check=True)
    prov = json.loads(vdb.read(str(first), "surface").metadata["rockvdb:params"])
    assert prov["strata"]["layers"][0]["top"] == 4  # the content, not the path
    strata.unlink()
    (tmp_path / "prov.json").write_text(json.dumps(prov))
    run([tool("vdb_amplify"), "-q", "--params", str(tmp_path / "prov.json"), "-o",
         str(tmp_path / "again.vdb")], check=True)
    assert_same_file(first, tmp_path / "again.vdb")


# ---- Ctrl-C and SIGTERM ---------------------------------------------------------------------

LONG_RUNS = {
    # Each takes several seconds on a 2-core machine (so 0.5 s in is mid-run).
    "rockpile tiles": lambda tmp, tile_file: [tool("vdb_rockpile"), "tiles", "--n", "6",
                                              "--seeds-per-cell", "1,3"],
    "rockpile pile": lambda tmp, tile_file: [tool("vdb_rockpile"), "pile", "--tiles",
                                             str(tile_file), "--support", str(big_ball(tmp)),
                                             "--keep-deep"],
    "blocks": lambda tmp, tile_file: [tool("vdb_blocks"), "--voxel-size", "0.04"],
    "amplify": lambda tmp, tile_file: [tool("vdb_amplify"), "--terrain", str(big_cliff(tmp)),
                                       "--tiles", str(big_cliff(tmp).with_suffix(".tile")),
                                       "--voxel-size", "0.03"],
    "detail": lambda tmp, tile_file: [tool("vdb_detail"), str(fine_ball(tmp)),
                                      "--gabor-amplitude", "0.02", "--gabor-frequency", "8"],
    "fractal rock": lambda tmp, tile_file: [tool("vdb_fractal_rock"), "--levels", "4",
                                            "--voxel-size", "0.004"],
    "fractal scatter": lambda tmp, tile_file: [tool("vdb_fractal_rock"), "--count", "600",
                                               "--levels", "2", "--area", "-10,-10,10,10",
                                               "--size", "0.6,0.5,0.35", "--voxel-size", "0.02"],
    "arches": lambda tmp, tile_file: [tool("vdb_arches"), str(arches_scene(tmp))],
}

ARCHES_TERRAIN = {"type": "strata", "samples": [300, 240], "base": 14, "amplitude": 9,
                  "layers": [{"material": "bedrock", "thickness": 6},
                             {"material": "sand", "thickness": 1.5},
                             {"material": "air", "thickness": 2},
                             {"material": "bedrock", "thickness": 40}]}


def arches_scene(tmp, samples=(300, 240)):
    """A strata terrain with an overhang band: ~3 s to bake at 1 m on 2 cores."""
    path = tmp / f"arches{samples[0]}.json"
    terrain = dict(ARCHES_TERRAIN, samples=list(samples))
    path.write_text(json.dumps({"terrain": terrain, "cell-size": 1.0}))
    return path


def big_cliff(tmp):
    import numpy as np
    path = tmp / "bigcliff.exr"
    if not path.exists():
        x = np.arange(41, dtype=np.float32)
        rockvdb.write_heightfield(str(path), np.tile(10 * np.clip((20 - x) / 4 + 0.5, 0, 1), (41, 1)))
        run([tool("vdb_blocks"), "-q", "--tile-size", "10", "--point-radius", "0.5",
             "--voxel-size", "0.25", "-o", str(tmp / "t.vdb"), "--tile",
             str(path.with_suffix(".tile"))], check=True)
    return path


def fine_ball(tmp):
    path = tmp / "fine.vdb"
    if not path.exists():
        run([tool("vdb_primitive"), "-q", "--voxel-size", "0.01", "-o", str(path), "sphere",
             "--radius", "1.5"], check=True)
    return path


def medium_ball(tmp):
    """The Python detail call's input: detail's band widening (tools::dilateSdf, no interrupter)
    grows with the band's voxels; on the 1 cm ball it alone ran 4.8 s in a loaded clean-clone
    CI run, on this 1.5 cm ball 0.8-1.6 s, while the whole call still takes seconds."""
    path = tmp / "medium.vdb"
    if not path.exists():
        run([tool("vdb_primitive"), "-q", "--voxel-size", "0.015", "-o", str(path), "sphere",
             "--radius", "1.5"], check=True)
    return path


def big_ball(tmp):
    path = tmp / "big.json"
    path.write_text(json.dumps({"type": "sphere", "radius": 3.5}))
    return path


@pytest.mark.parametrize("what", sorted(LONG_RUNS))
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupt_stops_within_a_second_and_writes_nothing(tmp_path, tile_file, what, sig):
    out = tmp_path / "out.vdb"
    out.write_bytes(b"previous output")
    args = LONG_RUNS[what](tmp_path, tile_file) + ["-o", str(out)]
    p = subprocess.Popen(args, stderr=subprocess.PIPE)
    time.sleep(0.5)
    assert p.poll() is None, "finished before the interrupt: make the run longer"
    t0 = time.monotonic()
    p.send_signal(sig)
    _, err = p.communicate(timeout=30)
    took = time.monotonic() - t0
    assert p.returncode == 130, err
    assert took < 1.0, took
    assert b"interrupted; nothing written" in err
    assert out.read_bytes() == b"previous output"
    assert not [f for f in os.listdir(tmp_path) if ".tmp-" in f]


@pytest.mark.parametrize("args", [
    ["vdb_detail", "BALL", "--gabor-amplitude", "0.03"],
    ["vdb_blocks", "--voxel-size", "0.1"],
    ["vdb_amplify", "--terrain", "CLIFF", "--tiles", "TILE", "--voxel-size", "0.1"],
    ["vdb_fractal_rock", "--levels", "3", "--voxel-size", "0.01", "--normal-map", "N_EXR"],
    ["vdb_fractal_rock", "--count", "100", "--levels", "1", "--voxel-size", "0.03"],
    ["vdb_arches", "ARCHES"],
])
def test_progress_only_goes_up_and_ends_at_100_for(tmp_path, ball_vdb, cliff, args):
    swap = {"BALL": str(ball_vdb), "CLIFF": str(cliff / "cliff.exr"), "TILE": str(cliff / "eq.tile"),
            "N_EXR": str(tmp_path / "n.exr"), "ARCHES": str(arches_scene(tmp_path, (80, 60)))}
    args = [swap.get(a, a) for a in args]
    seen = progress_of([tool(args[0]), *args[1:], "-o", str(tmp_path / "o.vdb")])
    assert len(seen) >= 3 and seen == sorted(seen) and seen[-1] == 100, seen


PY_INTERRUPT = """
import os, signal, sys, threading, time
import rockvdb
threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
t0 = time.monotonic()
try:
    {call}
except KeyboardInterrupt:
    took = time.monotonic() - t0 - 0.5
    print("KeyboardInterrupt", took)
    sys.exit(0)
print("finished", time.monotonic() - t0)
"""


@pytest.mark.parametrize("call", [
    "rockvdb.rock_tiles(n=6, seeds_per_cell=(1, 3))",
    "rockvdb.rock_pile(sys.argv[1], rockvdb.sphere(3.5), keep_deep=True)",
    "rockvdb.detail(rockvdb.read(sys.argv[2]), gabor_amplitude=0.02, gabor_frequency=8)",
    "rockvdb.block_tile(voxel_size=0.04)",
    "rockvdb.fractal_rock(levels=4, voxel_size=0.004)",
    "rockvdb.fractal_scatter(count=600, levels=2, area=(-10, -10, 10, 10), voxel_size=0.02)",
    "rockvdb.Stacks.from_scene(sys.argv[3]).bake()",
    # A long stroke (592 points, ~2 s): the edit itself is interrupted.
    "rockvdb.Stacks.from_scene(sys.argv[3]).sculpt([[x / 2, 120, 14] for x in range(4, 596)], "
    "radius=12, mode='carve')",
])
def test_python_calls_raise_keyboard_interrupt(tmp_path, tile_file, call):
    script = tmp_path / "s.py"
    script.write_text(PY_INTERRUPT.format(call=call))
    p = subprocess.run([sys.executable, str(script), str(tile_file), str(medium_ball(tmp_path)),
                        str(arches_scene(tmp_path))],
                       capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    word, took = p.stdout.split()
    assert word == "KeyboardInterrupt", p.stdout
    # No watchdog in Python (a host such as Blender must never be killed): phases without a
    # check (OpenVDB's fast sweeping and gradient in detail's band widening: 0.8-1.6 s on the
    # medium ball under a loaded CTest) run to their end first. A call that
    # ignored the interrupt would print "finished" above; this bound is a sanity check.
    assert float(took) < 4.0


# ---- progress --------------------------------------------------------------------------------

def progress_of(args):
    """Run under a pseudo-terminal (the bar shows only on a terminal); the percentages drawn."""
    master, slave = pty.openpty()
    p = subprocess.Popen(args, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=slave)
    os.close(slave)
    data = b""
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:
            break
        if not chunk:
            break
        data += chunk
    assert p.wait(timeout=120) == 0
    os.close(master)
    return [int(x) for x in re.findall(rb"\] +(\d+)%", data)]


def test_progress_only_goes_up_and_ends_at_100(tmp_path, tile_file):
    for args in (["tiles", "--n", "5", "--library", str(tmp_path / "lib.vdb")],
                 ["pile", "--tiles", str(tile_file), "--support", str(big_ball(tmp_path))]):
        seen = progress_of([tool("vdb_rockpile"), *args, "-o", str(tmp_path / "o.vdb")])
        assert len(seen) >= 5, seen
        assert seen == sorted(seen), seen
        assert seen[-1] == 100, seen
