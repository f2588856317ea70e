// rockvdb — the asset stage (issue 37): a level set to a game asset, one GLB with its LODs,
// UV atlas and a normal map baked from the level set. The table drives vdb_asset's options
// (and rockvdb.asset's keywords, next); runAsset is the one entry point.
#pragma once

#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>

#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace rockvdb {
namespace asset {

constexpr const char* kAssetTool = "vdb_asset";

struct AssetParams
{
    AssetParams();
    std::string lods;  ///< triangles per LOD, decreasing: "5000,1500,400"
    int textureSize;   ///< texels per side of the normal map (every LOD shares one atlas)
    int padding;       ///< texels between charts
    std::string name;  ///< the asset's name: nodes <name>_LOD0, ...
};

/// @brief The table of AssetParams (op "asset").
const Schema<AssetParams>& assetSchema();

/// @brief The LOD budgets of a "5000,1500,400" list (ValueError naming "lods" otherwise).
std::vector<size_t> parseLods(const std::string& text);

struct AssetInputs
{
    openvdb::FloatGrid::ConstPtr grid;               ///< the level set
    nlohmann::json names = nlohmann::json::object(); ///< e.g. {"input": path, "grid": name}
};

struct AssetResult : StageResult
{
    std::string glb; ///< the asset's bytes
};

/// @brief Mesh, simplify, unwrap, bake and write: stats hold the full mesh's and every LOD's
/// triangles, their distance to the level set (mean and max, m), the charts and the texel
/// density; the GLB's extras hold the provenance (the table's values, the inputs, and the
/// input grid's own generator and parameters).
AssetResult runAsset(const AssetParams& params, const AssetInputs& inputs, Task& task);

} // namespace asset
} // namespace rockvdb
