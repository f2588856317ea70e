// SPDX-License-Identifier: Apache-2.0
// rockvdb — a UV atlas for asset meshes (issue 37): charts by box projection, packed on shelves.
//
// Each triangle goes to the axis its normal points along most (±x, ±y, ±z); connected
// triangles of one axis form a chart, projected onto that axis' plane (never mirrored: seen
// from outside, u runs right and v up). Every chart keeps the same texel density (metres per
// texel), so a normal map's detail is even over the rock. Charts are packed on shelves,
// tallest first, with a gap of `padding` texels around each, at the largest density that fits
// [0, 1]². A projection stretches a triangle by at most 1 / cos(54.7°) = 1.73 in one
// direction and never folds it, so charts have no overlaps and no flips by construction.
// A dedicated unwrapper (xatlas, Blender's Smart UV Project with angle-based charts and
// least-squares conformal maps) makes fewer seams and less stretch; this one is chosen for
// being exact about what matters for baking: no overlap, no flip, even texel density,
// deterministic, and fast.
#pragma once

#include <rockvdb/asset/Lods.h>

#include <openvdb/openvdb.h>

#include <vector>

namespace rockvdb {
namespace asset {

/// A mesh with texture coordinates: a vertex per (mesh vertex, chart), so seams split.
struct UvMesh
{
    std::vector<openvdb::Vec3f> points;
    std::vector<openvdb::Vec2f> uvs;      ///< in [0, 1]², v up (glTF flips v on write)
    std::vector<uint32_t> indices;        ///< outward triangles, as the input's
    std::vector<uint32_t> source;         ///< the input vertex of each vertex
    std::vector<uint32_t> chartOf;        ///< the chart of each triangle
    size_t charts = 0;
    double texelsPerMetre = 0;            ///< at textureSize

    size_t triangles() const { return indices.size() / 3; }
};

/// @brief The atlas of @a mesh for a square texture of @a textureSize texels with @a padding
/// texels between charts (and at the border).
/// @throw ValueError for a texture size below 8 or above 16384, a padding below 0 or above
/// textureSize / 8, or a mesh without triangles.
UvMesh atlas(const TriMesh& mesh, int textureSize, int padding);

} // namespace asset
} // namespace rockvdb
