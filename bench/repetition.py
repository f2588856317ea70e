# SPDX-License-Identifier: Apache-2.0
"""Visible repetition of block tiles on a flat wall parallel to the tiling axes (implicit
blocks §6.4; issue 38 item 3's criterion, measured before aperiodic block tiles exist).

A 100 m x 20 m vertical wall (the face x = 0 of a box) amplified with one 10 m block tile: along
horizontal lines on the wall, the block each point of the surface belongs to (block_id: the
block's index in its tile; for aperiodic tiles, an id of the block's region content). The match
rate M(s) is the share of points whose block is the same s metres further along; a tiling that
repeats shows M = 1 at the tile period, against the level of the other shifts (the reference,
same run). Aperiodic rows (vdb_amplify --aperiodic, K colours) also give M at 20 and 30 m and
their time against the periodic tile's (same process).
usage: PYTHONPATH=build/python /usr/bin/python3 bench/repetition.py [BUILD_DIR]"""
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import pyopenvdb as vdb

import rockvdb

BUILD = sys.argv[1] if len(sys.argv) > 1 else "build"
VOXEL, PERIOD = 0.25, 10.0


def wall_ids(tile, tmp, **extra):
    """block_id along the wall's horizontal lines (rows z = 2..18 m): rows x points (-1: bare)."""
    box = os.path.join(tmp, "wall.vdb")
    subprocess.run([os.path.join(BUILD, "vdbtools", "vdb_primitive"), "-q", "box", "--size", "10,100,20",
                    "--center", "-5,50,10", "--voxel-size", str(VOXEL), "-o", box], check=True)
    surface, block_id, _ = rockvdb.amplify(box, [tile], max_slope=0.9, voxel_size=VOXEL, **extra)
    s, b = surface.getConstAccessor(), block_id.getConstAccessor()
    rows = []
    for z in np.arange(2.0, 18.0, 1.0):
        k = int(round(z / VOXEL))
        row = []
        for j in range(int(round(5 / VOXEL)), int(round(95 / VOXEL))):
            ident = -1
            for i in range(int(3 / VOXEL), int(-1 / VOXEL), -1):  # from outside in: the first solid voxel
                if s.getValue((i, j, k)) < 0:
                    ident = int(b.getValue((i, j, k)))
                    break
            row.append(ident)
        rows.append(row)
    return np.array(rows)


def match(ids, shift):
    a, c = ids[:, :-shift], ids[:, shift:]
    valid = (a >= 0) & (c >= 0)
    return float((a[valid] == c[valid]).mean()) if valid.any() else 0.0


def main():
    with tempfile.TemporaryDirectory() as tmp:
        print("| tile | M(period 10 m) | M(20 m) / M(30 m) | M(other shifts 3-28 m): mean / max | amplify time |")
        print("|---|---|---|---|---|")
        p = int(round(PERIOD / VOXEL))
        for kind in ("polyhedral", "tabular"):
            tile = os.path.join(tmp, f"{kind}.tile")
            subprocess.run([os.path.join(BUILD, "vdbtools", "vdb_blocks"), "-q", "--type", kind, "--tile-size",
                            str(PERIOD), "--seed", "3", "--voxel-size", str(VOXEL), "--tile", tile, "-o",
                            os.path.join(tmp, f"{kind}.vdb")], check=True)
            reference = None
            for label, extra in (("periodic", {}), ("aperiodic, K = 2", {"aperiodic": True, "colours": 2}),
                                 ("aperiodic, K = 3", {"aperiodic": True, "colours": 3})):
                if kind == "tabular" and extra.get("colours") == 3:
                    continue
                t0 = time.perf_counter()
                ids = wall_ids(tile, tmp, **extra)
                seconds = time.perf_counter() - t0
                reference = reference or seconds
                others = [match(ids, s) for s in range(int(3 / VOXEL), int(28 / VOXEL))
                          if abs(s % p) > 4 and abs(s % p - p) > 4]
                print(f"| {kind} 10 m, {label} | {match(ids, p):.3f} | {match(ids, 2 * p):.3f} / "
                      f"{match(ids, 3 * p):.3f} | {np.mean(others):.3f} / {np.max(others):.3f} | "
                      f"{seconds:.1f} s ({seconds / reference:.1f}x) |", flush=True)


if __name__ == "__main__":
    main()
