// SPDX-License-Identifier: Apache-2.0
// rockvdb — widen a level set's narrow band by whole voxel layers (a faster tools::dilateSdf).
#pragma once

#include <openvdb/openvdb.h>

namespace rockvdb {

/// @brief A copy of the level set @a grid whose band is grown by @a layers face-neighbour
/// voxel layers, the new voxels holding first-order upwind distances (|∇φ| = 1, Godunov's
/// scheme, the update OpenVDB's fast sweeping uses); the input's own voxels keep their values.
///
/// Same topology and, to within rounding, the same values as tools::dilateSdf(grid, layers):
/// where fast sweeping orders its updates by sweeping the whole band in eight directions, this
/// computes the layers in order, each from the ones before it and then relaxed twice with its
/// own voxels (Jacobi, so the result does not depend on the number of threads). On the demo's
/// amplified cliff (13.2 M voxels + 11.5 M new) 1.2 s instead of 6–7 s, mean difference
/// 0.0002 voxel, 131 voxels more than 0.1 voxel (at most 0.37: fast sweeping also lets a
/// front voxel take a path through a later layer); on a sphere widened by 20 layers the error
/// against the exact distance is the same as fast sweeping's (mean 0.030, max 0.096 voxel).
///
/// Active tiles are voxelised first. The background stays the input's; new voxels' values
/// may exceed it (callers clamp).
/// @param layers  number of voxel layers (≥ 0) added on each side.
/// @throw ValueError unless @a grid is a level set.
openvdb::FloatGrid::Ptr extendBand(const openvdb::FloatGrid& grid, int layers);

} // namespace rockvdb
