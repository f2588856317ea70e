// SPDX-License-Identifier: Apache-2.0
// rockvdb — texture maps baked from the level set, not from a mesh (issue 37): a tangent-space
// normal map, so a low-poly LOD carries the high-resolution surface's normals (Gabor ridges,
// erosion) in its texture, and ambient occlusion (asset/Occlusion.h) at the same points.
//
// For each texel of a chart: the point p on the LOD triangle under the texel centre, moved to
// the level set's zero along its gradient (two Newton steps, q = p - phi(p) grad phi), and the
// gradient's direction there (the trilinear sample of the voxels' central differences, see
// SurfaceField) is the high-resolution normal. It is written in the LOD's tangent frame as
// engines rebuild it: the vertex normal, tangent and handedness interpolated over the
// triangle (vertexFrames), the tangent made orthogonal to the normal, the bitangent their
// cross product times the handedness; rgb = (n·t, n·b, n·n_vertex) / 2 + 1/2 (glTF's convention: +y is +v, "OpenGL").
// The occlusion, when asked, is the Occlusion grid's value at q; the mask, the id at q.
// Texels outside every chart take the nearest covered texel's value (dilation over the whole
// texture), so bilinear reads and mip levels at chart borders stay on the chart's colours.
#pragma once

#include <rockvdb/asset/Atlas.h>
#include <rockvdb/asset/Occlusion.h>
#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <vector>

namespace rockvdb {
namespace asset {

/// Per vertex: unit normal (area-weighted face normals over the input vertex, so seams share
/// it) and tangent (xyz along +u, w = ±1 handedness), as glTF's NORMAL and TANGENT.
struct VertexFrames
{
    std::vector<openvdb::Vec3f> normals;
    std::vector<openvdb::Vec4f> tangents;
};
VertexFrames vertexFrames(const UvMesh& mesh);

struct BakedMaps
{
    int size = 0;
    std::vector<openvdb::Vec3f> normal; ///< size² texels, row 0 at v = 0 (bottom), values in [0, 1]
    std::vector<float> occlusion;       ///< size² texels in [0, 1] (1 = open), or empty
    std::vector<uint8_t> covered;       ///< 1 where a triangle covers the texel centre
    std::vector<int32_t> mask;          ///< size² ids (SurfaceField::mask), -1: none there; or empty
};

/// The level set the maps are baked from, with its gradient grid (tools::gradient: central
/// differences of the voxels, in world units), made once and shared by every LOD's bake. The
/// gradient at a point is the trilinear sample of that grid: the same as central differences
/// of trilinear samples a voxel apart (trilinear interpolation is linear and commutes with
/// whole-voxel shifts), in 8 lookups instead of 48.
struct SurfaceField
{
    /// @throw ValueError when @a grid is not a level set.
    explicit SurfaceField(const openvdb::FloatGrid& grid, const openvdb::FloatGrid* mask = nullptr);
    const openvdb::FloatGrid& grid;
    openvdb::Vec3SGrid::Ptr gradient;
    /// An id grid (material, block_id, rock_id: integer ids, background -1) baked as a mask:
    /// each texel takes the id of the voxel nearest its surface point, else of the nearest of
    /// the voxels round it that holds one (ids live in the band). Same transform as grid.
    const openvdb::FloatGrid* mask = nullptr;
};

/// @brief Bake @a field's normals (and @a occlusion's values, when given) into @a mesh's atlas
/// at @a size² texels (the atlas must have been made for this size).
BakedMaps bakeMaps(const UvMesh& mesh, const VertexFrames& frames, const SurfaceField& field,
                   int size, const Occlusion* occlusion, Task& task);
/// @brief As above, making the SurfaceField of @a grid. @throw ValueError when @a grid is not
/// a level set.
BakedMaps bakeMaps(const UvMesh& mesh, const VertexFrames& frames, const openvdb::FloatGrid& grid,
                   int size, const Occlusion* occlusion, Task& task);

/// @brief A normal map texel back to a world-space unit normal, given the frame at that point
/// (the inverse of the encoding above; for tests and for checking a bake).
openvdb::Vec3d decodeNormal(const openvdb::Vec3f& rgb, const openvdb::Vec3d& normal,
                            const openvdb::Vec4d& tangent);

/// How far a LOD's normals are from the level set's, with and without its normal map.
struct NormalMapError
{
    double mapDegrees = 0;  ///< the map's normal (bilinear, decoded in the LOD's frame) vs the SDF's
    double meshDegrees = 0; ///< the LOD's interpolated vertex normal vs the SDF's
    size_t samples = 0;
};

/// @brief Mean angles (area-weighted, 4 points per triangle, not texel centres) between the
/// level set's normal at the LOD point's projection onto the zero set and (a) the normal map's
/// bilinear value decoded as an engine does, (b) the LOD's own interpolated normal.
NormalMapError normalMapError(const UvMesh& mesh, const VertexFrames& frames, const BakedMaps& maps,
                              const SurfaceField& field);
NormalMapError normalMapError(const UvMesh& mesh, const VertexFrames& frames, const BakedMaps& maps,
                              const openvdb::FloatGrid& grid);

} // namespace asset
} // namespace rockvdb
