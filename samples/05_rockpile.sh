#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Rock piles (aperiodic-rock-piles §2–§6): an aperiodic corner-cube tile set of eroded Voronoi
# rocks, then a scree mound filled with them (union level set + rock ids, instances as points),
# with a preview tinted by rock id.
# usage: samples/05_rockpile.sh BUILD_DIR OUT_DIR [N]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
N="${3:-5}"
mkdir -p "$OUT"
"$BUILD/vdbtools/vdb_rockpile" tiles --n "$N" --seeds-per-cell 1,2 --g-max 2 --cube-size 1 \
    --seed 7 -o "$OUT/rockpile_rocks.tiles.vdb"
cat > "$OUT/rockpile_mound.json" <<'JSON'
{"type": "intersection", "children": [
  {"type": "transform", "scale": [1, 1, 0.45], "child": {"type": "sphere", "radius": 3}},
  {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, -1]}]}
JSON
"$BUILD/vdbtools/vdb_rockpile" pile --tiles "$OUT/rockpile_rocks.tiles.vdb" --support "$OUT/rockpile_mound.json" \
    --seed 11 --points "$OUT/rockpile_points.vdb" -o "$OUT/rockpile.vdb"
"$BUILD/vdbtools/vdb_preview" "$OUT/rockpile.vdb" --ids rock_id --azimuth 30 --elevation 30 \
    --zoom 1.3 -o "$OUT/rockpile.png"
