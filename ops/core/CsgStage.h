// SPDX-License-Identifier: Apache-2.0
// rockvdb — the CSG of level-set files and grids as a stage: vdb_csg and rockvdb.csg run one
// entry point (runCsg) over one table (csgSchema): the hard or smooth fold of GridCsg.h with
// the inputs' id grids carried, stamped with one provenance.
#pragma once

#include <rockvdb/core/GridCsg.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>

#include <vector>

namespace rockvdb {

constexpr const char* kCsgTool = "vdb_csg";

/// What a CSG takes beside its operation and inputs. Defaults, ranges and help: csgSchema().
struct CsgParams
{
    CsgParams();
    double smooth;      ///< R of the smooth operator (m); 0 = hard CSG (tools::csg*)
    bool ids;           ///< carry the inputs' id grids
    double maxMemoryGB; ///< 0 = 75% of RAM
};

/// @brief The table of CsgParams (op "csg"; vdb_csg's options, rockvdb.csg's keywords).
const Schema<CsgParams>& csgSchema();

/// @brief Fold @a op over the inputs (csgWithIds; their id grids only with params.ids):
/// grids = [surface, id grids...], each stamped with the table's values and @a names (the
/// operation, the inputs as the front-end names them, their own provenance under "sources",
/// which a replay skips). stats: active_voxels, id_grids, phases.
/// @throw ValueError for bad parameters or inputs that do not combine.
StageResult runCsg(CsgOp op, const CsgParams& params, const std::vector<CsgInput>& inputs,
                   const nlohmann::json& names, Task& task);

} // namespace rockvdb
