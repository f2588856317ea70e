#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The flagship scene: a sea cliff of fractured rock with a scree of boulders at its foot,
# every method of the suite joined in one pipeline of vdb_* tools, from procedural inputs only.
#   1. two block tiles (implicit-blocks §4): equidimensional and tabular
#   2. a procedural sea-cliff heightfield amplified with them in two strata (§5: tabular
#      above, equidimensional below), piped into surface detail (gradient warp, §4.2, and
#      horizontal Gabor ridges, gabor-details §3)
#   3. a corner-cube rock tile set (aperiodic-rock-piles) filling a scree wedge against the
#      cliff foot (the support is the wedge minus the terrain), piped into a CSG union with the
#      cliff that carries every id grid
#   4. fractal boulders (fractal-rocks-midpoint-displacement) scattered on the plateau by an
#      fBm density map, resting on the cliff's level set, united with the scene
#   5. a sea arch on the sea floor (arches, material stacks §3-§5): a warped rock wall turned
#      into bedrock stacks, pierced by a swept tunnel (§4.2), notched at its foot by a carve
#      stroke (§4.1), its top corner collapsed (§4.4) into sand and rock layers that the
#      stabilisation piles at its foot, where the scree's rock tiles are instanced (§5); united
#      with the scene
#   6. a shaded preview tinted by material: 0 terrain, 1 equidimensional blocks, 2 tabular
#      blocks, 3 scree rocks, 4 boulders, 5 arch bedrock, 6 arch sand, 7 arch rocks
# usage: samples/01_demo.sh BUILD_DIR OUT_DIR [--quality preview|draft|default|high]
#        (or ROCKVDB_QUALITY=...); writes OUT_DIR/demo.vdb and demo.png
set -euo pipefail
BUILD="${1:-build}"
OUT="${2:-out}"
QUALITY="${ROCKVDB_QUALITY:-default}"
if [ "${3:-}" = "--quality" ]; then QUALITY="${4:?--quality needs preview, draft, default or high}"; fi
DETAIL=1
case "$QUALITY" in
    # Look-dev: the same blocks, strata, rocks and arch at 30 cm, the cliff without its detail
    # step (its 8-12 cm warp and ridges are below the voxel, and the Gabor band is above the
    # voxel's Nyquist limit, which vdb_detail refuses).
    preview) VOXEL=0.3;  CELLS=4;  HF_CELL=0.5; DETAIL=0 ;;
    draft)   VOXEL=0.25; CELLS=4;  HF_CELL=0.5 ;;  # a quick look (tests use it)
    default) VOXEL=0.1;  CELLS=10; HF_CELL=0.5 ;;  # ~1.5 minutes on 2 cores
    high)    VOXEL=0.05; CELLS=20; HF_CELL=0.25 ;; # the papers' 5 cm (rocks: 20 voxels/cell)
    *) echo "01_demo.sh: --quality must be preview, draft, default or high (got '$QUALITY')" >&2; exit 2 ;;
esac
B="$BUILD/vdbtools"
mkdir -p "$OUT"

# One line per stage: name, seconds, and what its output holds (vdb_info --brief).
SUMMARY=()
stage() {  # stage NAME OUTPUT COMMAND...
    local name="$1" output="$2" t0 t1
    shift 2
    t0=$(date +%s.%N)
    "$@"
    t1=$(date +%s.%N)
    local what
    case "$output" in
        *.png) what="$(basename "$output")  $(du -h "$output" | cut -f1)" ;;
        *) what="$("$B/vdb_info" --brief "$output" | sed "s|^$OUT/||")" ;;
    esac
    SUMMARY+=("$(printf '%-30s %7.1f s   %s' "$name" "$(awk "BEGIN {print $t1 - $t0}")" "$what")")
}

# The terrain: an 80 x 60 m sea cliff (plateau 28 m, face 9 m wide, wavy coast along y).
SAMPLES="[$(awk "BEGIN {print 80 / $HF_CELL + 1}"), $(awk "BEGIN {print 60 / $HF_CELL + 1}")]"
CLIFF="{\"type\": \"sea_cliff\", \"samples\": $SAMPLES, \"cell_size\": $HF_CELL,
        \"height\": 28, \"coast\": 36, \"width\": 9, \"waviness\": 5, \"roughness\": 0.6,
        \"seed\": 7, \"base_depth\": 4}"
echo "$CLIFF" > "$OUT/demo_terrain.json"
cat > "$OUT/demo_strata.json" <<'JSON'
{"normal": [0.15, 0, 1], "noise": {"amplitude": 1.5, "frequency": 0.08, "seed": 2},
 "layers": [{"tile": "demo_equi", "top": 15}, {"tile": "demo_tabular"}]}
JSON
# The scree: a wedge against the cliff foot, its top at the angle of repose (~34 degrees)
# falling from 8 m to the sea floor, its ends sloping too; the terrain is cut out of it.
cat > "$OUT/demo_scree.json" <<JSON
{"type": "difference", "children": [
  {"type": "polytope", "smooth": 1.0, "planes": [
    [0.559, 0, 0.829, 28.5], [0, 0.559, 0.829, 29.0], [0, -0.559, 0.829, -5.6],
    [0, 0, -1, 1], [-1, 0, 0, -28]]},
  $CLIFF]}
