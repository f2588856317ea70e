#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Stone arches, sea caves and a tunnel network (arches §4.2, §4.4, §4.3; Fig. 1 / 20 / 23 kind):
# a sea cliff (plateau 22 m over a sand floor) whose stacks are edited by the scene's edits —
#  - a tunnel along the coast just inside the wavy face: where the bays cut into it the roof
#    stands as a row of arches, where the headlands stand it is a sea cave;
#  - a branching tunnel network from it into the plateau, with a large cave at the junction
#    (a bigger profile at that node, interpolated along the arcs);
#  - the cave's roof partly collapsed into rocks and sand (collapse erosion), sand dropped on
#    its floor (a deposit into the room at 5 m); each edit is stabilised locally.
# Writes arches_coast.vdb (+ .stacks) and a preview tinted by material (sand, bedrock, rocks).
# usage: samples/09_arches_coast.sh BUILD_DIR OUT_DIR [VOXEL]
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
VOXEL="${3:-0.25}"
B="$BUILD/vdbtools"
mkdir -p "$OUT"
"$B/vdb_arches" -q samples/data/arches_coast.json --voxel-size "$VOXEL" \
    --stacks "$OUT/arches_coast.stacks" -o "$OUT/arches_coast.vdb"
"$B/vdb_preview" -q "$OUT/arches_coast.vdb" --ids material --palette '2=#d9c08c,3=#7b7068,4=#4f4a46' \
    --azimuth 20 --elevation 20 --zoom 1.5 --width 800 --height 450 -o "$OUT/arches_coast.png"
