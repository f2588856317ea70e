#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Surface detail (implicit-blocks §4.2, Gabor details): a tabular block tile without relief,
# then the gradient warp and anisotropic Gabor ridges following the curvature, with a preview.
# usage: samples/04_detail.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.03}"
mkdir -p "$OUT"
"$BUILD/vdbtools/vdb_blocks" -q --type tabular --tile-size 6 --point-radius 0.3 --seed 4 \
    --warp-amplitude 0 --voxel-size "$VOXEL" -o "$OUT/detail_plain.vdb"
"$BUILD/vdbtools/vdb_detail" "$OUT/detail_plain.vdb" --warp-amplitude 0.03 --warp-scale 0.8 \
    --gabor-amplitude 0.025 --gabor-frequency 5 --direction-curvature --tilt 20,0 \
    -o "$OUT/detail_tabular.vdb"
"$BUILD/vdbtools/vdb_preview" "$OUT/detail_tabular.vdb" --azimuth 35 --elevation 25 --zoom 1.4 \
    -o "$OUT/detail_tabular.png"
