#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Material-stack terrain (arches-material-stacks-terrain §3, §6): two scenes, each saved as
# stacks and baked as level sets, with previews tinted by material (sand 2, bedrock 3,
# rocks 4), and the strata textured by their weight grids (§6, vdb_preview --texture).
#  - strata: procedural strata under an fBm top; an air stratum whose warped boundaries pinch
#    shut in places leaves overhangs, caves and the pillars between them;
#  - canyon: the canyon heightfield under 1.2 m of sand, stabilised: the sand slides off the
#    walls (steeper than its 33 degrees) into the valley floor, mass kept to the quantum.
# usage: samples/08_arches.sh BUILD_DIR OUT_DIR
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
B="$BUILD/vdbtools"
PALETTE='2=#d9c08c,3=#7b7068,4=#4f4a46'
mkdir -p "$OUT"
"$B/vdb_arches" -q samples/data/arches_strata.json --stacks "$OUT/arches_strata.stacks" \
    -o "$OUT/arches_strata.vdb"
"$B/vdb_preview" -q "$OUT/arches_strata.vdb" --ids material --palette "$PALETTE" \
    --azimuth 210 --elevation 12 --zoom 1.3 --width 640 --height 400 -o "$OUT/arches_strata.png"
# §6: the ground textured by its weight grids (triplanar, p = 8)
"$B/vdb_preview" -q "$OUT/arches_strata.vdb" --texture \
    --azimuth 210 --elevation 12 --zoom 1.3 --width 640 --height 400 -o "$OUT/arches_strata_textured.png"
"$B/vdb_arches" -q samples/data/arches_canyon.json --sigma 0.5 --voxel-size 0.25 \
    --stacks "$OUT/arches_canyon.stacks" -o "$OUT/arches_canyon.vdb"
"$B/vdb_preview" -q "$OUT/arches_canyon.vdb" --ids material --palette "$PALETTE" \
    --azimuth 35 --elevation 40 --zoom 1.2 --width 640 --height 400 -o "$OUT/arches_canyon.png"
