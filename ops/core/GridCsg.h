// SPDX-License-Identifier: Apache-2.0
// rockvdb — CSG on baked level-set grids (hard: tools::csg*, smooth: the §4.2 operator).
#pragma once

#include <rockvdb/core/Combinators.h>

#include <openvdb/openvdb.h>

#include <string>
#include <vector>

namespace rockvdb {

/// @brief Fold @a op over level sets left to right into a new level set.
/// Grids whose transform differs from the first are resampled onto it
/// (tools::resampleToMatch, a level-set rebuild). With @a smoothRadius = 0 this is
/// tools::csgUnion / csgIntersection / csgDifference on deep copies. With R > 0, each input's
/// band is first widened by extendBand (first-order upwind distances) so every value the smooth
/// operator reads within R of the result's band is a real distance; the blend is then
/// evaluated per voxel and clipped back to the first grid's half width.
/// @note Inputs are never modified. The result is named after the first input.
/// @throw ValueError when the resampled copies or the widened bands are estimated above
///        @a maxMemoryBytes (0: 75% of RAM), before anything is allocated.
openvdb::FloatGrid::Ptr csgGrids(CsgOp op, const std::vector<openvdb::FloatGrid::ConstPtr>& grids,
                                 double smoothRadius = 0.0, double maxMemoryBytes = 0);

/// @brief An id grid (block_id, rock_id, material: integer ids, background −1) for the result
/// of csgGrids(@a op, @a surfaces): each active voxel of @a result takes the id of the input
/// whose surface the result follows there — the smallest value for a union, the largest for
/// an intersection (ties: the first input) — read from that input's id grid (@a ids[i], null
/// when the input has none: −1). In a difference every id comes from the first input (the cut
/// faces belong to the solid that was cut; −1 where its id grid does not reach). Inputs on
/// other transforms are sampled in world space (trilinear values, nearest ids).
/// @return A float grid named @a name with @a result's active topology.
openvdb::FloatGrid::Ptr csgAttribute(CsgOp op,
                                     const std::vector<openvdb::FloatGrid::ConstPtr>& surfaces,
                                     const std::vector<openvdb::FloatGrid::ConstPtr>& ids,
                                     const openvdb::FloatGrid& result, const std::string& name);

/// One input of a CSG with its id grids (block_id, rock_id, material, ...).
struct CsgInput
{
    openvdb::FloatGrid::ConstPtr surface;
    std::vector<openvdb::FloatGrid::ConstPtr> ids; ///< the first of each name is used
};

/// @brief A file's level set @a gridName ("" = 'surface' or its only level set) and, with
/// @a withIds, its id grids: the float grids that are not level sets.
/// @a path "-" reads stdin. @throw IoError / ValueError naming the file.
CsgInput readCsgInput(const std::string& path, const std::string& gridName, bool withIds);

/// @brief csgGrids over the inputs' surfaces, then csgAttribute for every id grid name the
/// inputs hold, in order of first appearance (an input without that name: −1): what
/// vdb_csg and rockvdb.csg make. @return [surface, id grids...], unstamped.
openvdb::GridPtrVec csgWithIds(CsgOp op, const std::vector<CsgInput>& inputs,
                               double smoothRadius = 0.0, double maxMemoryBytes = 0);

} // namespace rockvdb
