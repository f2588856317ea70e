// SPDX-License-Identifier: Apache-2.0
// rockvdb — what every stage's entry point returns, whichever front-end called it.
//
// A stage has one entry point, run<Stage>(params, inputs, task) -> <Stage>Result, a
// StageResult with the stage's own extras (a tile, meshes, points). The CLI main prints
// `report` and writes `grids`; the Python binding converts `grids` and `stats` and returns
// them. Neither knows the stage's steps, so every guard of the entry holds on both.
#pragma once

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace rockvdb {

struct StageResult
{
    /// What the tool writes to its -o file (writeGrids puts ids first, level sets last).
    openvdb::GridPtrVec grids;
    /// Counts and times (keys with '_'), and "phases": [{"name", "seconds"}] in the order the
    /// entry ran them: Python returns this dict, vdb_* --stats writes it.
    nlohmann::json stats = nlohmann::json::object();
    /// What every grid above carries as rockvdb:params (the table's values and the inputs).
    nlohmann::json provenance;
    /// stats as the CLI prints them on stderr, one line each (without the tool's prefix).
    std::vector<std::string> report;
};

/// @brief The one provenance builder: the table's values @a params with @a inputs' keys set on
/// top (the stage's names for its inputs, such as "from-tile" or "support", never a row's).
nlohmann::json stageProvenance(nlohmann::json params, const nlohmann::json& inputs);

/// @brief What provenance records of a grid given in memory rather than as a file: its name,
/// and its own generator and parameters when it has rockvdb provenance.
nlohmann::json gridSource(const openvdb::GridBase& grid);

/// @brief Stamp @a provenance on every grid of @a grids (generator @a tool) and keep it in
/// @a result.provenance; @a result.grids becomes @a grids.
void stampResult(StageResult& result, const char* tool, openvdb::GridPtrVec grids,
                 const nlohmann::json& provenance);

/// @brief Stamp @a result.provenance (generator @a tool) on the grids a stage writes beside
/// its -o grids (points, a library, weights); null entries are skipped.
void stampExtras(const StageResult& result, const char* tool, const openvdb::GridPtrVec& extras);

/// @brief A bake's counts and times as stats (active_voxels, leaves, ... seconds).
nlohmann::json bakeStatsJson(const BakeStats& stats);

/// @brief The line a CLI prints of a bake: "bake: N active voxels, cull ... s, fill ... s,
/// finish ... s".
std::string bakeReport(const BakeStats& stats);

/// @brief The task's phases as stats: [{"name": ..., "seconds": ...}].
nlohmann::json phasesJson(const Task& task);

} // namespace rockvdb
