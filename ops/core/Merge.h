// rockvdb — merging the chunks of one bake (--region, leaf aligned) into the whole grid.
#pragma once

#include <openvdb/openvdb.h>

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

} // namespace rockvdb
