#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Issue 14: how much of an amplified cliff is made of blocks (implicit-blocks §5).

Four heightfield cliffs (the sea cliff of samples/03_amplify.sh, a straight 10 m cliff, a
butte, samples/data/canyon.exr), one 10 m equidimensional tile (seed 3), 20 cm voxels. For
each, rockvdb.coverage: the share of the steep surface voxels (|n_z| < 0.6, 2 m clear of the
footprint's edges) and of the gentle ones that carry a block id, beside the references in the
same run: the paper-tight presence range (-1, 0.5) with epsilon 0.5 (the previous defaults),
hull-only tiles (--no-fill) at today's defaults, and the carving variant.

usage: PYTHONPATH=build/python /usr/bin/python3 bench/cliff_coverage.py [OUT_DIR]
"""
import os
import sys
import time

import numpy as np

import rockvdb

HERE = os.path.dirname(os.path.abspath(__file__))


def terrains(out):
    """(name, heightfield path, region) for the four cliffs, cell size 0.5 m."""
    n, cell = 121, 0.5
    y, x = np.mgrid[0:n, 0:n] * cell
    coast = 30 + 4 * np.sin(y / 7.0) + 2 * np.sin(y / 2.3 + 1)
    t = np.clip((coast - x) / 8.0 + 0.5, 0, 1)
    sea = os.path.join(out, "coverage_sea_cliff.exr")
    rockvdb.write_heightfield(sea, (25 * t * t * (3 - 2 * t)).astype(np.float32))
    x1 = np.arange(65) * 0.5
    row = np.where(x1 < 14, 10.0, np.where(x1 > 18, 0.0, 10.0 - 2.5 * (x1 - 14)))
    straight = os.path.join(out, "coverage_straight.exr")
    rockvdb.write_heightfield(straight, np.tile(row, (65, 1)).astype(np.float32))
    n = 101
    y, x = np.mgrid[0:n, 0:n] * cell
    r = np.hypot(x - 25, y - 25) + 1.5 * np.sin(np.arctan2(y - 25, x - 25) * 5)
    t = np.clip((14 - r) / 6.0 + 0.5, 0, 1)
    butte = os.path.join(out, "coverage_butte.exr")
    rockvdb.write_heightfield(butte, (18 * t * t * (3 - 2 * t) + 0.05 * x).astype(np.float32))
    canyon = os.path.join(HERE, "..", "samples", "data", "canyon.exr")
    return [("sea cliff (sample 03)", sea, (2, 2, 58, 58)),
            ("straight 10 m cliff", straight, (2, 2, 30, 30)),
            ("butte", butte, (2, 2, 48, 48)),
            ("canyon.exr", canyon, (2, 2, 46, 46))]


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "out"
    os.makedirs(out, exist_ok=True)
    filled = rockvdb.block_tile(type="equidimensional", tile_size=10, seed=3, bake=False)
    hull = rockvdb.block_tile(type="equidimensional", tile_size=10, seed=3, bake=False,
                              fill=False)
    runs = [("defaults", filled, {}),
            ("(-1, 0.5), eps 0.5", filled, {"distance_range": (-1, 0.5), "max_slope": 0.5}),
            ("hull-only tile", hull, {}),
            ("carve 0.1", filled, {"carve": 0.1})]
    print("## amplify: steep surface carrying a block id (gentle in brackets), 10 m "
          "equidimensional tile, 20 cm voxels\n")
    print("| cliff | " + " | ".join(r[0] for r in runs) + " | bake (defaults) |")
    print("|---|" + "---|" * (len(runs) + 1))
    for name, path, region in terrains(out):
        cells, seconds = [], 0.0
        for label, tile, args in runs:
            t0 = time.time()
            s, ids, _ = rockvdb.amplify(path, [tile], cell_size=0.5, voxel_size=0.2, **args)
            if label == "defaults":
                seconds = time.time() - t0
            c = rockvdb.coverage(s, ids, region=region)
            cells.append(f"{c['steep']:.2f} ({c['gentle']:.2f})")
        print(f"| {name} | " + " | ".join(cells) + f" | {seconds:.1f} s |", flush=True)


if __name__ == "__main__":
    main()
