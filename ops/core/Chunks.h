// SPDX-License-Identifier: Apache-2.0
// rockvdb — chunked bakes: one bake split into boxes on leaf faces, each baked alone (by
// another process, another machine) and merged back bit for bit (core/Merge.h).
//
// A chunk is named by the split and its index: `chunks` "AxBxC" cuts the bake's whole index
// box (the field's bounds ∩ region, as the bake would fill it) into A·B·C boxes along x, y, z
// at multiples of 8 voxels (a ChunkGrid may ask for coarser cuts: the material-stack bake cuts
// x and y on its 128-voxel sweep tiles), and `chunk` "i/N" bakes box i only (i = x + A·(y + B·z)). Every
// voxel value is a pure function of its index and chunk boxes hold whole leaves, so the merged
// chunks are the whole bake. The whole box is the same in every process (a pure function of
// the parameters), so farm jobs (`--chunk i/N`, one process each) agree on it without talking.
//
// A --plan run (requestPlan) reports the whole box, the estimates and the split a memory
// budget needs, as JSON, instead of baking: rockvdb.distributed reads it to size its jobs.
#pragma once

#include <openvdb/openvdb.h>

#include <nlohmann/json.hpp>

#include <array>
#include <exception>
#include <functional>
#include <string>

namespace rockvdb {

struct ChunkSpec
{
    std::array<int, 3> dims{{1, 1, 1}};
    bool dimsGiven = false; ///< "AxBxC" given; else chosen for count (autoChunkDims)
    int index = -1;         ///< < 0: the whole bake
    int count = 0;

    bool active() const { return index >= 0; }

    /// @brief Parse the `chunks` ("AxBxC" or "") and `chunk` ("i/N" or "") rows of @a op.
    /// @throw ValueError naming the row: malformed text, i outside [0, N), N ≠ A·B·C.
    static ChunkSpec parse(const std::string& chunks, const std::string& chunk, const char* op);
};

/// Where a stage may cut: at multiples of @a align voxels (8: leaf faces; the material-stack
/// bake cuts on its 128-voxel sweep tiles), along z only when @a splitZ.
struct ChunkGrid
{
    int align = 8;
    bool splitZ = true;
};

/// @brief A·B·C = @a count chunks whose boxes are closest to cubes for @a whole.
/// @throw ValueError when @a grid forbids z cuts and no A·B·1 split makes @a count.
std::array<int, 3> autoChunkDims(const openvdb::CoordBBox& whole, int count, ChunkGrid grid = {});

/// @brief The split @a spec makes of @a whole (its dims, or autoChunkDims for its count).
std::array<int, 3> chunkDims(const ChunkSpec& spec, const openvdb::CoordBBox& whole,
                             ChunkGrid grid = {});

/// @brief Box @a index of @a whole cut into @a dims at multiples of @a grid.align; may be
/// empty when the cuts outnumber the leaves.
openvdb::CoordBBox chunkBox(const openvdb::CoordBBox& whole, const std::array<int, 3>& dims,
                            int index, ChunkGrid grid = {});

/// @brief "4x4x1".
std::string chunkDimsText(const std::array<int, 3>& dims);

/// Thrown by a bake when a plan was requested: the plan (JSON) instead of grids.
class PlanReady : public std::exception
{
public:
    explicit PlanReady(nlohmann::json plan) : mPlan(std::move(plan)) {}
    const char* what() const noexcept override { return "plan ready"; }
    const nlohmann::json& plan() const { return mPlan; }

private:
    nlohmann::json mPlan;
};

/// @brief Ask the next bake of this process for a plan: the whole box and estimates and, for
/// @a budgetBytes > 0, the fewest chunks whose estimates fit it (0: the spec's own split).
void requestPlan(double budgetBytes);
bool planRequested();

/// @brief When a plan is requested, throw PlanReady for a bake of @a whole at @a voxelSize
/// whose estimated peak bytes for a box are @a estimate(box); otherwise return.
/// @throw ValueError when no split into boxes of at least a leaf fits the budget.
void reportPlanIfRequested(const std::string& op, const openvdb::CoordBBox& whole,
                           double voxelSize, const ChunkSpec& spec,
                           const std::function<double(const openvdb::CoordBBox&)>& estimate,
                           ChunkGrid grid = {});

} // namespace rockvdb
