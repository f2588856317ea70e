# SPDX-License-Identifier: Apache-2.0
"""A sea cliff amplified with block tiles (implicit blocks §5), then weathered by a gradient
warp and Gabor ridges (gabor-details).

usage: PYTHONPATH=build/python /usr/bin/python3 samples/py/03_cliff.py [OUT_DIR]
"""
import os
import sys

import rockvdb

out = sys.argv[1] if len(sys.argv) > 1 else "out"
os.makedirs(out, exist_ok=True)
tile = rockvdb.block_tile(type="equidimensional", tile_size=10, seed=3, bake=False)
cliff = os.path.join(out, "py_cliff.json")  # a procedural terrain, as vdb_amplify --terrain reads it
with open(cliff, "w") as f:
    f.write('{"type": "sea_cliff", "samples": [81, 61], "cell_size": 0.5, "height": 20}')
stats = {}
surface, block_id, material = rockvdb.amplify(cliff, [tile], voxel_size=0.25, stats=stats)
weathered = rockvdb.detail(surface, warp_amplitude=0.1, warp_scale=3, gabor_amplitude=0.04,
                           gabor_frequency=1)
rockvdb.write(os.path.join(out, "py_cliff.vdb"), [weathered, block_id, material])
print(stats["replicated"], "blocks on the cliff,", weathered.activeVoxelCount(), "active voxels")
