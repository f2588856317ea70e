// SPDX-License-Identifier: Apache-2.0
// rockvdb — the rock-pile stage's front door: its parameter tables and its two entry points,
// `tiles` (a tile set, aperiodic-rock-piles §2–§5, arches §5) and `pile` (§6).
//
// vdb_rockpile and rockvdb.rock_tiles / rock_pile are thin wrappers over runTiles / runPile:
// the tables give both their options, defaults and checks, and the entry points stamp the
// provenance, so the two interfaces write the same grids, metadata included, and a file's
// rockvdb:params fed back as `vdb_rockpile <subcommand> --params` remakes it bit for bit.
#pragma once

#include <rockvdb/rockpile/RockPile.h>
#include <rockvdb/rockpile/RockTiles.h>

#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>

namespace rockvdb {
namespace rockpile {

/// The tool both entry points record as the generator of what they make.
constexpr const char* kToolName = "vdb_rockpile";

/// @brief The table of RockTileParams (`vdb_rockpile tiles`, rockvdb.rock_tiles).
const Schema<RockTileParams>& tilesSchema();
/// @brief The table of PileParams (`vdb_rockpile pile`, rockvdb.rock_pile).
const Schema<PileParams>& pileSchema();

struct TilesResult : StageResult
{
    TileSet set;
    openvdb::FloatGrid::Ptr rho;     ///< the tile set grid (tileGrid)
    openvdb::FloatGrid::Ptr library; ///< every rock's level set (when asked), else null
    openvdb::FloatGrid::Ptr libraryIds; ///< the library's rock_id (with library)
    double librarySeconds = 0;
};

/// @brief Generate a tile set (phases: voronoi + erosion, tile grid, library), every grid
/// stamped with provenance {"tiles": params}.
/// @throw ValueError before any work when tilesBytes() is over @a maxMemoryBytes (0: 75% of
///        RAM): the message gives the estimate and the parameters that lower it.
TilesResult runTiles(const RockTileParams& params, bool library, Task& task,
                     double maxMemoryBytes = 0);

/// @brief The library of a tile set made before (rockvdb.rock_library): every rock's level
/// set, grids = {rock_id, library}, stamped as runTiles stamps its own library ({"tiles": params}).
StageResult runLibrary(const TileSet& set, Task& task);

/// @brief Peak memory of runTiles, estimated from the parameters alone: the cells of every
/// region (aperiodic: 2·8 + 12·4(n−2) + 48·2(n−2)² + 256(n−2)³; periodic: n³) times m³
/// voxels each, at the bytes per voxel measured for the rocks' boxes, the Voronoi scratch
/// and the tile grid (and the library's level sets when asked).
double tilesBytes(const RockTileParams& params, bool library);

/// @brief The tile set of a file written by `tiles` (its grid 'rho').
/// @throw IoError for unreadable files, ValueError when the file holds no tile set.
TileSet readTileSet(const std::string& path);

struct PileResult : StageResult
{
    Pile pile;
    PileStats counts;                ///< as StageResult::stats (JSON) holds them
    openvdb::GridBase::Ptr points;   ///< instance points 'rocks' (when asked), else null
    openvdb::FloatGrid::Ptr library; ///< the tile set's library (when asked), else null
    openvdb::FloatGrid::Ptr libraryIds; ///< the library's rock_id (with library)
};

/// @brief Fill @a support with the rocks of @a tiles (phases: select, level sets), every
/// grid stamped with provenance {"pile": params + @a inputs}, where @a inputs names the tile
/// set and the support: the step runPile and the arches' rock layers (§5) share.
PileResult pileRocks(const TileSet& tiles, const Field& support, const PileParams& params,
                     const nlohmann::json& inputs, bool points, bool library, Task& task);

/// What runPile fills, and with what.
struct PileInputs
{
    /// The tile set: a file written by `tiles` (its grid 'rho'), or that grid.
    std::string tilesPath;
    openvdb::FloatGrid::ConstPtr tilesGrid;
    /// The support: a path (level set .vdb, JSON expression, closed .obj / .stl / .ply, read
    /// with the support rows), a field with the expression that rebuilds it, or a level set.
    std::string supportPath;
    FieldPtr supportField;
    nlohmann::json supportExpression;
    openvdb::FloatGrid::ConstPtr supportGrid;
    bool points = false;  ///< also the instances as VDB points
    bool library = false; ///< also the tile set's library
};

/// @brief `vdb_rockpile pile` and rockvdb.rock_pile: load the tile set and the support,
/// fill it (pileRocks), refuse an empty pile. grids: 'surface', 'rock_id' (and 'material').
/// Stats: placed, candidates, features, dropped_deep, select / level set seconds, phases.
/// @throw ValueError for bad parameters, a support no rock fits in, points or a library
/// asked of one chunk; IoError for unreadable files; Interrupted.
PileResult runPile(const PileParams& params, const PileInputs& inputs, Task& task);

} // namespace rockpile
} // namespace rockvdb
