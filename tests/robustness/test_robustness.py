# SPDX-License-Identifier: Apache-2.0
"""Hostile inputs (issue 19): one row per class of bad input, each run against the tools it
reaches. Every row must end with one readable error line (or a clean success), a non-zero exit
code when it fails, no crash, no hang, and nothing written or replaced.

The table is ROWS below: (name, command builder, expected exit code, a needle of the message).
Flipped-byte files are swept separately (FLIP_TOOLS), a fixed seeded set of flips per tool."""
import json
import math
import os
import random
import struct
import signal
import subprocess
import sys
import time
import zlib

import pytest

from conftest import run, tool

HERE = os.path.dirname(os.path.abspath(__file__))
SENTINEL = b"an earlier output that must survive\n"


@pytest.fixture(scope="module")
def valid(tmp_path_factory):
    """A small valid level set (a sphere) and a valid chunk of the same bake for vdb_merge."""
    d = tmp_path_factory.mktemp("valid")
    out = d / "sphere.vdb"
    run([tool("vdb_primitive"), "-q", "sphere", "--radius", "0.5", "--voxel-size", "0.05",
         "-o", str(out)], check=True)
    return out


def flipped(data, k, bit):
    b = bytearray(data)
    b[k] ^= 1 << bit
    return bytes(b)


def check_failure_is_clean(p, out, what):
    """A run that failed: one line on stderr, a usage (2) or runtime (1) exit, not a signal;
    the earlier output intact. A run that succeeded: a real file."""
    assert p.returncode >= 0, f"{what}: killed by signal {-p.returncode}: {p.stderr[-300:]}"
    assert p.returncode in (0, 1, 2), (what, p.returncode, p.stderr[-300:])
    if p.returncode == 0:
        return "read"
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and "error:" in lines[0], (what, p.stderr[-600:])
    assert lines[0].isprintable(), (what, lines[0])
    assert out.read_bytes() == SENTINEL, f"{what}: the earlier output was replaced"
    return "refused"


# Every tool that reads a .vdb, with the arguments around the input and an output path.
FLIP_TOOLS = {
    "vdb_info": lambda f, o: [tool("vdb_info"), f],
    "vdb_mesh": lambda f, o: [tool("vdb_mesh"), "-q", f, "-o", o + ".obj"],
    "vdb_preview": lambda f, o: [tool("vdb_preview"), "-q", f, "--width", "64", "--height", "48",
                                 "-o", o + ".png"],
    "vdb_csg": lambda f, o: [tool("vdb_csg"), "-q", "union", f, f, "-o", o],
    "vdb_detail": lambda f, o: [tool("vdb_detail"), "-q", f, "--warp-amplitude", "0.01", "-o", o],
    "vdb_merge": lambda f, o: [tool("vdb_merge"), "-q", f, "-o", o],
    "vdb_asset": lambda f, o: [tool("vdb_asset"), "-q", f, "--lods", "60", "--texture-size", "32",
                               "-o", o + ".glb"],
}


@pytest.mark.parametrize("name", sorted(FLIP_TOOLS))
def test_a_flipped_byte_never_crashes_a_reading_tool(name, valid, tmp_path):
    """A single flipped bit, in the header and metadata (most sensitive) and anywhere in the
    file: the tool reads the file or refuses it in one line; never a crash or a hang (the
    reader runs isolated under a memory cap, ops/core/VdbIO.cc)."""
    data = valid.read_bytes()
    rng = random.Random(19)
    spots = [rng.randrange(1200) for _ in range(25)] + [rng.randrange(len(data)) for _ in range(15)]
    spots.append(348)  # a metadata string size: garbled, it once asked for 6 GB and 15 s
    seen = {"read": 0, "refused": 0}
    for i, k in enumerate(spots):
        f = tmp_path / "flipped.vdb"
        f.write_bytes(flipped(data, k, rng.randrange(8)))
        out = tmp_path / "out.vdb"
        for ext in ("", ".obj", ".png"):
            (tmp_path / ("out.vdb" + ext)).write_bytes(SENTINEL)
        cmd = FLIP_TOOLS[name](str(f), str(out))
        try:
            p = run(cmd)
        except subprocess.TimeoutExpired:
            pytest.fail(f"{name}: hung on byte {k}")
        target = out if name in ("vdb_csg", "vdb_detail", "vdb_merge") else \
            tmp_path / ("out.vdb.obj" if name == "vdb_mesh" else "out.vdb.png" if name == "vdb_preview" else "out.vdb")
        seen[check_failure_is_clean(p, target, f"{name} byte {k}")] += 1
    assert seen["refused"] > 10, seen  # the sweep reaches the parts that matter


