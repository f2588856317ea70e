#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# A deep ravine swept with a non-convex profile, with eroded rocks at its bottom (arches §4.2,
# §4.4; Fig. 11): strata under a gently rolling top; a crack along a bent path, its profile a
# wide mouth over a ledge and undercut walls (overhangs inside the ravine), projected on the
# ground; two collapses of its walls drop rocks and sand to the bottom, a surface erosion
# weathers a stretch of its rim. Writes arches_ravine.vdb (+ .stacks) and a preview tinted by
# material (sand, bedrock, rocks).
# usage: samples/10_arches_ravine.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.25}"
B="$BUILD/vdbtools"
mkdir -p "$OUT"
"$B/vdb_arches" -q samples/data/arches_ravine.json --voxel-size "$VOXEL" \
    --stacks "$OUT/arches_ravine.stacks" -o "$OUT/arches_ravine.vdb"
"$B/vdb_preview" -q "$OUT/arches_ravine.vdb" --ids material --palette '2=#d9c08c,3=#7b7068,4=#4f4a46' \
    --azimuth 300 --elevation 35 --zoom 2.2 --width 800 --height 450 -o "$OUT/arches_ravine.png"
