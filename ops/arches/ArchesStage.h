// SPDX-License-Identifier: Apache-2.0
// rockvdb — the material-stack stage's front door ("Arches: a Framework for Modeling Complex
// Terrains", §3, §6): its parameter table and entry point.
//
// A scene is the table's JSON (what `vdb_arches scene.json` and `--params` read, and what every
// output's rockvdb:params records). Its "terrain" row is the initial terrain:
//   - a heightfield node of the expression language (heightfield, noise_terrain, sea_cliff):
//     one stack per sample, bedrock under sand-depth metres of sand;
//   - {"type": "strata", "samples": [nx, ny], "layers": [{"material": m, "thickness": t}, ...],
//      "base": b, "amplitude": a, "frequency": f, "warp": w, "warp_frequency": wf,
//      "octaves": n, "seed": s}: procedural strata (StackBuild.h);
//   - {"type": "level_set", "file": "x.vdb", "grid": "surface"}, or any other expression node:
//     a solid, turned into bedrock stacks by the roots along each stack's axis over extent.
#pragma once

#include <rockvdb/arches/Edits.h>
#include <rockvdb/arches/StackBake.h>
#include <rockvdb/arches/Stabilize.h>
#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace rockvdb {
namespace arches {

constexpr const char* kToolName = "vdb_arches";

struct ArchesParams
{
    ArchesParams();

    nlohmann::json terrain;                     ///< the initial terrain (see file comment)
    std::optional<std::array<double, 4>> extent; ///< xmin, ymin, xmax, ymax of a solid's stacks
    std::optional<double> cellSize;             ///< s (m); unset: a heightfield's spacing, else 1
    std::optional<double> floor;                ///< z0 (m); unset: the terrain's bottom
    double quantum;                             ///< q (m)
    double sandDepth;                           ///< sand on a heightfield terrain (m)
    std::string sandMap;                        ///< image scaling sandDepth per sample ("" = none)
    std::optional<double> sigma;                ///< σ (m); unset: half the cell size
    std::string kernel;                         ///< "interpolate" (default) or "box" (§3.3)
    std::optional<double> reach;                ///< interpolate's vertical reach R (m); unset: 4 cells
    std::optional<double> voxelSize;            ///< m; unset: the cell size
    double halfWidth;                           ///< voxels
    double reposeSand, reposeRocks;             ///< degrees
    bool stabilize;
    bool weights;                               ///< also the weight_<material> grids (§6)
    std::string rockTiles;                      ///< a tile set file: rocks instanced in rock layers (§5); "" = none
    double rockThreshold;                       ///< share of a rock's anchors inside the rock layers
    std::array<int, 3> materialIds;             ///< ids 'material' holds for sand, bedrock, rocks
    nlohmann::json edits;                       ///< the edits (Edits.h), applied in order after stabilisation
    int seed;
    double maxMemoryGB;
    /// One chunk of the bake (core/Chunks.h), cut in x and y on the redistance's 128-voxel
    /// sweep tiles; not with rock tiles (their rocks are chosen over the whole rock layers).
    ChunkParams chunking;
    std::string baseDir = ".";                  ///< relative paths in terrain (not a row: the scene file's folder)
};

/// @brief The table of ArchesParams (vdb_arches and rockvdb.Stacks).
const Schema<ArchesParams>& archesSchema();

struct ArchesStats
{
    size_t stacks = 0, layers = 0, bytes = 0;
    StabilizeStats stabilize;
    std::vector<EditStats> edits;
    size_t activeVoxels = 0;
    double bakeSeconds = 0; ///< every level set and 'material' (stabilisation: stabilize.seconds)
};

struct ArchesResult : StageResult
{
    Stacks stacks;
    openvdb::FloatGrid::Ptr surface;               ///< the ground (sand ∪ bedrock ∪ rocks), 'surface'
    std::vector<openvdb::FloatGrid::Ptr> materials; ///< one level set per ground material present, named by it
    openvdb::FloatGrid::Ptr material;              ///< 'material' ids over the ground's band
    std::vector<openvdb::FloatGrid::Ptr> weights;   ///< weight_<material> fog grids (§6) of the ground materials present
    openvdb::FloatGrid::Ptr rockId;                ///< with rock-tiles: the instanced rock per voxel (bg −1), else null
    openvdb::GridBase::Ptr points;                 ///< with rock-tiles: the instances as VDB points 'rocks'
                                                   ///< (P, rock, tile, instance; as vdb_rockpile pile --points)
    size_t rocksPlaced = 0;                        ///< with rock-tiles: rocks instanced
    double rockSeconds = 0;                        ///< with rock-tiles: instancing time
    ArchesStats stats;                             ///< (StageResult's JSON: statsJson())

