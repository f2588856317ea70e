// SPDX-License-Identifier: Apache-2.0
// rockvdb — small helpers every stage needs when it builds grids by hand: integer floor
// division for cell / tile indices, and the empty level-set and attribute grids a stage fills
// (linear transform, grid class, name: the DESIGN.md conventions in one place).
#pragma once

#include <openvdb/openvdb.h>

#include <string>

namespace rockvdb {

/// @brief ⌊a / b⌋ for b > 0 (C++'s / rounds towards zero).
inline int floorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

/// @brief The coordinate scaled by an integer (cell index → voxel index).
inline openvdb::Coord scaled(const openvdb::Coord& c, int s)
{
    return openvdb::Coord(c[0] * s, c[1] * s, c[2] * s);
}

/// @brief An empty narrow-band level set: background halfWidth·voxelSize (pass the
/// background), class level set, the given name, on `transform`.
inline openvdb::FloatGrid::Ptr emptyLevelSet(const std::string& name,
                                             openvdb::math::Transform::Ptr transform,
                                             float background)
{
    auto grid = openvdb::FloatGrid::create(background);
    grid->setTransform(transform);
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    grid->setName(name);
    return grid;
}

/// @brief An empty level set on a linear transform of `voxelSize` (cell-centred at the origin).
inline openvdb::FloatGrid::Ptr emptyLevelSet(const std::string& name, double voxelSize,
                                             float background)
{
    return emptyLevelSet(name, openvdb::math::Transform::createLinearTransform(voxelSize),
                         background);
}

/// @brief An empty attribute grid (class unknown: ids, materials) sharing `transform`.
inline openvdb::FloatGrid::Ptr emptyAttribute(const std::string& name,
                                              openvdb::math::Transform::Ptr transform,
                                              float background)
{
    auto grid = openvdb::FloatGrid::create(background);
    grid->setTransform(transform);
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->setName(name);
    return grid;
}

} // namespace rockvdb
