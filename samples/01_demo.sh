#!/usr/bin/env bash
# Demo: a small rocky scene (fBm terrain + five warped boulders, smooth-unioned, each with
# its id) baked to a level set with a block_id grid, then a shaded preview tinted by id.
# usage: samples/01_demo.sh BUILD_DIR OUT_DIR
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
HERE="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$OUT"
"$BUILD/vdbtools/vdb_primitive" --voxel-size 0.05 --seed 1 -o "$OUT/demo.vdb" \
    expr "$HERE/demo_scene.json" --attribute block_id
"$BUILD/vdbtools/vdb_preview" "$OUT/demo.vdb" --ids block_id --azimuth 225 --elevation 35 \
    --zoom 1.5 -o "$OUT/demo.png"
"$BUILD/vdbtools/vdb_info" "$OUT/demo.vdb"
