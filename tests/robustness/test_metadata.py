# SPDX-License-Identifier: Apache-2.0
"""Hostile metadata inside valid files (issue 40): a flipped bit in rockvdb's own metadata of a
tile file, a rock tile set, a .stacks file or a chunk manifest, against every tool and Python
reader that reads it. Each run reads the file or refuses it in one line naming the file; never
a crash, a hang, more than 5 s or more than 512 MB (what a garbled count once asked for:
~3.9 GB over 10 s), and nothing written.

The flips are seeded: the same bytes every run. Where a file carries a checksum (.stacks) half
the flips recompute it, so the content checks behind it are swept too."""
import json
import os
import random
import struct
import subprocess
import sys
import time
import zlib

import pytest

from conftest import run, tool

SENTINEL = b"an earlier output that must survive\n"
SECONDS, MEGABYTES = 5.0, 512
FLIPS = 40


def metadata_span(data, key):
    """(start, end) of the JSON text of string metadata @a key in a .vdb's bytes, with the
    4-byte length before it (the length's own bits are swept too)."""
    k = data.find(key.encode())
    assert k > 0, key
    start = data.find(b"{", k)
    n = struct.unpack("<I", data[start - 4:start])[0]
    return start - 4, start + n


def stacks_fixup(data):
    """The .stacks bytes with their checksum recomputed (a consistent hostile file): FNV-1a 64
    as StackFile.cc computes it (its offset basis is 1469598103934665603, one digit short of
    FNV's 14695981039346656037: the format's own constant)."""
    h = 1469598103934665603
    for b in data[:-8]:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return data[:-8] + struct.pack("<Q", h)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("meta")
    q = ["-q"]
    run([tool("vdb_blocks"), *q, "--tile-size", "6", "--point-radius", "0.5", "--voxel-size", "0.2",
         "-o", str(d / "tile.vdb"), "--tile", str(d / "tile.tile")], check=True)
    run([tool("vdb_rockpile"), *q, "tiles", "--tiling", "periodic", "--n", "3",
         "--voxels-per-cell", "4", "-o", str(d / "rocks.vdb")], check=True)
    run([tool("vdb_arches"), *q, "--terrain",
         '{"type": "noise_terrain", "samples": [16, 16], "cell_size": 0.5, "amplitude": 2}',
         "--stacks", str(d / "s.stacks"), "-o", str(d / "arches.vdb")], check=True)
    # Two chunks of one bake and their manifest, as rockvdb.distributed writes it.
    entries = []
    for i in range(2):
        name = f"chunk_{i:05d}.vdb"
        run([tool("vdb_blocks"), *q, "--tile-size", "6", "--point-radius", "0.5", "--voxel-size", "0.2",
             "--chunks", "2x1x1", "--chunk", f"{i}/2", "-o", str(d / name)], check=True)
        data = (d / name).read_bytes()
        entries.append({"index": i, "file": name, "crc32": zlib.crc32(data), "bytes": len(data)})
    (d / "manifest.json").write_text(json.dumps({"format": "rockvdb-chunks", "version": 1,
                                                 "count": 2, "files": entries}))
    (d / "terrain.json").write_text(json.dumps({"type": "noise_terrain", "samples": [12, 12],
                                                "cell_size": 0.5, "amplitude": 1.5}))
    (d / "support.json").write_text(json.dumps({"type": "sphere", "center": [0.5, 0.5, 0.5],
                                                "radius": 0.4}))
    return d


def spans(kind, files):
    """(source file, suffix, byte ranges to sweep) of a file kind."""
    if kind == "tile":
        data = (files / "tile.vdb").read_bytes()
        return files / "tile.vdb", ".vdb", [metadata_span(data, "rockvdb:tile")]
    if kind == "tile json":
        return files / "tile.tile", ".tile", [(0, (files / "tile.tile").stat().st_size)]
    if kind == "rock tile set":
        data = (files / "rocks.vdb").read_bytes()
        return files / "rocks.vdb", ".vdb", [metadata_span(data, "rockvdb:tiles")]
    if kind == "stacks":
        data = (files / "s.stacks").read_bytes()
        params = struct.unpack("<I", data[12:16])[0]
        return files / "s.stacks", ".stacks", [(8, 16 + params + 8 + 40 + 8)]  # the header
    if kind == "manifest":
        return files / "manifest.json", ".json", [(0, (files / "manifest.json").stat().st_size)]
    raise KeyError(kind)


