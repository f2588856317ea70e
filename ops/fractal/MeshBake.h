// rockvdb — narrow-band level sets of closed triangle meshes, baked directly (fractal rocks).
//
// Each mesh ("part") is baked alone on a dense box around it: every triangle visits the voxels
// of its bounding box grown by the band and keeps, per voxel, the nearest triangle (squared
// distance, the plane distance first as an early out); the sign comes from the nearest
// feature's angle-weighted pseudo-normal (Bærentzen & Aanæs 2005: exact for closed, consistently
// oriented meshes), so no flood fill is needed inside the band. The parts' leaves are then
// united in part order (per voxel the smaller value, and its part's id), and OpenVDB's
// signedFloodFill gives the insides their tiles.
//
// Why not tools::meshToVolume: measured on fractal rocks it costs 20–50 ms for a 9 000-voxel
// pebble and ~90–160 ms for a 1 m rock at 1 cm (bench `fractal`); this bake is exact in the
// band as well and parallel over parts (a scatter) or over slabs of one part (a big rock).
#pragma once

#include <rockvdb/core/Field.h>
#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <vector>

namespace rockvdb {
namespace fractal {

/// One closed, outward-oriented triangle mesh (world points, m).
struct MeshPart
{
    const std::vector<Vec3d>* points = nullptr;
    const std::vector<openvdb::Vec3I>* triangles = nullptr;
};

/// @brief The union of @a parts as a narrow-band level set 'surface' (half width @a halfWidth
/// voxels of @a voxelSize m, on the cell-centred linear transform), and when @a ids is given
/// 'rock_id' over the same voxels (the index of the part whose value the voxel takes).
/// @a disjoint: the parts' insides do not meet (a scatter): their leaves are united by the min
/// of their band values and one flood fill follows. Otherwise (overlapping rocks, a cave's
/// chain) each part is flood-filled alone and the union takes the min of full values, inside
/// tiles included. Bitwise the same at any thread count. The task is checked per part / slab.
openvdb::FloatGrid::Ptr bakeMeshes(const std::vector<MeshPart>& parts, double voxelSize,
                                   double halfWidth, bool disjoint, Task& task,
                                   openvdb::FloatGrid::Ptr* ids = nullptr);

} // namespace fractal
} // namespace rockvdb
