#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Fractal rocks (fractal-rocks-midpoint-displacement): boulders and pebbles scattered on the
# canyon heightfield by an fBm density map (§1), each resting on the terrain with a sixth of
# it sunk, united with the terrain's level set; a preview tinted by material (
# 4 boulders, 5 pebbles; the terrain carries no id).
# usage: samples/07_fractal_boulders.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.05}"
B="$BUILD/vdbtools"
mkdir -p "$OUT"
# The ground: the 48 x 48 m canyon (0.5 m cells), and its level set to unite with.
"$B/vdb_heightfield" -q samples/data/canyon.exr --cell-size 0.5 --voxel-size "$VOXEL" \
    -o "$OUT/fractal_ground.vdb"
# 60 boulders (rough tops, smooth bottoms), then 300 pebbles of one level (the paper's advice
# for hundreds of small rocks); two scatters do not see each other, so a pebble may touch a
# boulder.
"$B/vdb_fractal_rock" -q --count 60 --ground samples/data/canyon.exr --ground-cell-size 0.5 \
    --size 2.4,1.9,1.3 --levels 2 --h-up 0.55 --h-down 0.9 --density-scale 10 --seed 3 \
    --material 4 --voxel-size "$VOXEL" --points "$OUT/fractal_boulders_pts.vdb" -o - |
"$B/vdb_csg" -q union "$OUT/fractal_ground.vdb" - -o "$OUT/fractal_boulders.vdb"
"$B/vdb_fractal_rock" -q --count 300 --ground samples/data/canyon.exr --ground-cell-size 0.5 \
    --size 0.7,0.55,0.4 --levels 1 --density-scale 6 --seed 4 --material 5 \
    --voxel-size "$VOXEL" -o - |
"$B/vdb_csg" -q union "$OUT/fractal_boulders.vdb" - -o "$OUT/fractal_scene.vdb"
"$B/vdb_preview" "$OUT/fractal_scene.vdb" --ids material \
    --palette '4=#6f6a62,5=#b3a58c' --azimuth 35 --elevation 35 --zoom 1.6 \
    -o "$OUT/fractal_boulders.png"