def flipped_copies(kind, files, folder):
    """FLIPS copies of the file, each with one seeded bit flipped in its metadata."""
    src, suffix, ranges = spans(kind, files)
    data = src.read_bytes()
    rng = random.Random(40 + sum(map(ord, kind)))
    out = []
    for t in range(FLIPS):
        lo, hi = ranges[rng.randrange(len(ranges))]
        k = rng.randrange(lo, hi)
        bit = rng.randrange(8)
        if t % 2:
            # Every other flip turns a digit into another digit: the text stays valid JSON
            # and a count, a size or a coordinate changes (up to 9x, or 10^k for a leading
            # digit) — what only the value checks catch.
            digits = [i for i in range(lo, hi) if 48 <= data[i] <= 57]
            if digits:
                k = digits[rng.randrange(len(digits))]
                bit = rng.choice([c for c in range(4) if 48 <= data[k] ^ (1 << c) <= 57])
        b = bytearray(data)
        b[k] ^= 1 << bit
        if kind == "stacks" and t % 4 >= 2:
            b = bytearray(stacks_fixup(bytes(b)))
        # A manifest lists its chunks relative to its folder: keep it beside them.
        path = (files if kind == "manifest" else folder) / f"flip_{kind.replace(' ', '_')}_{t}{suffix}"
        path.write_bytes(bytes(b))
        out.append((k, path))
    return out


# kind -> {reader name: argv builder (input, output)}
READERS = {
    "tile": {
        "vdb_blocks --from-tile": lambda f, o, d: [tool("vdb_blocks"), "-q", "--from-tile", f,
                                                   "--voxel-size", "0.2", "-o", o],
        "vdb_amplify --tiles": lambda f, o, d: [tool("vdb_amplify"), "-q", "--terrain",
                                                str(d / "terrain.json"), "--tiles", f,
                                                "--voxel-size", "0.25", "-o", o],
    },
    "tile json": {
        "vdb_blocks --from-tile": lambda f, o, d: [tool("vdb_blocks"), "-q", "--from-tile", f,
                                                   "--voxel-size", "0.2", "-o", o],
    },
    "rock tile set": {
        "vdb_rockpile pile": lambda f, o, d: [tool("vdb_rockpile"), "-q", "pile", "--tiles", f,
                                              "--support", str(d / "support.json"), "-o", o],
    },
    "stacks": {
        "vdb_arches --from-stacks": lambda f, o, d: [tool("vdb_arches"), "-q", "--from-stacks", f,
                                                     "-o", o],
    },
    "manifest": {
        "vdb_merge --manifest": lambda f, o, d: [tool("vdb_merge"), "-q", "--manifest", f, "-o", o],
    },
}
CASES = [(kind, name) for kind in READERS for name in READERS[kind]]


PEAK = os.path.join(os.path.dirname(os.path.abspath(__file__)), "peak.py")


def measured(cmd, report):
    """Run @a cmd through peak.py: (exit code or -signal, stderr text, seconds, peak resident
    MB of the command alone), @a report the scratch file for peak.py's numbers."""
    t0 = time.monotonic()
    p = subprocess.run([sys.executable, PEAK, str(report), *cmd], stdout=subprocess.DEVNULL,
                       stderr=subprocess.PIPE, timeout=600)
    seconds = time.monotonic() - t0
    r = json.loads(report.read_text())
    return r["rc"], p.stderr.decode(errors="replace"), seconds, r["mb"]


@pytest.mark.parametrize("kind, name", CASES, ids=[f"{k}: {n}" for k, n in CASES])
def test_a_flipped_bit_in_metadata_is_read_or_refused_in_one_line(kind, name, files, tmp_path):
    seen = {"read": 0, "refused": 0}
    for k, f in flipped_copies(kind, files, tmp_path):
        out = tmp_path / "out.vdb"
        out.write_bytes(SENTINEL)
        rc, err, seconds, mb = measured(READERS[kind][name](str(f), str(out), files),
                                        tmp_path / "peak.json")
        what = f"{name} on {kind} byte {k}"
        assert rc >= 0, f"{what}: killed by signal {-rc}: {err[-300:]}"
        assert seconds <= SECONDS, f"{what}: {seconds:.1f} s"
        assert mb <= MEGABYTES, f"{what}: {mb:.0f} MB"
        if rc == 0:
            seen["read"] += 1
            continue
        lines = [l for l in err.splitlines() if l.strip()]
        assert rc in (1, 2) and len(lines) == 1 and "error:" in lines[0], (what, rc, err[-600:])
        assert lines[0].isprintable(), (what, lines[0])
        assert f.name in lines[0] or kind == "stacks" and "stacks" in lines[0], (what, lines[0])
        assert out.read_bytes() == SENTINEL, f"{what}: the earlier output was replaced"
        seen["refused"] += 1
    print(kind, name, seen)
    assert seen["refused"] >= 3, seen  # the sweep reaches values that matter