    nlohmann::json& statsJson() { return StageResult::stats; }
};

/// @brief A scene file: its JSON object of the table's keys, and in @a baseDir its folder (what
/// relative paths in its terrain resolve against). @throw ValueError / IoError naming @a path.
nlohmann::json readScene(const std::string& path, std::string& baseDir);

/// @brief Path rows given beside a scene (command-line options, Python keywords) name files
/// from the working folder, not the scene's: made absolute in @a given (rock-tiles, sand-map).
void anchorGivenPaths(nlohmann::json& given);

/// @brief The initial stacks of @a params' terrain (phase "stacks"). @a solid, when given,
/// is the level set of a {"type": "level_set"} terrain already in memory (Python passes
/// grids; the node's file is then not read).
/// @throw ValueError naming the terrain key at fault; IoError for unreadable files.
Stacks buildStacks(const ArchesParams& params, Task& task,
                   openvdb::FloatGrid::ConstPtr solid = nullptr);

/// @brief Stabilise @a stacks in place when params.stabilize says so (§3.4), at the table's
/// repose angles.
StabilizeStats stabilizeIfAsked(const ArchesParams& params, Stacks& stacks, Task& task);

/// What bakeStacks makes.
enum class ArchesOutput
{
    All,      ///< surface, one level set per ground material present, material, weights (if asked)
    Surface,  ///< the ground only
    Sand, Bedrock, Rocks, Water, ///< that material's level set only (empty grid if absent)
    Ids,      ///< surface and 'material'
    Weights   ///< surface and the weight_<material> grids
};
/// @brief "all", "surface" (or "ground"), "sand", "bedrock", "rocks", "water", "material",
/// "weights".
/// @throw ValueError naming @a what.
ArchesOutput archesOutputFromString(const std::string& name, const std::string& what);

/// @brief Bake @a stacks as they are (no stabilisation): the grids of @a output, not yet
/// stamped (bakeScene and runStacks stamp one provenance on all). With rock-tiles (§5), the
/// rock layers are filled with the tile set's rocks (vdb_rockpile's pile, supported by the
/// rocks' own level set): the ground is then sand ∪ bedrock united with those rocks, 'rocks'
/// is the rocks' level set, 'rock_id' names the rock at each voxel, and 'points' holds the
/// instances. Each grid is the same bit for bit whichever @a output asked for it.
ArchesResult bakeStacks(const ArchesParams& params, const Stacks& stacks, ArchesOutput output, Task& task);

/// @brief The edits' context from the table: σ (unset: half the cell) and the repose angles.
EditContext editContext(const ArchesParams& params, const StackGeometry& geometry);

/// @brief Apply @a edits (a list; its first is edit number @a first of the scene) in order.
std::vector<EditStats> applyEdits(const ArchesParams& params, Stacks& stacks, const nlohmann::json& edits,
                                  size_t first, Task& task);

/// @brief stabilizeIfAsked, the scene's edits, then bakeStacks(All) on a scene's initial
/// stacks (the steps of runArches, for tests that build stacks themselves).
ArchesResult runStacks(const ArchesParams& params, Stacks stacks, Task& task);

/// What a scene's stacks are made from: a scene file, or saved stacks, or neither (the rows
/// alone), and rows given on top (command-line options, Python keywords).
struct SceneInputs
{
    std::string scenePath;  ///< a scene file; its folder resolves its own relative paths
    std::string stacksPath; ///< or saved stacks (.stacks): given rows may only be the bake's
                            ///< (bakeOnlyRows) and more edits, applied after the saved ones
    nlohmann::json given = nlohmann::json::object(); ///< rows on top, the table's names
    /// Path rows in @a given name files from the working folder (anchorGivenPaths). vdb_arches
    /// always anchors; rockvdb.Stacks only beside a scene file (its provenance then keeps
    /// relative paths as given).
    bool anchorGiven = true;
    /// The level set of a {"type": "level_set"} terrain given in memory (Python), named in
    /// provenance by its own provenance.
    openvdb::FloatGrid::ConstPtr terrainGrid;
    /// The scene will be baked with its rocks as points (vdb_arches --points): refused without
    /// rock-tiles before any work.
    bool points = false;
};

/// A scene's stacks, ready to bake or edit further.
struct Scene
{
    ArchesParams params;        ///< resolved: edits as content, the saved and the new ones
    Stacks stacks;
    nlohmann::json inputs = nlohmann::json::object(); ///< provenance keys besides the table's
    StabilizeStats stabilize;   ///< the scene's stabilisation (none for saved stacks)
    std::vector<EditStats> edits; ///< the edits applied here (for saved stacks: the new ones)
};

/// @brief The scene of vdb_arches and rockvdb.Stacks alike: read the scene file or the saved
/// stacks, merge the given rows on top (saved stacks: only the bake's rows and more edits),
/// build the stacks, stabilise them when the scene says so, apply its edits.
/// @throw ValueError naming the row at fault; IoError for unreadable files; Interrupted.
Scene openScene(const SceneInputs& inputs, Task& task);

/// @brief The scene a .stacks file was made by (its parameters), checked against the table
/// as the file's: @throw IoError "corrupt stacks file '<path>': parameters: ..." (one line).
nlohmann::json savedScene(const std::string& paramsText, const std::string& path);

/// @brief Bake the stacks of a scene (bakeStacks; @a params, @a inputs as openScene gave them)
/// with @a overrides on top of its rows: only the bake's (bakeOnlyRows); the other rows made
/// the stacks. @a points: the rocks instanced in rock layers as VDB points (needs rock-tiles
/// and an output that instances them).
ArchesResult bakeScene(const ArchesParams& params, const Stacks& stacks,
                       const nlohmann::json& inputs, const nlohmann::json& overrides,
                       ArchesOutput output, bool points, Task& task);

/// @brief vdb_arches: openScene, then bakeScene(All); the result's stats and report say what
/// the stacks, the stabilisation, each edit and the bake did.
ArchesResult runArches(const SceneInputs& inputs, Task& task);

/// @brief An edit's stats as JSON (quanta, window, time) and as the CLI's line; and a
/// stabilisation's.
nlohmann::json editStatsJson(const EditStats& e);
nlohmann::json stabilizeStatsJson(const StabilizeStats& s);

/// @brief The rows a saved .stacks file may be baked with differently (the bake's own:
/// voxel-size, half-width, max-memory, weights, material-ids) besides more edits; every other
/// row made the stacks.
const std::vector<std::string>& bakeOnlyRows();
/// @brief bakeOnlyRows as text for messages: "voxel-size, half-width, ... and material-ids".
std::string bakeOnlyRowsText();

} // namespace arches
} // namespace rockvdb