JSON
# The sea arch: a wall 17 x 5 x 14 m standing across the view (52 degrees from x), its stacks
# 25 cm wide down to just under the sea floor, smoothed over a bit more than a stack (sigma);
# the edits pierce, notch and break it.
cat > "$OUT/demo_arch.json" <<'JSON'
{"terrain": {"type": "warp", "amplitude": 0.5, "frequency": 0.3, "octaves": 3, "seed": 6,
             "child": {"type": "transform", "translate": [68, 33, 5], "rotate": [0, 0, 52],
                       "child": {"type": "box", "size": [17, 5, 14], "rounding": 1.5}}},
 "extent": [54, 20, 82, 46], "floor": -0.3, "cell-size": 0.25, "sigma": 0.3, "weights": false,
 "material-ids": [6, 5, 7],
 "edits": [
   {"tool": "tunnel", "nodes": [[72.7, 29.3, 0.5], [63.3, 36.7, 0.5]],
    "profile": [[-4, -1.5], [4, -1.5], [4.2, 2.5], [2.5, 5.5], [0, 6.5], [-2.5, 5.5], [-4.2, 2.5]]},
   {"tool": "sculpt", "mode": "carve", "radius": 1.8, "strength": 3,
    "points": [[72.68, 35.71, 1.5], [73.3, 36.5, 1.5], [73.92, 37.29, 1.5]]},
   {"tool": "erode", "mode": "collapse", "center": [72.5, 38.5, 11], "radius": 3.5, "rho": 0.7}]}
JSON

tiles() {
    "$B/vdb_blocks" -q --type equidimensional --tile-size 10 --seed 3 --voxel-size 0.2 \
        -o "$OUT/demo_equi.vdb" --tile "$OUT/demo_equi.tile"
    "$B/vdb_blocks" -q --type tabular --tile-size 10 --seed 4 --voxel-size 0.2 \
        -o "$OUT/demo_tabular.vdb" --tile "$OUT/demo_tabular.tile"
}
cliff() {
    if [ "$DETAIL" = 0 ]; then
        "$B/vdb_amplify" -q --terrain "$OUT/demo_terrain.json" \
            --tiles "$OUT/demo_equi.tile,$OUT/demo_tabular.tile" --strata "$OUT/demo_strata.json" \
            --voxel-size "$VOXEL" -o "$OUT/demo_cliff.vdb"
        return
    fi
    "$B/vdb_amplify" -q --terrain "$OUT/demo_terrain.json" \
        --tiles "$OUT/demo_equi.tile,$OUT/demo_tabular.tile" --strata "$OUT/demo_strata.json" \
        --voxel-size "$VOXEL" -o - |
    "$B/vdb_detail" -q - --warp-amplitude 0.12 --warp-scale 3 \
        --gabor-amplitude 0.08 --gabor-frequency 1.2 --direction-axis 0,0,1 \
        -o "$OUT/demo_cliff.vdb"
}
rocks() {
    "$B/vdb_rockpile" -q tiles --n 5 --cube-size 5 --voxels-per-cell "$CELLS" \
        --seeds-per-cell 1,3 --anisotropy 1.6,1.3,1 --seed 5 -o "$OUT/demo_rocks.tiles.vdb"
}
scree() {
    "$B/vdb_rockpile" -q pile --tiles "$OUT/demo_rocks.tiles.vdb" --support "$OUT/demo_scree.json" \
        --material 3 -o - |
    "$B/vdb_csg" -q union "$OUT/demo_cliff.vdb" - -o "$OUT/demo_scree.vdb"
}
boulders() {
    # The plateau is the ground: the cliff's level set, its top per column.
    "$B/vdb_fractal_rock" -q --count 40 --ground "$OUT/demo_cliff.vdb" --area 3,5,26,55 \
        --size 3,2.4,1.6 --levels 2 --seed 9 --density-scale 12 --material 4 \
        --voxel-size "$VOXEL" -o - |
    "$B/vdb_csg" -q union "$OUT/demo_scree.vdb" - -o "$OUT/demo_boulders.vdb"
}
arch() {
    "$B/vdb_arches" -q "$OUT/demo_arch.json" --rock-tiles "$OUT/demo_rocks.tiles.vdb" \
        --voxel-size "$VOXEL" -o - |
    "$B/vdb_csg" -q union "$OUT/demo_boulders.vdb" - -o "$OUT/demo.vdb"
}
preview() {
    "$B/vdb_preview" "$OUT/demo.vdb" --ids material \
        --palette '0=#9a9184,1=#c8ae86,2=#b58a7c,3=#7d8792,4=#6f6a62,5=#a3876a,6=#d9c08c,7=#5f5a55' \
        --azimuth -38 --elevation 24 --zoom 1.5 --width 1280 --height 720 \
        -o "$OUT/demo.png" 2> "$OUT/demo_preview.txt"
}

T0=$(date +%s.%N)
stage "block tiles (vdb_blocks x2)" "$OUT/demo_tabular.vdb" tiles
CLIFF_STAGE="cliff (vdb_amplify | detail)"
if [ "$DETAIL" = 0 ]; then CLIFF_STAGE="cliff (vdb_amplify)"; fi
stage "$CLIFF_STAGE" "$OUT/demo_cliff.vdb" cliff
stage "rock tiles (vdb_rockpile)" "$OUT/demo_rocks.tiles.vdb" rocks
stage "scree (rockpile pile | csg)" "$OUT/demo_scree.vdb" scree
stage "boulders (fractal_rock | csg)" "$OUT/demo_boulders.vdb" boulders
stage "sea arch (vdb_arches | csg)" "$OUT/demo.vdb" arch
stage "preview (vdb_preview)" "$OUT/demo.png" preview
{
    echo "rockvdb demo ($QUALITY: ${VOXEL} m voxels) in $OUT:"
    printf '  %s\n' "${SUMMARY[@]}"
    printf '  %-30s %7.1f s\n' "total" "$(awk "BEGIN {print $(date +%s.%N) - $T0}")"
    echo "  preview: $(sed 's/^vdb_preview: //' "$OUT/demo_preview.txt") (material ids)"
} >&2
