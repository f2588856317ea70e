#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Gabor details along a skeleton (Gabor details §3 and its future work; Fig. 2 kind): a ring
# made of 24 capsules (a skeleton-based implicit), detailed with frames from a closed polyline
# along its core and detail parameters stored along that polyline: the ridges follow the ring,
# their height grows 7x from one side to the other and their frequency falls. Writes
# detail_ring.vdb (the plain ring beside it) and a preview.
# usage: samples/12_detail_skeleton.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.02}"
mkdir -p "$OUT"
# The ring and its skeleton: 24 points on a circle of radius 1.5 m in the xy plane; the
# amplitude 0.005 m at θ = 180° up to 0.035 m at θ = 0, the frequency 9 down to 6 cycles/m.
/usr/bin/python3 - "$OUT" <<'PY'
import json, math, sys
out = sys.argv[1]
pts = [[1.5 * math.cos(2 * math.pi * k / 24), 1.5 * math.sin(2 * math.pi * k / 24), 0.0] for k in range(24)]
ring = {"type": "union", "smooth": 0.1,
        "children": [{"type": "capsule", "a": pts[k], "b": pts[(k + 1) % 24], "radius": 0.5} for k in range(24)]}
amp = [round(0.02 + 0.015 * math.cos(2 * math.pi * k / 24), 4) for k in range(24)]
freq = [round(7.5 - 1.5 * math.cos(2 * math.pi * k / 24), 3) for k in range(24)]
skeleton = {"polylines": [{"points": pts, "closed": True, "radius": 1.2, "weight": 4,
                           "amplitude": amp, "frequency": freq}]}
json.dump(ring, open(f"{out}/detail_ring.json", "w"), indent=1)
json.dump(skeleton, open(f"{out}/detail_ring_skeleton.json", "w"), indent=1)
PY
"$BUILD/vdbtools/vdb_primitive" -q expr "$OUT/detail_ring.json" --voxel-size "$VOXEL" \
    -o "$OUT/detail_ring_plain.vdb"
# --gabor-amplitude 0: detail only where the skeleton carries it (all of the ring here);
# orientation 90: the frequency across the skeleton, so the ridges run along it.
"$BUILD/vdbtools/vdb_detail" -q "$OUT/detail_ring_plain.vdb" --gabor-amplitude 0 --warp-amplitude 0 \
    --gabor-orientation 90 --gabor-bandwidth 2 --direction-skeleton "$OUT/detail_ring_skeleton.json" \
    --seed 2 -o "$OUT/detail_ring.vdb"
"$BUILD/vdbtools/vdb_preview" -q "$OUT/detail_ring.vdb" --azimuth 200 --elevation 40 --zoom 1.3 \
    -o "$OUT/detail_ring.png"
