// rockvdb — terrain amplification by block replication (implicit-blocks-rocky-scenery.txt §5).
//
// The tile of blocks virtually tiles space; copy (cell c, block i) exists when its presence
// e_i(a_i + s·c) holds: enough of the block's anchors lie in a distance range [va, vb] of the
// terrain surface on steep ground (|g·u_z| < ε). The replication t(p) = ∪ b_i(p - s·c) over
// the present copies (paper's max ↦ our min) is unioned with the terrain: f̃ = f ∪ t.
// Presence is decided once per (cell, block), in parallel, before baking.
#pragma once

#include <blocks/BlockTile.h>
#include <core/Field.h>

#include <memory>

namespace rockvdb {
namespace amplify {

/// Placement rules (§5); the paper replicates a block when more than half its anchors pass.
struct PlacementRules
{
    double distanceMin = -1.0; ///< va: anchors at terrain distance >= va (m, negative inside)
    double distanceMax = 0.5;  ///< vb: ... and <= vb
    double maxSlope = 0.5;     ///< ε: |g·u_z| < ε (0 = nothing qualifies, 1 = any slope)
    int anchors = 8;           ///< anchors tested per block (the tile stores up to 16)
    double fraction = 0.5;     ///< a copy is present when more than this share passes
    /// Region of interest: anchors outside it fail (default: everywhere). Heightfield
    /// terrains use their footprint, so the solid's artificial side walls stay bare.
    BBoxd region = infiniteBounds();
    void validate() const;
};

struct AmplifyStats
{
    size_t cells = 0;          ///< tile cells examined
    size_t replicated = 0;     ///< #R: present (cell, block) copies
    double blockBytes = 0;     ///< memory of the block fields (planes, anchors, bounds)
    double presenceSeconds = 0;
};

/// @brief The set of present copies for one tile over a terrain (computed on construction).
std::shared_ptr<const blocks::Presence> computePresence(const Field& terrain,
                                                        const blocks::BlockTile& tile,
                                                        const PlacementRules& rules,
                                                        AmplifyStats& stats);

/// @brief f̃ = f ∪ t: the terrain united with the present block copies of @a tile. Attribute
/// ids are block indices (terrain voxels: kNoId).
FieldPtr amplifiedTerrain(FieldPtr terrain, std::shared_ptr<const blocks::BlockTile> tile,
                          const PlacementRules& rules, AmplifyStats& stats);

} // namespace amplify
} // namespace rockvdb
