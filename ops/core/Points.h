// SPDX-License-Identifier: Apache-2.0
// rockvdb — instances as a VDB points grid that Houdini can instance and vdb_asset / pyopenvdb
// read: P, orient (a unit quaternion, components x, y, z, w: Houdini's orient), pscale,
// variant (the index of the piece to copy: a string-free variant, since Houdini reserves
// `instance` for a string path), id (the instance's index) and any further int attributes.
#pragma once

#include <openvdb/Grid.h>
#include <openvdb/math/Quat.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace rockvdb {

struct InstancePoints
{
    std::vector<openvdb::Vec3d> positions;
    std::vector<openvdb::math::Quats> orient; ///< (x, y, z, w)
    std::vector<float> pscale;
    std::vector<int32_t> variant;
    std::vector<openvdb::Vec3f> scale; ///< per-axis scale beside pscale (empty: not written)
    std::vector<openvdb::Vec3f> pivot; ///< the piece's local pivot (empty: not written)
    std::vector<std::pair<std::string, std::vector<int32_t>>> ints; ///< e.g. rock, tile
};

/// @brief The points grid @a name (positions in cells of @a voxelSize) with P, orient, pscale,
/// variant, id (0, 1, ... in the given order), scale and pivot when given, and @a points.ints.
/// Houdini's Copy to Points puts piece point x at P + orient·(pscale·scale·(x − pivot)).
/// Every vector holds one value per position. @throw ValueError when the sizes differ.
openvdb::GridBase::Ptr instancePointsGrid(const InstancePoints& points, double voxelSize,
                                          const std::string& name);

} // namespace rockvdb
