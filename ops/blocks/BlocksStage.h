// rockvdb — the block-tile stage's front door: its parameter tables and its entry points
// (vdb_blocks, rockvdb.block_tile and BlockTile.bake are thin wrappers over them).
#pragma once

#include <rockvdb/blocks/BlockTile.h>

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Schema.h>
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
    BakeParams bake;
};

/// @brief The table of BlocksParams (tileSchema()'s rows, periods, the bake's rows).
const Schema<BlocksParams>& blocksSchema();

struct BlocksResult
{
    std::shared_ptr<const BlockTile> tile;
    BakeResult bake; ///< surface and block_id (bake.attribute), metadata stamped
};

/// @brief Generate a tile (the task checked between phases).
std::shared_ptr<const BlockTile> makeTile(const BlockTileParams& params, Task& task);

/// @brief Bake @a tile over params.periods at params.bake: 'surface' and 'block_id', the tile
/// description as metadata rockvdb:tile, provenance = the table's values (the tile's own
/// parameters) and @a inputs (e.g. {"from-tile": path}).
/// @throw ValueError when the voxel is too coarse for the tile (the tile field is exact to
/// tile size / 4), or for bad settings; Interrupted when cancelled.
BlocksResult bakeTile(std::shared_ptr<const BlockTile> tile, const BlocksParams& params,
                      const nlohmann::json& inputs, Task& task);

/// @brief vdb_blocks: generate the tile of params.tile, then bakeTile.
BlocksResult runBlocks(const BlocksParams& params, Task& task);

} // namespace blocks
} // namespace rockvdb
