# SPDX-License-Identifier: Apache-2.0
"""Every rockvdb call that takes or returns a grid, in one process: run by test_host.py inside
hosts that loaded OpenVDB before rockvdb (LD_PRELOAD, Blender) and in a plain interpreter;
the reports (voxel counts, hashes of the grids' values) must agree.
usage: host_calls.py OUT_DIR   (writes OUT_DIR/host.json)"""
import hashlib
import json
import os
import sys

import numpy as np

import pyopenvdb as vdb

import rockvdb


def digest(grid):
    """Hash of the grid's values over its active bounding box (and the box itself)."""
    lo, hi = grid.evalActiveVoxelBoundingBox()
    a = np.zeros(tuple(hi[k] - lo[k] + 1 for k in range(3)), dtype=np.float32)
    grid.copyToArray(a, ijk=lo)
    return hashlib.sha1(repr((lo, hi)).encode() + a.tobytes()).hexdigest()


def run(out):
    """Run every call, writing files into out; returns the report dict."""
    report = {}
    tile = rockvdb.block_tile(type="tabular", tile_size=4, point_radius=0.3, voxel_size=0.1, seed=2)
    report["tile_voxels"] = tile.surface.activeVoxelCount()
    detailed = rockvdb.detail(tile.surface, warp_amplitude=0.03, gabor_amplitude=0.03,
                              gabor_frequency=2, direction_axis=(0, 0, 1))
    report["detail_voxels"] = detailed.activeVoxelCount()
    report["detail_digest"] = digest(detailed)
    rockvdb.write(os.path.join(out, "host.vdb"), [detailed, tile.block_id])
    vdb.write(os.path.join(out, "host_pyopenvdb.vdb"), [tile.surface])
    ball = rockvdb.sphere(1.0).bake(voxel_size=0.1)
    u = rockvdb.csg("union", [ball, rockvdb.box((3, 0.5, 0.5)).bake(voxel_size=0.1)])
    report["csg_voxels"] = u.activeVoxelCount()
    rockvdb.mesh(u, os.path.join(out, "host.obj"))
    rockvdb.preview(u, os.path.join(out, "host.png"), width=64, height=48)
    ramp = rockvdb.expression(json.dumps({"type": "plane", "normal": [-0.8, 0, 0.6]})) & \
        rockvdb.box((8, 8, 8))
    terrain = ramp.bake(voxel_size=0.1)
    amp_tile = rockvdb.block_tile(type="equidimensional", tile_size=4, point_radius=0.3,
                                  voxel_size=0.1, seed=3)
    surface, block_id, material = rockvdb.amplify(terrain, [amp_tile], voxel_size=0.1,
                                                  max_slope=1.0, distance_range=(-0.5, 0.5))
    report["amplify_voxels"] = surface.activeVoxelCount()
    report["amplify_digest"] = digest(surface)
    tiles = rockvdb.rock_tiles(n=4, voxels_per_cell=4, cube_size=1.0)
    pile, rock_id = rockvdb.rock_pile(tiles, ball)
    report["pile_voxels"] = pile.activeVoxelCount()
    report["pile_digest"] = digest(pile)
    rock, mesh = rockvdb.fractal_rock(levels=2, voxel_size=0.05, seed=3)
    report["fractal_voxels"] = rock.activeVoxelCount()
    report["fractal_digest"] = digest(rock)
    report["fractal_triangles"] = int(mesh["triangles"].shape[0])
    scatter, _ = rockvdb.fractal_scatter(count=20, levels=1, voxel_size=0.05, area=(-2, -2, 2, 2),
                                         seed=1)
    report["scatter_digest"] = digest(scatter)
    # Material stacks from the mushroom-ish ball on a slab (a grid terrain), saved and read back.
    stacks = rockvdb.Stacks(u, cell_size=0.1, quantum=0.005, floor=-0.5)
    stacks.save(os.path.join(out, "host.stacks"))
    again = rockvdb.Stacks.load(os.path.join(out, "host.stacks"))
    grids = again.bake()
    ground = grids["surface"]
    report["stacks_equal"] = again == stacks
    report["stacks_layers"] = stacks.layer_count
    report["stacks_digest"] = digest(ground)
    report["stacks_grids"] = [g.name for g in grids.values()]
    report["read_back"] = rockvdb.read(os.path.join(out, "host.vdb")).activeVoxelCount()
    report["pyopenvdb_read_back"] = vdb.read(os.path.join(out, "host_pyopenvdb.vdb"),
                                             "surface").activeVoxelCount()
    return report


if __name__ == "__main__":
    out = sys.argv[1]
    report = run(out)
    with open(os.path.join(out, "host.json"), "w") as f:
        json.dump(report, f)