def test_a_garbled_size_is_reported_not_allocated(valid, tmp_path):
    """Byte 348 of this file is inside a metadata string's size: flipped, the reader misreads
    every size after it and once asked for 6 GB over 15 s before failing. The read is capped
    (64x the file, at least 512 MB) and says what is wrong."""
    f = tmp_path / "garbled.vdb"
    f.write_bytes(flipped(valid.read_bytes(), 348, 0))
    p = run([tool("vdb_info"), str(f)])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 1 and len(lines) == 1, p.stderr[-500:]
    assert "a size in it is out of range" in lines[0], lines[0]


def test_python_read_survives_flipped_files_in_one_interpreter(valid, tmp_path):
    """rockvdb.read of 80 flipped files in one interpreter: each is read or raises IOError /
    ValueError with one line; the interpreter lives on (it used to segfault after a raise)."""
    script = f"""
import random, rockvdb
data = open({str(valid)!r}, 'rb').read()
rng = random.Random(5)
read = refused = 0
for t in range(80):
    b = bytearray(data)
    b[rng.randrange(1200) if t % 2 else rng.randrange(len(data))] ^= 1 << rng.randrange(8)
    open({str(tmp_path / 'p.vdb')!r}, 'wb').write(b)
    try:
        rockvdb.read({str(tmp_path / 'p.vdb')!r})
        read += 1
    except (IOError, ValueError) as e:
        assert '\\n' not in str(e) and str(e).isprintable(), str(e)
        refused += 1
print(read, refused)
"""
    p = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    read, refused = map(int, p.stdout.split())
    assert read + refused == 80 and refused > 20
    assert p.stderr == "", p.stderr[-500:]  # nothing from crashed readers leaks out


