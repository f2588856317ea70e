# SPDX-License-Identifier: Apache-2.0
"""Fractal rocks (fractal-rocks §1-§9): one rock with its mesh, boulders scattered on a
heightfield, and a cave chain carved out of a block.

usage: PYTHONPATH=build/python /usr/bin/python3 samples/py/02_fractal_boulders.py [OUT_DIR]
"""
import os
import sys

import rockvdb

out = sys.argv[1] if len(sys.argv) > 1 else "out"
os.makedirs(out, exist_ok=True)
rock, mesh = rockvdb.fractal_rock(levels=3, size=(1, 0.8, 0.5), seed=2, voxel_size=0.02)
rockvdb.write(os.path.join(out, "py_rock.vdb"), [rock])
ground = rockvdb.heightfield("samples/data/canyon.exr", cell_size=0.5, voxel_size=0.25)
stats = {}
surface, rock_id = rockvdb.fractal_scatter(ground, count=25, size=(1.2, 1, 0.7), levels=2,
                                           voxel_size=0.1, seed=5, stats=stats)
rockvdb.write(os.path.join(out, "py_boulders.vdb"), [surface, rock_id])
block = rockvdb.box((8, 4, 4)).bake(voxel_size=0.1)
carved, cave = rockvdb.fractal_carve(block, count=6, levels=1, carve_start=(-3, 0, 0), seed=1)
rockvdb.write(os.path.join(out, "py_carved.vdb"), [carved, cave])
print(stats["placed"], "of", stats["asked"], "boulders placed")
