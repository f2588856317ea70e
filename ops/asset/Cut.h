// SPDX-License-Identifier: Apache-2.0
// rockvdb — one block or rock cut out of a level set by its id (issue 37): a block of a
// `vdb_blocks` tile, a rock of a `vdb_rockpile tiles` set, a block of an amplified cliff, each
// as its own asset.
//
// The id grids (block_id, rock_id: floats holding integer ids, DESIGN "Grid names") hold ids
// only in the narrow band; a block's deep interior has none. Ownership is therefore spread
// inwards: inside the surface (φ < 0), every voxel of the block's box takes the id of the band
// voxel nearest by 6-connected steps (a breadth-first search from all band voxels at once, in
// a fixed order). The block is the voxels it owns; where it touches another block without a
// gap (blocks fused in the union), the two owned regions meet and a cut face is made there
// (a voxel pair −h/2 | +h/2), and the result is rebuilt as a level set
// (tools::levelSetRebuild). A rock that stands apart keeps its band values bit for bit.
#pragma once

#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <map>
#include <vector>

namespace rockvdb {
namespace asset {

/// @brief An id grid's value as an integer id (ids are floats holding integers below 2^24,
/// background -1): false for anything else.
bool asId(float value, int& id);

/// @brief The distinct ids in @a ids's active voxels where @a surface is inside its band
/// (integers ≥ 0), sorted.
std::vector<int> surfaceIdList(const openvdb::FloatGrid& surface, const openvdb::FloatGrid& ids);

/// @brief The index-space box of every such id's voxels (one pass over the id grid).
std::map<int, openvdb::CoordBBox> surfaceIdBoxes(const openvdb::FloatGrid& surface,
                                                 const openvdb::FloatGrid& ids);

struct CutResult
{
    openvdb::FloatGrid::Ptr grid; ///< the block's level set (same transform and band)
    bool rebuilt = false;         ///< a cut face was made (fused to a neighbour), or neighbours were dropped
    size_t voxels = 0;            ///< voxels of the box searched
};

/// @brief Block @a id of @a surface, owned as above; @a box, when given, is its entry of
/// surfaceIdBoxes (saves a pass over the id grid per id).
/// @throw ValueError when @a id is not in @a ids (the message lists the range there is), when
/// the grids' transforms differ, or when the block's box exceeds @a maxVoxels voxels.
CutResult cutId(const openvdb::FloatGrid& surface, const openvdb::FloatGrid& ids, int id,
                size_t maxVoxels, Task& task, const openvdb::CoordBBox* box = nullptr);

} // namespace asset
} // namespace rockvdb
