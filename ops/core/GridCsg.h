// rockvdb — CSG on baked level-set grids (hard: tools::csg*, smooth: the §4.2 operator).
#pragma once

#include "Combinators.h"

#include <openvdb/openvdb.h>

#include <vector>

namespace rockvdb {

/// @brief Fold @a op over level sets left to right into a new level set.
/// Grids whose transform differs from the first are resampled onto it
/// (tools::resampleToMatch, a level-set rebuild). With @a smoothRadius = 0 this is
/// tools::csgUnion / csgIntersection / csgDifference on deep copies. With R > 0, each input's
/// band is first widened by tools::dilateSdf (fast sweeping) so every value the smooth
/// operator reads within R of the result's band is a real distance; the blend is then
/// evaluated per voxel and clipped back to the first grid's half width.
/// @note Inputs are never modified. The result is named after the first input.
openvdb::FloatGrid::Ptr csgGrids(CsgOp op, const std::vector<openvdb::FloatGrid::ConstPtr>& grids,
                                 double smoothRadius = 0.0);

} // namespace rockvdb
