// SPDX-License-Identifier: Apache-2.0
// rockvdb — merging the chunks of one bake (--region, leaf aligned) into the whole grid.
#pragma once

#include <openvdb/openvdb.h>

#include <nlohmann/json.hpp>

#include <string>

#include <vector>

namespace rockvdb {

/// @brief Merge float grids that are chunks of one bake (same name, class, transform and
/// background): each chunk's leaves are copied (a leaf present in several chunks takes the
/// union of their active voxels, which must agree where they overlap), then level sets get
/// their inside/outside tiles back with OpenVDB's signed flood fill above the leaves. Chunks
/// aligned to leaf boundaries merge to exactly the whole bake's values.
/// @throw ValueError for chunks that do not belong together (names, transforms, classes,
///        backgrounds, or two different values for one active voxel).
openvdb::FloatGrid::Ptr mergeChunks(const std::vector<openvdb::FloatGrid::ConstPtr>& chunks);

/// @brief mergeChunks one chunk at a time, so a merge holds one chunk beside the result's
/// tree (vdb_merge reads a chunk file, adds it, lets it go).
class ChunkMerger
{
public:
    /// @brief Add the next chunk (the first gives the name, class, transform, background and
    /// metadata). @throw ValueError as mergeChunks.
    void add(const openvdb::FloatGrid& chunk);
    /// @brief add() that takes @a chunk's nodes instead of copying them (it is left empty).
    void take(openvdb::FloatGrid& chunk);
    /// @brief The merged grid (level sets flood-filled above the leaves); null before add.
    openvdb::FloatGrid::Ptr finish();
    size_t chunks() const { return mCount; }

private:
    openvdb::FloatGrid::Ptr mOut;
    size_t mCount = 0;
};

/// @brief The parameters of the whole bake that a chunk's parameters (core/Chunks.h) are one
/// chunk of: @a params with its `chunk` and `chunks` rows (at the top or in a subcommand's
/// object) back to their defaults; @a chunk receives the chunk's "i/N" ("" when none).
nlohmann::json wholeBakeParams(const nlohmann::json& params, std::string* chunk = nullptr);

} // namespace rockvdb
