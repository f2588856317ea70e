# SPDX-License-Identifier: Apache-2.0
"""Makes the small inputs the README's commands use (committed beside this script; run it
again to rebuild them): a canyon heightfield and a rock relief image (float EXR), and a
closed boulder mesh (OBJ). The JSON inputs next to them are written by hand.
usage: PYTHONPATH=build/python /usr/bin/python3 samples/data/make_data.py [OUT_DIR]"""
import json
import os
import sys

import numpy as np

import rockvdb

out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))

# canyon.exr: 97 x 97 samples (0.5 m apart: 48 m square), a river canyon along y with 60-80
# degree walls, 18 m deep, metres (EXR values are metres before --height-scale).
n, cell = 97, 0.5
y, x = np.mgrid[0:n, 0:n] * cell
centre = 24 + 3 * np.sin(y / 6.0)
d = np.abs(x - centre)
t = np.clip((d - 5) / 5, 0, 1)
z = 18 * t * t * (3 - 2 * t) + 0.3 * np.sin(x * 1.3) * np.cos(y * 0.9)
rockvdb.write_heightfield(os.path.join(out, "canyon.exr"), z.astype(np.float32))

# relief.exr: 128 x 128 rock relief in [0, 1] (crossed ridges and pits), tiling seamlessly.
u, v = np.mgrid[0:128, 0:128] * (2 * np.pi / 128)
r = (0.5 + 0.25 * np.sin(3 * u + np.sin(2 * v)) * np.cos(5 * v)
     + 0.15 * np.sin(11 * u + 7 * v) + 0.1 * np.cos(17 * v - 5 * u))
r = (r - r.min()) / (r.max() - r.min())
rockvdb.write_heightfield(os.path.join(out, "relief.exr"), r.astype(np.float32))

# boulder.obj: a closed, warped boulder 2.4 m long standing on z = 0 (z up).
boulder = (rockvdb.box((2.4, 1.6, 1.4), center=(0, 0, 0.7), rounding=0.4)
           .warp(0.15, frequency=0.8, seed=5))
rockvdb.mesh(boulder.bake(voxel_size=0.08), os.path.join(out, "boulder.obj"), adaptivity=0.3)
print("wrote canyon.exr, relief.exr and boulder.obj to", out)
