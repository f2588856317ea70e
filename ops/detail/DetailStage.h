// SPDX-License-Identifier: Apache-2.0
// rockvdb — the surface-detail stage's front door: its parameter table and its one entry
// point, runDetail (vdb_detail and rockvdb.detail are thin wrappers over it).
//
// The table's rows are what a user gives (a skeleton or blend as a file path or inline JSON);
// engine() turns them into the DetailParams the detail field works with.
#pragma once

#include <rockvdb/detail/Detail.h>

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace rockvdb {
namespace detail {

/// The tool the entry point records as the generator of what it makes.
constexpr const char* kDetailTool = "vdb_detail";

/// vdb_detail's options, rockvdb.detail's keywords: one member per row of detailSchema(),
/// which holds every default (a default-constructed DetailStageParams holds them).
struct DetailStageParams
{
    DetailStageParams();

    double warpAmplitude;
    std::string warpRelief;   ///< "turbulence" or an image path
    double warpScale;
    int warpOctaves;
    double warpSharpness;
    double gaborAmplitude, gaborFrequency, gaborBandwidth, gaborOrientation, gaborImpulses;
    double gaborFalloff;
    bool gaborIsotropic;
    std::array<double, 2> tilt;
    std::optional<std::array<double, 3>> directionAxis;
    nlohmann::json directionSkeleton; ///< null or {"segments": [...]} (a file: its content)
    bool directionCurvature;
    std::string singular;
    uint64_t seed;
    nlohmann::json blend;             ///< null or {"warp_amplitude": ...} (a file: its content)
    BakeParams bake;                  ///< voxel size and band default to the input's

    /// @brief The detail field's parameters (skeleton and blend files read here).
    /// @throw ValueError / IoError for conflicting directions, unreadable or malformed files.
    DetailParams engine() const;
};

/// @brief The table of DetailStageParams (vdb_detail, rockvdb.detail).
const Schema<DetailStageParams>& detailSchema();

/// What runDetail works on (grids, read by the caller) and how provenance names them.
struct DetailInputs
{
    openvdb::FloatGrid::ConstPtr grid;              ///< the level set to detail
    std::vector<openvdb::FloatGrid::Ptr> ids;      ///< id grids carried onto the result
    openvdb::FloatGrid::ConstPtr blendMask;        ///< weights of the blend, or null
    nlohmann::json names = nlohmann::json::object(); ///< e.g. {"input": path, "grid": name}
};

struct DetailResult : StageResult
{
    BakeResult bake;                           ///< bake.surface: the detailed level set
    std::vector<openvdb::FloatGrid::Ptr> ids;  ///< inputs.ids carried onto it
};

/// @brief Detail a level set and re-bake it (renormalised), carrying its id grids; every grid
/// stamped with provenance: the table's values (voxel size and band as used), @a inputs.names,
/// and the input's own provenance under "sources" (which a replay skips).
/// @throw ValueError for a grid that is not a level set, a blend without a mask (or the
/// reverse) and bad parameters; Interrupted when the task is cancelled.
DetailResult runDetail(const DetailStageParams& params, const DetailInputs& inputs, Task& task);

} // namespace detail
} // namespace rockvdb
