# SPDX-License-Identifier: Apache-2.0
"""A periodic tile of tabular blocks (implicit blocks §4), baked over 2 x 1 x 1 periods with its
block ids, and a preview tinted by block.

usage: PYTHONPATH=build/python /usr/bin/python3 samples/py/01_block_tile.py [OUT_DIR]
"""
import os
import sys

import rockvdb

out = sys.argv[1] if len(sys.argv) > 1 else "out"
os.makedirs(out, exist_ok=True)
stats = {}
tile = rockvdb.block_tile(type="tabular", tile_size=10, seed=4, voxel_size=0.2, periods=(2, 1, 1),
                          stats=stats)
rockvdb.write(os.path.join(out, "py_blocks.vdb"), [tile.surface, tile.block_id])
tile.save(os.path.join(out, "py_blocks.tile"))  # vdb_amplify --tiles reads it
rockvdb.preview(tile.surface, os.path.join(out, "py_blocks.png"), ids=tile.block_id, width=480,
                height=270)
print(len(tile.blocks), "blocks,", stats["bake"]["active_voxels"], "active voxels")
