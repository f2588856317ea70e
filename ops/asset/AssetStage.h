// SPDX-License-Identifier: Apache-2.0
// rockvdb — the asset stage (issue 37): a level set (or one block / rock of it, by id) to a
// game asset, one GLB with its LODs, UV atlases, normal and occlusion maps baked from the level
// set, and a convex collision hull. The table drives vdb_asset's options and rockvdb.asset's
// keywords; runAsset is the one entry point (runAssetEach: every id of an id grid).
#pragma once

#include <rockvdb/asset/Instances.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>

#include <openvdb/openvdb.h>

#include <map>
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
    bool occlusion;    ///< bake ambient occlusion (asset/Occlusion.h)
    double aoDistance; ///< occluders count within this distance (m); 0: a quarter of the extent
    int mapBits;       ///< 8 or 16 bits per PNG channel
    int id;            ///< cut this id out of the id grid (asset/Cut.h); -1: the whole level set
    bool collision;    ///< a convex hull node UCX_<name>_00
};

/// @brief The table of AssetParams (op "asset").
const Schema<AssetParams>& assetSchema();

/// @brief The LOD budgets of a "5000,1500,400" list (ValueError naming "lods" otherwise).
std::vector<size_t> parseLods(const std::string& text);

/// @brief The id grid a cut reads from @a grids: @a name, or (empty) the first of block_id,
/// rock_id present. @throw ValueError naming the float grids there are when none is found.
openvdb::FloatGrid::Ptr findIdGrid(const openvdb::GridPtrVec& grids, const std::string& name,
                                   const std::string& source);

struct AssetInputs
{
    openvdb::FloatGrid::ConstPtr grid;               ///< the level set
    openvdb::FloatGrid::ConstPtr ids;                ///< the id grid (needed for id >= 0)
    /// An id grid (material, block_id, rock_id) to bake into a mask texture per LOD (Maps.h,
    /// SurfaceField::mask; Gltf.h, GltfAsset::maskName), or none.
    openvdb::FloatGrid::ConstPtr mask;
    nlohmann::json names = nlohmann::json::object(); ///< e.g. {"input": path, "grid": name}
    /// A surface with fewer triangles than LOD 0 asks has every budget scaled down so that
    /// LOD 0 is the whole surface (runAssetEach: a pile's small rocks), instead of an error;
    /// the provenance records the budgets used, so it replays without this flag.
    bool fitLods = false;
    /// Every id's box (asset/Cut.h, surfaceIdBoxes), when known: a cut need not search the
    /// id grid (runAssetEach finds them all in one pass).
    const std::map<int, openvdb::CoordBBox>* idBoxes = nullptr;
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

/// @brief Every id of the id grid on the surface (sorted).
std::vector<int> assetIds(const AssetInputs& inputs);

struct AssetSetResult : StageResult
{
    std::vector<std::pair<int, std::string>> glbs; ///< (id, bytes), ids rising
};

/// @brief runAsset for every id of assetIds (params.id ignored), each named <name>_<id> with
/// its own provenance (its id and name) and its LODs fitted (AssetInputs::fitLods): stats
/// hold each asset's, report a line per asset.
AssetSetResult runAssetEach(const AssetParams& params, const AssetInputs& inputs, Task& task);

/// @brief A rock pile's unique rocks as one GLB (readPileInstances): each rock an asset named
/// <name>_<rock> with its LODs fitted (as runAssetEach), its mesh centred on its seed, drawn at
/// every instance's seed by EXT_mesh_gpu_instancing. @a names (e.g. {"input": points path,
/// "tiles": tile set path}) go in the provenance. params.id must be -1.
AssetResult runAssetInstances(const AssetParams& params, const PileInstances& pile,
                              const nlohmann::json& names, Task& task);

} // namespace asset
} // namespace rockvdb
