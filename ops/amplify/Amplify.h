// SPDX-License-Identifier: Apache-2.0
// rockvdb — terrain amplification by block replication (implicit-blocks-rocky-scenery.txt §5).
//
// The tile of blocks virtually tiles space; copy (cell c, block i) exists when its presence
// e_i(a_i + s·c) holds: enough of the block's anchors lie in a distance range [va, vb] of the
// terrain surface on steep ground (|g·u_z| < ε). The replication t(p) = ∪ b_i(p - s·c) over
// the present copies (paper's max ↦ our min) is unioned with the terrain: f̃ = f ∪ t.
// Presence is decided once per (cell, block), in parallel, before baking.
#pragma once

#include <rockvdb/blocks/Aperiodic.h>
#include <rockvdb/blocks/BlockTile.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Field.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <nlohmann/json_fwd.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace rockvdb {
namespace amplify {

/// Placement rules (§5); the paper replicates a block when more than half its anchors pass.
/// The paper gives no values for [va, vb] and ε; the defaults make cliffs of 10 m tiles'
/// blocks walls of blocks: 91–94% of the steep surface of four test cliffs carries a block id
/// (README, "Cliffs made of blocks"), gentle ground staying mostly bare. The range should
/// reach about a block's size into the terrain: with 20 m tiles, widen it.
struct PlacementRules
{
    double distanceMin = -3.0; ///< va: anchors at terrain distance >= va (m, negative inside)
    double distanceMax = 2.0;  ///< vb: ... and <= vb
    double maxSlope = 0.6;     ///< ε: |g·u_z| < ε (0 = nothing qualifies, 1 = any slope)
    int anchors = 8;           ///< anchors tested per block (the tile stores up to 16)
    double fraction = 0.5;     ///< a copy is present when more than this share passes
    /// Region of interest: anchors outside it fail (default: everywhere). Heightfield
    /// terrains use their footprint, so the solid's artificial side walls stay bare.
    BBoxd region = infiniteBounds();
    /// Optional mask image over the xy plane (pixel column i, row j at x = i·maskCellSize,
    /// y = j·maskCellSize, like heightfields): anchors where it reads < 0.5 fail; outside the
    /// image they fail too.
    std::shared_ptr<const GrayImage> mask;
    double maskCellSize = 1.0;
    /// The surface the distance and slope tests read (default: the terrain field itself).
    /// Heightfield terrains set their open height surface: an anchor inside the plateau near
    /// the footprint's edge must not see the closed solid's side wall as a steep face.
    FieldPtr surface;
    void validate() const;
    /// @brief Limit anchors to @a roi as well (intersected with the current region).
    void restrictTo(const BBoxd& roi);
    /// @brief The distance from the terrain surface within which presence reads exact
    /// terrain distances: max(|va|, |vb|) + 0.5 m, at least 1 m.
    double reach() const;
};

/// Strata (the material γ of §5): layers stacked along a (possibly tilted) normal, their
/// boundaries optionally warped by noise; each layer names the tile its blocks come from.
struct Strata
{
    Vec3d normal = Vec3d(0, 0, 1);
    double noiseAmplitude = 0.0; ///< boundary warp (m)
    double noiseFrequency = 0.05;
    uint64_t noiseSeed = 1;
    std::vector<double> tops;    ///< ascending layer tops; the last layer has none
    std::vector<int> tiles;      ///< tile index per layer (tops.size() + 1 entries)