def png_claiming(width, height):
    """A 16-bit grey PNG header claiming width x height pixels, with a few bytes of data."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 16, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(b"\0" * 4096)) + b"\0" * 300)


def deep_expression(depth):
    return '{"type": "union", "children": [' * depth + '{"type": "sphere", "radius": 1}' + "]}" * depth


def deep_params(depth):
    return '{"voxel-size": ' + "[" * depth + "0.1" + "]" * depth + "}"


# name -> (files to write {name: text}, argv builder (tmp) -> list, exit code, needle)
ROWS = {
    "device as input (/dev/zero)": (
        {}, lambda t: [tool("vdb_info"), "/dev/zero"], 1, "not a regular file"),
    "endless stdin (/dev/zero)": (
        {}, lambda t: ["sh", "-c", f"{tool('vdb_info')} - < /dev/zero"], 1, "not a VDB file"),
    "10 000-level expression": (
        {"deep.json": deep_expression(10000)},
        lambda t: [tool("vdb_primitive"), "expr", str(t / "deep.json"), "--voxel-size", "0.1",
                   "-o", str(t / "out.vdb")], 2, "nested deeper than 200 levels"),
    "10 000-level --params": (
        {"deep_params.json": deep_params(10000)},
        lambda t: [tool("vdb_primitive"), "--params", str(t / "deep_params.json"), "sphere",
                   "-o", str(t / "out.vdb")], 2, "nested deeper than 200 levels"),
    "1e400 in --params": (
        {"huge.json": '{"voxel-size": 1e400}'},
        lambda t: [tool("vdb_primitive"), "--params", str(t / "huge.json"), "sphere",
                   "-o", str(t / "out.vdb")], 2, "number overflow parsing '1e400'"),
    "10 000-level arches edits": (
        {"scene.json": json.dumps({"terrain": {"type": "box", "size": [4, 4, 2]}}),
         "edits.json": "[" * 10000 + "]" * 10000},
        lambda t: [tool("vdb_arches"), str(t / "scene.json"), "--edits", str(t / "edits.json"),
                   "-o", str(t / "out.vdb")], 2, "nested deeper than 200 levels"),
    "--tile and -o the same file": (
        {}, lambda t: [tool("vdb_blocks"), "--tile-size", "4", "--voxel-size", "0.2", "--tile",
                       str(t / "out"), "-o", str(t / "out")], 2, "name the same file"),
    "--library and -o both stdout": (
        {}, lambda t: [tool("vdb_rockpile"), "tiles", "--n", "4", "--library", "-", "-o", "-"], 2,
        "both write to stdout"),
    "--points and -o the same file (through ./)": (
        {}, lambda t: [tool("vdb_fractal_rock"), "--count", "3", "--points", str(t / "." / "out.vdb"),
                       "-o", str(t / "out.vdb")], 2, "name the same file"),
    "--stacks and -o the same file": (
        {"scene.json": json.dumps({"terrain": {"type": "box", "size": [4, 4, 2]}})},
        lambda t: [tool("vdb_arches"), str(t / "scene.json"), "--stacks", str(t / "out"),
                   "--points", str(t / "out"), "-o", str(t / "out.vdb")], 2, "name the same file"),
    "a 346-byte PNG claiming 60000x60000 pixels": (
        {"big.png": png_claiming(60000, 60000)},
        lambda t: [tool("vdb_heightfield"), str(t / "big.png"), "-o", str(t / "out.vdb")], 1,
        "corrupt or truncated image (its header claims 60000x60000 pixels, 7.2 GB"),
    "a noise terrain 4e122 m across": (  # found by fuzz_json (regressions/json/noise-terrain-huge-cell)
        {"huge_cell.json": json.dumps({"type": "noise_terrain", "samples": [9, 9], "cell_size": 4e122,
                                       "amplitude": 2})},
        lambda t: [tool("vdb_primitive"), "expr", str(t / "huge_cell.json"), "-o", str(t / "out.vdb")], 2,
        "extent (samples x cell size) must be <= 1e9 m"),
    "noise octaves of 8.9e116": (  # found by fuzz_json (regressions/json/noise-octaves-huge)
        {"octaves.json": json.dumps({"type": "noise_terrain", "samples": [9, 9], "octaves": 8.9e116})},
        lambda t: [tool("vdb_primitive"), "expr", str(t / "octaves.json"), "-o", str(t / "out.vdb")], 2,
        "at /octaves: expected an integer (got 8.9e+116)"),
    "a polytope of 4000 planes": (
        {"poly.json": json.dumps({"type": "polytope", "planes": [
            [math.cos(k), math.sin(k), math.sin(3 * k), 1.0] for k in range(4000)]})},
        lambda t: [tool("vdb_primitive"), "expr", str(t / "poly.json"), "-o", str(t / "out.vdb")], 2,
        "number of planes must be <= 512"),
    "an authored box 1e6 m wide": (
        {"authored.json": json.dumps([{"type": "box", "center": [0, 0, 0], "size": [1e6, 1e6, 1e6]}])},
        lambda t: [tool("vdb_blocks"), "--authored", str(t / "authored.json"), "-o", str(t / "out.vdb")],
        2, "authored block 0 is 1e+06 m across, wider than the 20 m tile"),
    "rockpile tiles --n 40": (
        {}, lambda t: [tool("vdb_rockpile"), "tiles", "--n", "40", "-o", str(t / "out.vdb")], 2,
        "needs about 737.8 GB, over the"),
    "rockpile tiles over --max-memory": (
        {}, lambda t: [tool("vdb_rockpile"), "tiles", "--n", "8", "--max-memory", "1", "-o",
                       str(t / "out.vdb")], 2, "or raise --max-memory"),
    "a failing second output (--meshes m.stl)": (
        {}, lambda t: [tool("vdb_blocks"), "-q", "--voxel-size", "0.5", "--meshes", str(t / "m.stl"),
                       "-o", str(t / "out.vdb")], 2, "but this writes .obj or .ply"),
    "a sphere 2e8 m away (indices overflow)": (
        {}, lambda t: [tool("vdb_primitive"), "-q", "sphere", "--center", "2e8,0,0", "--voxel-size",
                       "0.1", "-o", str(t / "out.vdb")], 2, "the result is empty"),
}

# name -> (argv builder (tmp, valid sphere) -> list, exit code, needle): rows on a valid file.
ON_VALID = {
    "csg with a 1e308 smooth radius": (
        lambda t, v: [tool("vdb_csg"), "-q", "union", str(v), str(v), "--smooth", "1e308", "-o",
                      str(t / "out.vdb")], 2, "the result is empty"),
    "mesh at an isovalue outside the band": (
        lambda t, v: [tool("vdb_mesh"), "-q", str(v), "--isovalue", "5", "-o", str(t / "out.obj")], 2,
        "no surface at isovalue 5"),
}


@pytest.mark.parametrize("name", sorted(ON_VALID))
def test_hostile_parameters_on_a_valid_file(name, valid, tmp_path):
    argv, code, needle = ON_VALID[name]
    out = tmp_path / "out.vdb"
    out.write_bytes(SENTINEL)
    p = run(argv(tmp_path, valid))
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == code and len(lines) == 1 and needle in lines[0], p.stderr[-500:]
    assert out.read_bytes() == SENTINEL


@pytest.mark.parametrize("name", sorted(ROWS))
def test_hostile_input_row(name, tmp_path):
    files, argv, code, needle = ROWS[name]
    for f, text in files.items():
        (tmp_path / f).write_bytes(text if isinstance(text, bytes) else text.encode())
    out = tmp_path / "out.vdb"
    out.write_bytes(SENTINEL)
    p = run(argv(tmp_path))
    assert p.returncode == code, (p.returncode, p.stderr[-500:])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert len(lines) == 1 and "error:" in lines[0] and needle in lines[0], p.stderr[-500:]
    assert out.read_bytes() == SENTINEL


def test_a_10000_level_pile_support_is_refused(tmp_path):
    tiles = tmp_path / "tiles.vdb"
    run([tool("vdb_rockpile"), "-q", "tiles", "--tiling", "periodic", "--n", "3",
         "--voxels-per-cell", "4", "-o", str(tiles)], check=True)
    (tmp_path / "deep.json").write_text(deep_expression(10000))
    out = tmp_path / "out.vdb"
    out.write_bytes(SENTINEL)
    p = run([tool("vdb_rockpile"), "pile", "--tiles", str(tiles), "--support",
             str(tmp_path / "deep.json"), "-o", str(out)])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 2 and len(lines) == 1, p.stderr[-500:]
    assert "nested deeper than 200 levels" in lines[0]
    assert out.read_bytes() == SENTINEL


def test_a_report_to_a_full_disk_fails_and_json_stays_json(valid, tmp_path):
    """vdb_info > /dev/full used to exit 0; provenance that is not JSON made --json print
    '<discarded>'. Now: exit 1 with one line, and --json is valid JSON holding the text."""
    p = subprocess.run(f"{tool('vdb_info')} {valid} > /dev/full", shell=True, capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 1 and "cannot write to stdout" in p.stderr, p.stderr
    import pyopenvdb as vdb
    g = vdb.read(str(valid), "surface")
    g["rockvdb:params"] = '{"voxel-size": 0.05, "broken'
    odd = tmp_path / "odd.vdb"
    vdb.write(str(odd), [g])
    p = run([tool("vdb_info"), "--json", str(odd)])
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    text = json.dumps(info)
    assert '{\\"voxel-size\\": 0.05, \\"broken' in text, text[:500]


def test_python_deep_json_is_a_value_error():
    import rockvdb
    with pytest.raises(ValueError, match="nested deeper than 200 levels"):
        rockvdb.expression(deep_expression(10000))


def sphere_to(out):
    return run([tool("vdb_primitive"), "-q", "sphere", "--radius", "0.5", "--voxel-size", "0.1",
                "-o", str(out)])


def test_an_output_symlink_is_followed_not_replaced(tmp_path):
    """-o onto a symbolic link writes the file it points to (even a dangling link's) and
    leaves the link a link; a rename over the link used to replace it."""
    target = tmp_path / "real.vdb"
    target.write_bytes(SENTINEL)
    link = tmp_path / "link.vdb"
    link.symlink_to("real.vdb")
    assert sphere_to(link).returncode == 0
    assert link.is_symlink() and target.read_bytes()[:8] == b" BDV\0\0\0\0"
    dangling = tmp_path / "dangling.vdb"
    dangling.symlink_to("made.vdb")
    assert sphere_to(dangling).returncode == 0
    assert dangling.is_symlink() and (tmp_path / "made.vdb").stat().st_size > 1000
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dangling.vdb", "link.vdb", "made.vdb", "real.vdb"]


def test_an_output_device_or_fifo_is_written_through(tmp_path):
    """-o onto a character device or a named pipe writes to it as a stream: the device node
    stays a device (as root a rename replaced /dev/null with a file); a full device fails in
    one line. Tested on device nodes made here, never the system's."""
    import stat
    import threading
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo, "rb").read()))
    reader.start()
    assert sphere_to(fifo).returncode == 0
    reader.join(60)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and got and got[0][:8] == b" BDV\0\0\0\0"
    if os.geteuid() != 0:
        pytest.skip("device nodes need root")
    null, full = tmp_path / "null", tmp_path / "full"
    os.mknod(null, stat.S_IFCHR | 0o666, os.makedev(1, 3))
    os.mknod(full, stat.S_IFCHR | 0o666, os.makedev(1, 7))
    assert sphere_to(null).returncode == 0
    assert stat.S_ISCHR(os.lstat(null).st_mode)
    p = sphere_to(full)
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 1 and len(lines) == 1 and "No space left on device" in lines[0], p.stderr
    assert stat.S_ISCHR(os.lstat(full).st_mode)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["full", "null", "pipe"]  # no temporaries


