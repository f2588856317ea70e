#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Periodic against aperiodic tiling (arches §5 against aperiodic-rock-piles §2–§3): the same
# pebbles (α = β = 2, γ = 1: flattish) from a periodic tile — Poisson-sphere seeds in one
# cube — and from 2-colour corner cubes, each filling the same river bed (6 × 3 m, 30 cm deep).
# Seen from above, the periodic bed repeats every cube (1.2 m); the aperiodic one does not.
# usage: samples/06_riverbed.sh BUILD_DIR OUT_DIR
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
mkdir -p "$OUT"
ROCKS=(--anisotropy 2,2,1 --g-max 2 --cube-size 1.2 --voxels-per-cell 10 --seed 5)
"$BUILD/vdbtools/vdb_rockpile" tiles --tiling periodic --n 5 "${ROCKS[@]}" -o "$OUT/riverbed_pebbles_periodic.tiles.vdb"
"$BUILD/vdbtools/vdb_rockpile" tiles --tiling aperiodic --n 5 "${ROCKS[@]}" -o "$OUT/riverbed_pebbles_aperiodic.tiles.vdb"
cat > "$OUT/riverbed_bed.json" <<'JSON'
{"type": "box", "center": [0, 0, 0], "size": [6.0, 3.0, 0.3]}
JSON
for t in periodic aperiodic; do
    "$BUILD/vdbtools/vdb_rockpile" pile --tiles "$OUT/riverbed_pebbles_$t.tiles.vdb" --support "$OUT/riverbed_bed.json" \
        --seed 3 -o "$OUT/riverbed_$t.vdb"
    "$BUILD/vdbtools/vdb_preview" "$OUT/riverbed_$t.vdb" --azimuth 90 --elevation 89 \
        --zoom 1.9 --width 640 --height 320 -o "$OUT/riverbed_$t.png"
done
