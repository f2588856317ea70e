# SPDX-License-Identifier: Apache-2.0
"""Rocks in contact without simulation (aperiodic rock piles): a tile set of corner cubes, a
pile filling a mound, the instances as points.

usage: PYTHONPATH=build/python /usr/bin/python3 samples/py/04_rock_pile.py [OUT_DIR]
"""
import os
import sys

import rockvdb

out = sys.argv[1] if len(sys.argv) > 1 else "out"
os.makedirs(out, exist_ok=True)
tiles = rockvdb.rock_tiles(n=4, cube_size=1, seed=7, path=os.path.join(out, "py_rocks.tiles.vdb"))
# A flattened dome: a sphere squashed to 45% in z, cut at the ground.
mound = rockvdb.sphere(2.0).transform(scale=(1, 1, 0.45)) & rockvdb.box((6, 6, 2), center=(0, 0, 1))
stats = {}
surface, rock_id = rockvdb.rock_pile(tiles, mound, seed=3, stats=stats)
rockvdb.write(os.path.join(out, "py_pile.vdb"), [surface, rock_id])
print(stats["placed"], "rocks in the pile")