# A full disk, simulated with RLIMIT_FSIZE (writes past 64 KB fail with EFBIG; SIGXFSZ is
# ignored so the write returns the error): every Python writer raises OSError, keeps the
# previous file as it was and leaves no temporary behind.
PY_WRITERS = {
    "write": "rockvdb.write(out, [big])",
    "rock_tiles(path=)": "rockvdb.rock_tiles(path=out, n=4)",
    "write_heightfield": "rockvdb.write_heightfield(out + '.exr', numpy.random.rand(200, 200))",
    "mesh": "rockvdb.mesh(big, out + '.obj')",
    "BlockTile.save": "rockvdb.block_tile(bake=False, tile_size=8).save(out + '.tile')",
}
PY_FULL_DISK = """
import os, resource, signal, sys
import numpy
import rockvdb
out = sys.argv[1]
big = rockvdb.sphere(1.0).bake(voxel_size=0.02)
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (65536, resource.RLIM_INFINITY))
try:
    {call}
except OSError as e:
    print("OSError", e)
    sys.exit(0)
print("no error")
sys.exit(1)
"""


@pytest.mark.parametrize("name", sorted(PY_WRITERS))
def test_a_python_writer_on_a_full_disk_raises_and_keeps_the_old_file(name, tmp_path):
    out = tmp_path / "out.vdb"
    targets = [out] + [tmp_path / ("out.vdb" + ext) for ext in (".exr", ".obj", ".tile")]
    for t in targets:
        t.write_bytes(SENTINEL)
    p = subprocess.run([sys.executable, "-c", PY_FULL_DISK.format(call=PY_WRITERS[name]), str(out)],
                       capture_output=True, text=True, timeout=300, env=os.environ)
    assert p.returncode == 0 and p.stdout.startswith("OSError"), (p.stdout, p.stderr[-800:])
    assert "cannot write" in p.stdout, p.stdout
    assert all(t.read_bytes() == SENTINEL for t in targets)
    assert sorted(os.listdir(tmp_path)) == sorted(t.name for t in targets)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """Inputs of the memory and time rows that need files made by the tools."""
    d = tmp_path_factory.mktemp("scene")
    run([tool("vdb_blocks"), "-q", "--voxel-size", "0.5", "--tile", str(d / "eq.tile"), "-o",
         str(d / "eq.vdb")], check=True)
    run([tool("vdb_rockpile"), "-q", "tiles", "--n", "4", "-o", str(d / "tiles.vdb")], check=True)
    run([tool("vdb_primitive"), "-q", "sphere", "--radius", "0.01", "--voxel-size", "0.0005", "-o",
         str(d / "fine.vdb")], check=True)
    run([tool("vdb_primitive"), "-q", "sphere", "--radius", "500", "--voxel-size", "10", "-o",
         str(d / "coarse.vdb")], check=True)
    # A terrain 2800 km across on voxels 200 km apart.
    run([tool("vdb_primitive"), "-q", "sphere", "--radius", "1e6", "--voxel-size", "2e5", "-o",
         str(d / "far_voxels.vdb")], check=True)
    # A 'level set' with active tiles (fast sweeping would voxelise 6.9e12 voxels).
    subprocess.run([sys.executable, "-c", (
        "import pyopenvdb as vdb, sys\n"
        "g = vdb.FloatGrid(0.3); g.gridClass = vdb.GridClass.LEVEL_SET; g.name = 'surface'\n"
        "g.transform = vdb.createLinearTransform(0.1)\n"
        "g.fill((0, 0, 0), (40959, 40959, 4095), -0.3, True)\n"
        "vdb.write(sys.argv[1], [g])\n"), str(d / "tiles_terrain.vdb")], check=True)
    (d / "far.json").write_text(json.dumps({"type": "sphere", "center": [1e8, 0, 0], "radius": 2}))
    (d / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n")
    # Found by fuzz_mesh (regressions/mesh/ply-face-count-huge; its first byte picks the format).
    src = os.path.join(os.path.dirname(__file__), "..", "fuzz", "regressions", "mesh",
                       "ply-face-count-huge")
    (d / "huge_face.ply").write_bytes(open(src, "rb").read()[1:])
    (d / "blend.json").write_text(json.dumps({"gabor_amplitude": 0.04}))
    subprocess.run([sys.executable, "-c", (
        "import json, sys, pyopenvdb as vdb\n"
        "d = sys.argv[1]\n"
        # Blend masks of 5, -3 and NaN over the fine sphere.
        "for name, v in (('five', 5.0), ('minus', -3.0), ('nan', float('nan'))):\n"
        "    g = vdb.FloatGrid(0.0); g.name = 'mask'; g.transform = vdb.createLinearTransform(0.0005)\n"
        "    g.fill((-5, -5, -5), (5, 5, 5), v, True)\n"
        "    vdb.write(d + '/mask_' + name + '.vdb', [g])\n"
        # A tile set whose description says n = 5 where the grid was made with n = 4.
        "rho = vdb.read(d + '/tiles.vdb', 'rho')\n"
        "meta = json.loads(rho['rockvdb:tiles']); meta['params']['n'] = 5\n"
        "rho['rockvdb:tiles'] = json.dumps(meta)\n"
        "vdb.write(d + '/tiles_edited.vdb', [rho])\n"
        # Two chunks of one grid that differ by one float step at one voxel.
        "a = vdb.read(d + '/fine.vdb', 'surface'); b = a.deepCopy()\n"
        "acc = b.getAccessor(); v = acc.getValue((20, 0, 0))\n"
        "import numpy; acc.setValueOn((20, 0, 0), float(numpy.nextafter(numpy.float32(v), numpy.float32(1))))\n"
        "vdb.write(d + '/chunk_a.vdb', [a]); vdb.write(d + '/chunk_b.vdb', [b])\n"),
        str(d)], check=True)
    return d


# name -> (argv builder (tmp, scene) -> list, exit code, needle): rows on files the tools made.
ON_SCENE = {
    "csg onto a 20 000x finer first input": (
        lambda t, d: [tool("vdb_csg"), "union", str(d / "fine.vdb"), str(d / "coarse.vdb"), "-o",
                      str(t / "out.vdb")], 2, "input 2 (voxel size 10 m) on the first input's voxel "
        "size 0.0005 m needs about 1.2 PB"),
    "a 500-byte truncated second input": (
        lambda t, d: ["sh", "-c", f"head -c 500 {d / 'coarse.vdb'} > {t / 'trunc.vdb'} && "
                      f"{tool('vdb_csg')} union {d / 'fine.vdb'} {t / 'trunc.vdb'} -o {t / 'out.vdb'}"],
        1, "truncated or corrupt VDB file"),
    "amplify a terrain with active tiles": (
        lambda t, d: [tool("vdb_amplify"), "--terrain", str(d / "tiles_terrain.vdb"), "--tiles",
                      str(d / "eq.tile"), "-o", str(t / "out.vdb")], 2,
        "its 100 active tiles count at their full voxel count"),
    "amplify a terrain on voxels 200 km apart": (
        lambda t, d: [tool("vdb_amplify"), "--terrain", str(d / "far_voxels.vdb"), "--tiles",
                      str(d / "eq.tile"), "-o", str(t / "out.vdb")], 2, "over the presence table's 5e7"),
    "a pile support at x = 1e8": (
        lambda t, d: [tool("vdb_rockpile"), "pile", "--tiles", str(d / "tiles.vdb"), "--support",
                      str(d / "far.json"), "-o", str(t / "out.vdb")], 2,
        "the support reaches 1e+08 m from the origin"),
    # Messages that misled.
    "bounds of 1e30 m are not 'unbounded'": (
        lambda t, d: [tool("vdb_primitive"), "box", "--size", "1e30,1,1", "-o", str(t / "out.vdb")], 2,
        "the field's bounds reach 5e+29 m from the origin"),
    "an OBJ index counts from 1": (
        lambda t, d: [tool("vdb_rockpile"), "pile", "--tiles", str(d / "tiles.vdb"), "--support",
                      str(d / "bad.obj"), "-o", str(t / "out.vdb")], 2,
        "bad.obj:4: vertex index 99 out of range (3 vertices, counted from 1)"),
    "a PLY face announcing 2e9 vertices": (
        lambda t, d: [tool("vdb_rockpile"), "pile", "--tiles", str(d / "tiles.vdb"), "--support",
                      str(d / "huge_face.ply"), "-o", str(t / "out.vdb")], 2,
        "huge_face.ply: malformed PLY face 0: it announces 1950000000 vertices (at most 1000)"),
    "a blend mask of 5": (
        lambda t, d: [tool("vdb_detail"), str(d / "fine.vdb"), "--blend", str(d / "blend.json"),
                      "--blend-mask", str(d / "mask_five.vdb"), "-o", str(t / "out.vdb")], 2,
        "blend mask 'mask' holds 5 at voxel"),
    "a blend mask of -3": (
        lambda t, d: [tool("vdb_detail"), str(d / "fine.vdb"), "--blend", str(d / "blend.json"),
                      "--blend-mask", str(d / "mask_minus.vdb"), "-o", str(t / "out.vdb")], 2,
        "blend mask 'mask' holds -3 at voxel"),
    "a blend mask of NaN": (
        lambda t, d: [tool("vdb_detail"), str(d / "fine.vdb"), "--blend", str(d / "blend.json"),
                      "--blend-mask", str(d / "mask_nan.vdb"), "-o", str(t / "out.vdb")], 2,
        "blend mask 'mask' holds nan at voxel"),
    "tile metadata with an edited n": (
        lambda t, d: [tool("vdb_rockpile"), "pile", "--tiles", str(d / "tiles_edited.vdb"), "--support",
                      str(d / "far.json"), "-o", str(t / "out.vdb")], 1,
        "the metadata was edited or belongs to another grid"),
}


def test_a_merge_mismatch_prints_two_different_numbers(scene, tmp_path):
    """The values once printed as '0.28841 vs 0.28841': nine digits tell any two floats apart."""
    p = run([tool("vdb_merge"), str(scene / "chunk_a.vdb"), str(scene / "chunk_b.vdb"), "-o",
             str(tmp_path / "out.vdb")])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 2 and len(lines) == 1 and "chunks disagree" in lines[0], p.stderr
    a, b = lines[0].split("): ")[1].split(" (")[0].split(" vs ")
    assert a != b and float(a) != float(b)


def test_python_nan_is_a_value_error_naming_the_parameter():
    sys.path.insert(0, os.path.join(os.environ["ROCKVDB_BUILD"], "python"))
    import rockvdb
    with pytest.raises(ValueError, match=r"^block_tile: tile_size must be finite \(got nan\)$"):
        rockvdb.block_tile(bake=False, tile_size=float("nan"))
    with pytest.raises(ValueError, match=r"fractal_rock: .* must be finite \(got inf\)"):
        rockvdb.fractal_rock(voxel_size=float("inf"))


@pytest.mark.parametrize("name", sorted(ON_SCENE))
def test_memory_and_time_are_estimated_first(name, scene, tmp_path):
    argv, code, needle = ON_SCENE[name]
    out = tmp_path / "out.vdb"
    out.write_bytes(SENTINEL)
    p = run(argv(tmp_path, scene))
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == code and len(lines) == 1 and needle in lines[0], p.stderr[-800:]
    assert out.read_bytes() == SENTINEL


def test_a_heightfield_of_1e9_m_cells_bakes_at_once(tmp_path):
    """--cell-size 1e-9 once searched 1e8 rings of cells per voxel: now the search ends at
    the grid's edge and the (thin column) terrain bakes in well under a second."""
    import numpy
    sys.path.insert(0, os.path.join(os.environ["ROCKVDB_BUILD"], "python"))
    import rockvdb
    rockvdb.write_heightfield(str(tmp_path / "h.exr"), numpy.random.RandomState(1).rand(64, 64))
    p = run([tool("vdb_heightfield"), "-q", str(tmp_path / "h.exr"), "--cell-size", "1e-9", "-o",
             str(tmp_path / "out.vdb")])
    assert p.returncode == 0, p.stderr
    import pyopenvdb
    g = pyopenvdb.read(str(tmp_path / "out.vdb"), "surface")
    assert g.activeVoxelCount() > 0


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_a_signal_during_the_writes_replaces_nothing(tmp_path, sig):
    """All outputs of a run land together: with -o a FIFO nobody reads, the run blocks in its
    last step, writing; a signal then must leave the other output (--tile, a regular file)
    as it was, remove its temporary and exit 130 within a second or so."""
    import signal
    import time
    fifo = tmp_path / "fifo.vdb"
    os.mkfifo(fifo)
    tile = tmp_path / "t.tile"
    tile.write_bytes(SENTINEL)
    p = subprocess.Popen([tool("vdb_blocks"), "-q", "--voxel-size", "0.5", "--tile", str(tile), "-o",
                          str(fifo)], stderr=subprocess.PIPE)
    # Wait until the tile's temporary is on disk: the run is then at its writes.
    deadline = time.monotonic() + 120
    while not [f for f in os.listdir(tmp_path) if ".tmp-" in f] and time.monotonic() < deadline:
        assert p.poll() is None, p.stderr.read()
        time.sleep(0.02)
    time.sleep(0.2)
    t0 = time.monotonic()
    p.send_signal(getattr(signal, sig))
    _, err = p.communicate(timeout=30)
    assert p.returncode == 130 and time.monotonic() - t0 < 2.0, (p.returncode, err)
    assert tile.read_bytes() == SENTINEL
    assert sorted(os.listdir(tmp_path)) == ["fifo.vdb", "t.tile"]


def test_a_file_name_that_is_not_utf8_is_written_and_read(tmp_path):
    """Found by fuzz_json (regressions/json/provenance-invalid-utf8): provenance embeds file
    names, and a Latin-1 name made every tool fail with a raw JSON type error. Names are bytes
    on Linux: they are written and read, the provenance holds U+FFFD where a byte is not UTF-8."""
    name = os.fsencode(str(tmp_path)) + b"/caf\xe9.vdb"
    p = run([tool("vdb_primitive"), "-q", "sphere", "--radius", "0.5", "--voxel-size", "0.1", "-o", name])
    assert p.returncode == 0 and os.path.exists(name), p.stderr
    out = os.fsencode(str(tmp_path)) + b"/u\xfe.vdb"
    p = run([tool("vdb_csg"), "-q", "union", name, name, "-o", out])
    assert p.returncode == 0, p.stderr
    p = run([tool("vdb_info"), "--json", out])
    assert p.returncode == 0, p.stderr
    info = json.loads(p.stdout)
    assert "caf\ufffd.vdb" in json.dumps(info, ensure_ascii=False)


def test_an_exr_whose_offsets_point_past_the_end_is_refused(tmp_path):
    """Found by fuzz_image (regressions/image/exr-seek-past-end): a corrupt line-offset table
    made OpenEXR seek to 2^64 - 1 and our in-memory stream's bounds check wrapped around.
    Now the read fails with one line and the output is untouched."""
    src = os.path.join(os.path.dirname(__file__), "..", "fuzz", "regressions", "image",
                       "exr-seek-past-end")
    h = tmp_path / "h.exr"
    h.write_bytes(open(src, "rb").read())
    out = tmp_path / "out.vdb"
    out.write_bytes(SENTINEL)
    p = run([tool("vdb_heightfield"), "-q", str(h), "-o", str(out)])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode != 0 and len(lines) == 1 and "h.exr" in lines[0], p.stderr[-800:]
    assert out.read_bytes() == SENTINEL


def test_a_nameless_level_set_is_found_not_recursed(tmp_path):
    """Found by fuzz_vdb (regressions/vdb/nameless-level-set): a file whose only level set has
    no name made the default look-up ('surface', else the only level set) call itself by that
    empty name for ever: a stack overflow in every tool reading it. Now the grid is used."""
    import pyopenvdb
    g = pyopenvdb.createLevelSetSphere(1.0, voxelSize=0.1)
    g.name = ""
    pyopenvdb.write(str(tmp_path / "nameless.vdb"), [g])
    sys.path.insert(0, os.path.join(os.environ["ROCKVDB_BUILD"], "python"))
    import rockvdb
    got = rockvdb.read(str(tmp_path / "nameless.vdb"))
    assert got.activeVoxelCount() == g.activeVoxelCount() > 0
    assert got.evalActiveVoxelBoundingBox() == g.evalActiveVoxelBoundingBox()


def test_a_newer_format_version_is_refused_and_nothing_reaches_stdout(valid, tmp_path):
    """A flipped bit in the format version (224 -> 480): OpenVDB reads on after a warning that
    its log prints on stdout, into a pipeline's data. Refused in one line, stdout empty, in a
    tool writing to stdout and in Python."""
    f = tmp_path / "v480.vdb"
    f.write_bytes(flipped(valid.read_bytes(), 9, 0))
    env = dict(os.environ, PYTHONPATH=os.path.join(os.environ["ROCKVDB_BUILD"], "python"))
    for argv in ([tool("vdb_csg"), "-q", "union", str(f), str(valid), "-o", "-"],
                 [sys.executable, "-c", "import rockvdb, sys\ntry:\n    rockvdb.read(sys.argv[1])\n"
                  "except OSError as e:\n    sys.exit(str(e))\n", str(f)]):
        p = subprocess.run(argv, capture_output=True, env=env, timeout=60)
        lines = [l for l in p.stderr.decode().splitlines() if l.strip()]
        assert p.returncode == 1 and len(lines) == 1 and not p.stdout, (p.stdout[:200], p.stderr)
        assert "format version 480 is newer than this OpenVDB reads (224 or earlier)" in lines[0]


ENDLESS = os.path.join(os.path.dirname(__file__), "..", "fuzz", "regressions", "vdb", "endless-read")


def test_a_file_that_loops_the_reader_is_refused_after_its_cpu_budget(tmp_path):
    """Found by fuzz_vdb (regressions/vdb/endless-read, its format version since set back to
    224, which newer versions are refused before reading): a garbled count made OpenVDB's
    reader loop for ever, and every reading tool hung. The check's child process now has a
    CPU budget (10 s for a small file): one line, nothing on stdout, nothing left running."""
    t0 = time.monotonic()
    p = run([tool("vdb_info"), ENDLESS])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 1 and len(lines) == 1, p.stderr
    assert "was still reading its 1086 bytes after 10 s" in lines[0]
    assert not p.stdout and time.monotonic() - t0 < 30


def test_ctrl_c_stops_a_looping_read_at_once_in_the_cli_and_in_python(tmp_path):
    """Ctrl-C during that read: the tool exits 130 within a second (its watchdog) and the
    check's child dies with it; Python raises KeyboardInterrupt within a second (the read
    asks the interpreter for signals while it waits)."""
    sys.path.insert(0, os.path.join(os.environ["ROCKVDB_BUILD"], "python"))
    env = dict(os.environ, PYTHONPATH=os.path.join(os.environ["ROCKVDB_BUILD"], "python"))
    for argv in ([tool("vdb_info"), ENDLESS],
                 [sys.executable, "-c", "import rockvdb, sys\n"
                  "try:\n    rockvdb.read(sys.argv[1])\n"
                  "except KeyboardInterrupt:\n    sys.exit(42)\n", ENDLESS]):
        p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True)
        # Wait for the check's child to be reading (the interpreter and the import first).
        deadline, kids = time.monotonic() + 60, []
        while not kids and time.monotonic() < deadline:
            assert p.poll() is None, p.stderr.read()
            time.sleep(0.1)
            kids = [int(c) for c in open(f"/proc/{p.pid}/task/{p.pid}/children").read().split()]
        assert kids, "no check child is reading"
        time.sleep(0.3)
        t0 = time.monotonic()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=30)
        assert time.monotonic() - t0 < 1.0, err
        assert p.returncode == (130 if argv[0] != sys.executable else 42), err
        time.sleep(0.2)
        for k in kids:
            try:
                state = open(f"/proc/{k}/stat").read().rsplit(")", 1)[1].split()[0]
            except OSError:
                continue
            assert state == "Z", f"the check child {k} outlived its parent ({state})"