PY_READERS = {
    "tile": "rockvdb.load_tile(path)",
    "tile json": "rockvdb.load_tile(path)",
    "rock tile set": "rockvdb.rock_library(vdb.read(path, 'rho'))",
    "stacks": "rockvdb.Stacks.load(path)",
}


@pytest.mark.parametrize("kind", sorted(PY_READERS))
def test_python_readers_survive_flipped_metadata(kind, files, tmp_path):
    """rockvdb's Python readers on the same flips, in one interpreter: each reads or raises
    IOError / ValueError in one line, within 5 s; the interpreter stays under 512 MB."""
    paths = [str(p) for _, p in flipped_copies(kind, files, tmp_path)]
    script = f"""
import json, sys, time
import pyopenvdb as vdb
import rockvdb
read = refused = 0
for path in {paths!r}:
    t0 = time.monotonic()
    try:
        {PY_READERS[kind]}
        read += 1
    except (IOError, ValueError) as e:
        assert '\\n' not in str(e) and str(e).isprintable(), str(e)
        refused += 1
    assert time.monotonic() - t0 <= {SECONDS}, (path, time.monotonic() - t0)
print(json.dumps({{"read": read, "refused": refused}}))
"""
    report = tmp_path / "peak.json"
    p = subprocess.run([sys.executable, PEAK, str(report), sys.executable, "-c", script],
                       capture_output=True, text=True, timeout=600)
    peak = json.loads(report.read_text())
    assert peak["rc"] == 0, p.stderr[-2000:]
    r = json.loads(p.stdout.splitlines()[-1])
    assert r["refused"] >= 3 and peak["mb"] <= MEGABYTES, (r, peak)


def test_a_corrupt_tile_names_the_file_the_key_and_the_value(files, tmp_path):
    """The message the issue asks for: file, key path and value, exit 1, nothing written."""
    tile = json.loads((files / "tile.tile").read_text())
    tile["blocks"][1]["planes"] = tile["blocks"][1]["planes"] * 200  # 800+ planes
    (tmp_path / "t.tile").write_text(json.dumps(tile))
    out = tmp_path / "o.vdb"
    p = run([tool("vdb_blocks"), "--from-tile", str(tmp_path / "t.tile"), "--voxel-size", "0.2",
             "-o", str(out)])
    lines = [l for l in p.stderr.splitlines() if l.strip()]
    assert p.returncode == 1 and len(lines) == 1, p.stderr
    assert f"corrupt tile file '{tmp_path / 't.tile'}': blocks[1].planes has" in lines[0], lines[0]
    assert "entries (expected 1 to 512)" in lines[0] and not out.exists()
    # A bound 4e9 m away, in a .vdb's metadata: the key path starts at rockvdb:tile.
    tile = json.loads((files / "tile.tile").read_text())
    tile["blocks"][2]["bounds"][1][0] = 4.0e9
    script = (f"import pyopenvdb as vdb, json\n"
              f"g = vdb.read({str(files / 'tile.vdb')!r}, 'surface')\n"
              f"g['rockvdb:tile'] = {json.dumps(json.dumps(tile))}\n"
              f"vdb.write({str(tmp_path / 'b.vdb')!r}, [g])\n")
    subprocess.run([sys.executable, "-c", script], check=True)
    p = run([tool("vdb_blocks"), "--from-tile", str(tmp_path / "b.vdb"), "--voxel-size", "0.2",
             "-o", str(out)])
    assert p.returncode == 1, p.stderr
    assert "rockvdb:tile.blocks[2].bounds[1][0] has value 4000000000" in p.stderr, p.stderr
    assert not out.exists()
