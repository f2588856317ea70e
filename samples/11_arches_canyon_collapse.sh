#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# A canyon whose cliffs shed rocks and sand (arches §4.4; Fig. 22): the canyon heightfield under
# a thin sand cover; collapse erosion bites into its cliffs in four places, turning the bedrock
# there into rocks (75%) and sand that the stabilisation carries down into piles at the cliffs'
# feet, and a surface erosion weathers a stretch of rim into sand. Writes
# arches_canyon_collapse.vdb (+ .stacks) and a preview tinted by material.
# usage: samples/11_arches_canyon_collapse.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.25}"
B="$BUILD/vdbtools"
mkdir -p "$OUT"
"$B/vdb_arches" -q samples/data/arches_canyon_collapse.json --voxel-size "$VOXEL" \
    --stacks "$OUT/arches_canyon_collapse.stacks" -o "$OUT/arches_canyon_collapse.vdb"
"$B/vdb_preview" -q "$OUT/arches_canyon_collapse.vdb" --ids material \
    --palette '2=#d9c08c,3=#7b7068,4=#4f4a46' --azimuth 35 --elevation 40 --zoom 1.4 \
    --width 800 --height 450 -o "$OUT/arches_canyon_collapse.png"
