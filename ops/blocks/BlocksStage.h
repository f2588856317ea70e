// SPDX-License-Identifier: Apache-2.0
// rockvdb — the block-tile stage's front door: its parameter tables and its entry points
// (vdb_blocks, rockvdb.block_tile and BlockTile.bake are thin wrappers over runBlocks).
#pragma once

#include <rockvdb/blocks/Aperiodic.h>
#include <rockvdb/blocks/BlockTile.h>

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>

#include <array>
#include <memory>

namespace rockvdb {
namespace blocks {

/// The tool the entry points record as the generator of what they make.
constexpr const char* kBlocksTool = "vdb_blocks";

/// @brief The tile's rows: what defines a tile (a tile file's "params").
const Schema<BlockTileParams>& tileSchema();

/// vdb_blocks' options, rockvdb.block_tile's keywords: the tile's rows, the periods baked and
/// the bake's rows (defaults in blocksSchema()).
struct BlocksParams
{
    BlocksParams();

    BlockTileParams tile;
    std::array<int, 3> periods;
    bool aperiodic;  ///< bake the corner-coloured cube tiling of the tile's parameters
    int colours;     ///< its lattice vertices' colours
    BakeParams bake;
};

/// @brief The rows "aperiodic" and "colours" of a stage that tiles blocks (vdb_blocks,
/// vdb_amplify): one definition, help and range for both.
template<typename P>
void addAperiodicRows(Schema<P>& s, bool P::*aperiodic, int P::*colours, const char* where)
{
    s.member(param("aperiodic", ParamType::Bool, "", false, Range::any(),
                   std::string("Tile aperiodically (implicit blocks §6.4's future work): lattice "
                               "vertices take one of --colours colours and each cube the blocks of "
                               "its 8 corners' colouring, made from the tile's parameters as cubes "
                               "need them; blocks cross cube faces whole") + where),
             aperiodic);
    s.member(param("colours", ParamType::Int, "", kDefaultColours, Range::closed(kMinColours, kMaxColours),
                   "Aperiodic: colours of the lattice vertices (K: a vertex region recurs with "
                   "odds 1/K, an edge's 1/K^2, a face's 1/K^4; 3 makes nearly every cube's tile "
                   "anew)"),
             colours);
}

/// @brief The table of BlocksParams (tileSchema()'s rows, periods, the bake's rows).
const Schema<BlocksParams>& blocksSchema();

/// What runBlocks works on besides the table's values.
struct BlocksInputs
{
    /// A tile to bake (a .tile file read, a BlockTile from Python); null: generate the tile
    /// of params.tile. A given tile's own parameters replace the tile rows (provenance too).
    std::shared_ptr<const BlockTile> tile;
    /// Provenance keys naming the given tile, e.g. {"from-tile": path}.
    nlohmann::json source = nlohmann::json::object();
    bool bake = true;    ///< false: generate (or take) the tile only, no grids
    bool meshes = false; ///< also mesh every block in its home frame (result.meshes)
    /// tools::volumeToMesh's adaptivity for the meshes, in [0, 1]: 0 one quad per surface
    /// voxel; the default merges the blocks' flat faces (6.6 % of the uniform mesh's vertices
    /// for a 20 m tile at 5 cm, bench/meshes.py), its polygon centres as close to the level
    /// set as the uniform mesh's (test_blocks_cli).
    double meshAdaptivity = 0.5;
};

struct BlocksResult : StageResult
{
    std::shared_ptr<const BlockTile> tile;
    BakeResult bake; ///< surface and block_id (bake.attribute), metadata stamped
    Mesh meshes;     ///< with inputs.meshes: one triangle group per block, named "block"
};

/// @brief The block-tile stage, vdb_blocks and rockvdb.block_tile / BlockTile.bake alike:
/// generate the tile of params.tile (or take inputs.tile), bake it over params.periods at the
/// bake rows ('surface' and 'block_id', the tile description as metadata rockvdb:tile,
/// provenance = the table with the tile's own parameters and inputs.source), and mesh its
/// blocks when asked. Phases: generation (when generating), bake, meshes (when asked).
/// Stats: the tile's (Table 1: points, discs, blocks, mean_points, seconds per step) and the
/// bake's.
/// @throw ValueError for bad values, a voxel too coarse for the tile (checked before
/// generating: the tile field is exact to tile size / 4), or meshes asked of one chunk;
/// Interrupted when cancelled.
BlocksResult runBlocks(const BlocksParams& params, const BlocksInputs& inputs, Task& task);

} // namespace blocks
} // namespace rockvdb
