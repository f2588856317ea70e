#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Fractured block tiles (implicit-blocks §4): a tabular tile at 10 cm with its tile file and a
# preview tinted by block id. Prints the Table-1 statistics and the generation time.
# usage: samples/02_blocks.sh BUILD_DIR OUT_DIR [TYPE]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
TYPE="${3:-tabular}"
mkdir -p "$OUT"
"$BUILD/vdbtools/vdb_blocks" --type "$TYPE" --tile-size 20 --seed 7 --voxel-size 0.1 \
    -o "$OUT/blocks_$TYPE.vdb" --tile "$OUT/blocks_$TYPE.tile"
"$BUILD/vdbtools/vdb_preview" "$OUT/blocks_$TYPE.vdb" --ids block_id --azimuth 30 --elevation 25 --zoom 1.4 \
    -o "$OUT/blocks_$TYPE.png"
"$BUILD/vdbtools/vdb_info" "$OUT/blocks_$TYPE.vdb" | head -4
