// SPDX-License-Identifier: Apache-2.0
// rockvdb — a rock pile's instances as glTF instancing (issue 37): the points of
// `vdb_rockpile pile --points` (P = each instance's seed, rock = its library rock) and the tile
// set the rocks come from. A pile instances the few unique rocks of a tile set many times,
// translated only (aperiodic-rock-piles §6: the corner cubes are copied, never rotated), so a
// game engine draws each unique rock's mesh once per instance (EXT_mesh_gpu_instancing)
// instead of loading every copy.
#pragma once

#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <cstdint>
#include <string>
#include <vector>

namespace rockvdb {
namespace rockpile {
struct TileSet;
}
namespace asset {

/// One unique rock and where its copies stand.
struct Prototype
{
    size_t rock = 0;                   ///< index into the tile set's rocks (the points' 'rock')
    openvdb::FloatGrid::Ptr grid;      ///< its level set, in the tile set's canonical voxels
    openvdb::Vec3d pivot;              ///< its seed in those voxels' world frame (m): the mesh's origin
    std::vector<openvdb::Vec3d> seeds; ///< world seed of every copy (m), sorted (x, then y, then z)
};

struct PileInstances
{
    std::vector<Prototype> prototypes; ///< by rising rock index
    size_t instances = 0;              ///< points read
    double voxelSize = 0;              ///< the tile set's voxel (m)
};

/// @brief The instances of a points file (grid 'rocks', else its only points grid, with an
/// int32 attribute 'rock') whose rocks come from the tile set file @a tilesPath (written by
/// `vdb_rockpile tiles`). Every point must stand where a copy of its rock can (its seed
/// shifted by whole voxels): otherwise the points and the tile set do not belong together.
/// Each prototype's level set is rebuilt from the tile set (rockpile/RockTiles.h,
/// rockLevelSet), half width @a halfWidth voxels.
/// @throw ValueError naming the file and the point for missing grids or attributes, rock
/// indices outside the set, points off their rock's lattice, or no points; IoError for
/// unreadable files.
PileInstances readPileInstances(const std::string& pointsPath, const std::string& tilesPath,
                                double halfWidth, Task& task);

/// One instance as the points hold it: its library rock and its seed (world, m).
struct PilePoint
{
    int64_t rock = 0;
    openvdb::Vec3d position;
};

/// @brief The instances of @a points in the tile set @a set (what readPileInstances makes of
/// a file's points); @a source names the points in messages.
/// @throw ValueError as readPileInstances.
PileInstances pileInstances(const rockpile::TileSet& set, const std::vector<PilePoint>& points,
                            double halfWidth, const std::string& source, Task& task);

} // namespace asset
} // namespace rockvdb
