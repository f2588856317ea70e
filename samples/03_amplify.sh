#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Terrain amplification (implicit-blocks §5): a 60 m sea-cliff heightfield, two block tiles
# (equidimensional below a tilted, noise-warped stratum boundary, tabular above) and the
# amplified cliff at VOXEL metres, with a preview tinted by material.
# usage: samples/03_amplify.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.1}"
mkdir -p "$OUT"
# The heightfield: a 25 m plateau falling over ~8 m to the sea floor along a wavy coastline.
PYTHONPATH="$BUILD/python" /usr/bin/python3 - "$OUT/amplify_cliff.exr" <<'PY'
import sys
import numpy as np
import rockvdb
n, cell = 121, 0.5
y, x = np.mgrid[0:n, 0:n] * cell
coast = 30 + 4 * np.sin(y / 7.0) + 2 * np.sin(y / 2.3 + 1)
t = np.clip((coast - x) / 8.0 + 0.5, 0, 1)
rockvdb.write_heightfield(sys.argv[1], (25 * t * t * (3 - 2 * t)).astype(np.float32))
PY
"$BUILD/vdbtools/vdb_blocks" --type equidimensional --tile-size 10 --seed 3 --voxel-size 0.2 \
    -o "$OUT/amplify_equi.vdb" --tile "$OUT/amplify_equi.tile"
"$BUILD/vdbtools/vdb_blocks" --type tabular --tile-size 10 --seed 4 --voxel-size 0.2 \
    -o "$OUT/amplify_tabular.vdb" --tile "$OUT/amplify_tabular.tile"
cat > "$OUT/amplify_strata.json" <<'JSON'
{"normal": [0.2, 0, 1], "noise": {"amplitude": 1.5, "frequency": 0.08, "seed": 2},
 "layers": [{"tile": "amplify_equi", "top": 14}, {"tile": "amplify_tabular"}]}
JSON
"$BUILD/vdbtools/vdb_amplify" --terrain "$OUT/amplify_cliff.exr" --cell-size 0.5 --height-scale 1 \
    --tiles "$OUT/amplify_equi.tile,$OUT/amplify_tabular.tile" --strata "$OUT/amplify_strata.json" \
    --voxel-size "$VOXEL" -o "$OUT/amplify_cliff.vdb"
"$BUILD/vdbtools/vdb_preview" "$OUT/amplify_cliff.vdb" --ids material --azimuth -60 --elevation 20 \
    --zoom 1.3 -o "$OUT/amplify_cliff.png"
