// SPDX-License-Identifier: Apache-2.0
// rockvdb — a baked level set as a Field (e.g. a 3D terrain with overhangs from Houdini).
#pragma once

#include <rockvdb/core/Field.h>

#include <openvdb/openvdb.h>

namespace rockvdb {

/// @brief Trilinear samples of a level-set grid: a distance within its narrow band and
/// ±background beyond (a lower bound of the distance there). The band is first widened
/// (widenBand) to at least @a exactWidth metres, so callers that read
/// distances or gradients that far from the surface get real values.
/// The field shares @a grid (or its widened copy) and never modifies it.
/// @throw ValueError unless @a grid is a level set.
/// @throw ValueError when widening is estimated above @a maxMemoryBytes (0: 75% of RAM).
FieldPtr levelSetField(openvdb::FloatGrid::ConstPtr grid, double exactWidth = 0.0,
                       double maxMemoryBytes = 0.0);

/// @brief @a grid itself when its band already reaches @a exactWidth metres, else a copy
/// widened by extendBand (first-order upwind distances, as tools::dilateSdf): whole
/// face-neighbour layers, one more than exactWidth needs
/// (for trilinear samples at the edge), clamped to and with background at the new width.
/// Face layers reach exactWidth along the axes and about width + (exactWidth − width)/√3
/// along the diagonals; voxels beyond hold ±background.
/// @throw ValueError unless @a grid is a level set.
/// @throw ValueError when the widened band is estimated above @a maxMemoryBytes (0: 75% of
///        RAM) before widening: active tiles (which extendBand voxelises) count at their
///        full voxel count.
openvdb::FloatGrid::ConstPtr widenBand(openvdb::FloatGrid::ConstPtr grid, double exactWidth,
                                       double maxMemoryBytes = 0.0);

} // namespace rockvdb
