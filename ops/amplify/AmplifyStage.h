// SPDX-License-Identifier: Apache-2.0
// rockvdb — the amplification stage's front door: its parameter table and its one entry
// point, runAmplify (vdb_amplify and rockvdb.amplify are thin wrappers over it).
#pragma once

#include <rockvdb/amplify/Amplify.h>

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace rockvdb {
namespace amplify {

/// The tool the entry point records as the generator of what it makes.
constexpr const char* kAmplifyTool = "vdb_amplify";

/// vdb_amplify's options, rockvdb.amplify's keywords (defaults in amplifySchema(); the
/// presence rules' defaults are PlacementRules' own initial values, which the table shows).
struct AmplifyParams
{
    AmplifyParams();

    std::string terrainGrid;        ///< level set to read from a .vdb terrain
    double cellSize, heightScale, baseDepth; ///< heightfield images
    nlohmann::json strata;          ///< null or the strata object (a file's content)
    bool mixedTileSizes;
    std::optional<std::array<double, 6>> roi;
    double maskCellSize;            ///< 0 = the heightfield's cell size
    double carve;
    bool aperiodic;                 ///< corner-coloured cube tiles made from the tile's parameters
    int colours;                    ///< of the aperiodic tiling's lattice vertices
    PlacementRules rules;           ///< max slope, distance range, anchors, fraction
    BakeParams bake;
};

/// @brief The table of AmplifyParams.
const Schema<AmplifyParams>& amplifySchema();

/// What runAmplify works on: the terrain (a level set grid, or a path: heightfield image,
/// procedural heightfield .json, level-set .vdb or "-"), the tiles with their names (strata
/// name tiles by these), an optional mask image, and how provenance names them.
struct AmplifyInputs
{
    openvdb::FloatGrid::ConstPtr terrainGrid;
    std::string terrainPath;
    std::vector<std::shared_ptr<const blocks::BlockTile>> tiles;
    std::vector<std::string> tileNames;
    std::shared_ptr<const GrayImage> mask;
    nlohmann::json names = nlohmann::json::object(); ///< e.g. {"terrain": path, "tiles": [...]}
};

struct AmplifyRun : StageResult
{
    AmplifyResult amplified; ///< surface, block_id, material (provenance stamped; also in grids)
    AmplifyStats counts;     ///< as StageResult::stats (JSON) holds them
};

/// @brief Amplify the terrain (phases: presence, bake). Every guard of the stage is here.
/// Stats: replicated (#R), cells, block_field_bytes, active_voxels, presence_seconds,
/// bake_seconds, split_seconds, phases.
/// @throw ValueError / IoError for bad parameters or inputs; Interrupted when cancelled.
AmplifyRun runAmplify(const AmplifyParams& params, const AmplifyInputs& inputs, Task& task);

} // namespace amplify
} // namespace rockvdb