    /// @brief Elevation e(p) = n·p + noise(p) used to find the layer.
    double elevation(const Vec3d& p) const;
    /// @brief The tile index of the layer holding p.
    int tileAt(const Vec3d& p) const;
    /// @brief {"normal": [..], "noise": {"amplitude", "frequency", "seed"}, "layers":
    /// [{"tile": name, "top": z}, ..., {"tile": name}]}; tile names are the tiles' file stems
    /// (or their 0-based index). ValueError for unknown tiles or unordered tops.
    static Strata fromJson(const nlohmann::json& j, const std::vector<std::string>& tileNames);
};

struct AmplifyStats
{
    size_t cells = 0;          ///< tile cells examined
    size_t replicated = 0;     ///< #R: present (cell, block) copies
    double blockBytes = 0;     ///< memory of the block fields (blocks::tileFieldBytes: planes, anchors, bounds, relief table)
    double presenceSeconds = 0;
    double bakeSeconds = 0;    ///< band bake of f̃ (cull + fill + finish)
    double splitSeconds = 0;   ///< union of the parts' grids and block_id / material split
    BakeStats bake;
};

/// @brief A heightfield terrain as a field with exact distances within rules.reach(); the
/// rules' region is limited to the footprint (1 m in from its edge), so the closed solid's
/// vertical side walls, which are not terrain, stay bare.
FieldPtr heightfieldTerrain(std::shared_ptr<const Heightfield> hf, double baseDepth,
                            PlacementRules& rules);

/// @brief A 3D terrain level set (overhangs, arches) as a field, its band widened to
/// rules.reach() so that presence reads true distances.
FieldPtr levelSetTerrain(openvdb::FloatGrid::ConstPtr grid, const PlacementRules& rules,
                         double maxMemoryBytes = 0.0);

/// @brief ValueError unless all tiles share one size (or @a mixedSizes allows it).
void checkTileSizes(const std::vector<std::shared_ptr<const blocks::BlockTile>>& tiles,
                    bool mixedSizes);

/// The baked amplified terrain: 'surface', 'block_id' and 'material'.
struct AmplifyResult
{
    openvdb::FloatGrid::Ptr surface, blockId, material;
};

/// f̃'s two parts, kept apart so that each is baked the cheapest way and the grids united.
struct AmplifiedParts
{
    FieldPtr terrain;     ///< f
    FieldPtr blocks;      ///< t, the present copies of every tile with their ids (null: none)
    double carveGap = 0;  ///< > 0: the carving variant (see amplifiedTerrain)
    /// @brief f̃ as one field: f ∪ t, the carved min(t, max(f, gap - t)), or f alone.
    FieldPtr united() const;
};

/// @brief Bake f̃ over @a settings' region with block ids, and split them into block_id and
/// material; bake and split times go to @a stats.
///
/// The union f ∪ t is baked as two level sets on the same voxels and united voxel by voxel
/// (min, the block's id where the block is closer): the terrain is an exact distance and
/// needs no renormalisation, its exact search runs only over the terrain's own band, and the
/// blocks are evaluated only over theirs. Both bakes cover the box (or chunk) the single
/// bake of f̃ would fill, so chunks still merge bit for bit. The carving variant reads the
/// blocks' field far beyond their band (gap - t) and is baked as one field.
AmplifyResult bakeAmplified(const AmplifiedParts& parts, BakeSettings settings,
                            AmplifyStats& stats,
                            openvdb::util::NullInterrupter* interrupt = nullptr);

/// @brief Unite a terrain level set (taken over and modified) and a blocks level set on the
/// same transform and background, voxel by voxel: value min(f, t), active where |min| <
/// background; block_id and material as splitMaterial makes them, from the blocks' ids
/// (tile·kMaterialStride + block) where t < f, terrain (−1, kTerrainMaterial) elsewhere.
/// Over a leaf that only one grid has, the other's sign is read from its field (once per
/// leaf), not from its tiles: a chunk's tiles are not signed reliably near its faces.
AmplifyResult uniteWithBlocks(openvdb::FloatGrid::Ptr terrain, const openvdb::FloatGrid& blocks,
                              const openvdb::FloatGrid& blockIds, const Field& terrainField,
                              const Field& blocksField);

/// @brief One line per phase for logs: "#R ...", "bake: ...", "phases: ...".
std::vector<std::string> describe(const AmplifyStats& stats);

/// @brief The set of present copies for one tile over a terrain (computed on construction).
/// With @a strata, an anchor also needs the strata's tile at its position to be @a tileIndex.
/// @a task (optional) is stepped per batch of cells and its cancel throws Interrupted. With
/// @a only, the cells it leaves out hold no copy (and cost nothing).
std::shared_ptr<const blocks::Presence> computePresence(const Field& terrain,
                                                        const blocks::BlockTile& tile,
                                                        const PlacementRules& rules,
                                                        AmplifyStats& stats,
                                                        const Strata* strata = nullptr,
                                                        int tileIndex = 0, Task* task = nullptr,
                                                        const std::function<bool(int, int, int)>& only = {});

/// Attribute ids of the amplified terrain: tile·kMaterialStride + block (terrain: kNoId).
constexpr float kMaterialStride = 65536.0f;

/// Material ids: bare terrain is 0, the blocks of tile k are k + 1 (so other stages' solids,
/// e.g. a rock pile, can take the next ids and one 'material' grid names every part).
constexpr float kTerrainMaterial = 0.0f;

/// @brief Split a bake's ids (tile·kMaterialStride + block) in place into block indices and
/// return the matching "material" grid (kTerrainMaterial on bare terrain, 1 + tile index on
/// blocks).
openvdb::FloatGrid::Ptr splitMaterial(openvdb::FloatGrid& ids);

/// @brief f̃ = f ∪ t: the terrain united with the present block copies of every tile (one
/// tile, or several chosen per stratum). Attribute ids: see kMaterialStride.
/// With @a carveGap > 0 the carving variant: blocks replace the terrain's skin where they
/// are present, f̃ = min(t, max(f, gap - t)): the terrain is cut back to the blocks dilated
/// by the gap, so rock faces are made of blocks and the fractures between them open up.
FieldPtr amplifiedTerrain(FieldPtr terrain,
                          const std::vector<std::shared_ptr<const blocks::BlockTile>>& tiles,
                          const PlacementRules& rules, AmplifyStats& stats,
                          const Strata* strata = nullptr, double carveGap = 0.0,
                          Task* task = nullptr);

/// @brief As amplifiedTerrain, its parts apart (what bakeAmplified bakes). With @a aperiodic,
/// the blocks are those of its corner-coloured cube tiles (the tile's own parameters; one
/// tile, no strata) instead of the periodic tile's.
AmplifiedParts amplifiedParts(FieldPtr terrain,
                              const std::vector<std::shared_ptr<const blocks::BlockTile>>& tiles,
                              const PlacementRules& rules, AmplifyStats& stats,
                              const Strata* strata = nullptr, double carveGap = 0.0,
                              Task* task = nullptr,
                              std::shared_ptr<const blocks::AperiodicTiles> aperiodic = nullptr);

} // namespace amplify
} // namespace rockvdb
