// SPDX-License-Identifier: Apache-2.0
// rockvdb — game-asset meshes from a level set (issue 37, first part): the surface as a welded
// triangle mesh, its levels of detail (meshoptimizer's topology-preserving simplifier), and
// their geometric error measured against the level set itself.
#pragma once

#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

#include <cstdint>
#include <vector>

namespace rockvdb {
namespace asset {

/// A triangle mesh: world positions (m) and three indices per triangle, outward
/// (counter-clockwise seen from outside), as glTF and the engines expect.
struct TriMesh
{
    std::vector<openvdb::Vec3f> points;
    std::vector<uint32_t> indices;

    size_t triangles() const { return indices.size() / 3; }
};

/// @brief The level set's zero surface (tools::volumeToMesh, no adaptivity: the detail stays
/// for the maps and the simplifier), quads split along their shorter diagonal, vertices
/// shared: closed and manifold where the level set's surface is.
/// @throw ValueError for a grid that is not a float level set or has no surface.
TriMesh surfaceMesh(const openvdb::FloatGrid& grid);

/// One level of detail.
struct Lod
{
    TriMesh mesh;
    size_t target = 0;       ///< triangles asked for
    double simplifyError = 0; ///< meshoptimizer's own error estimate, relative to the extent
};

/// @brief Levels of detail of @a full, each simplified from @a full itself (not from the
/// previous level) to at most targets[i] triangles by meshopt_simplify (edge collapses that
/// keep the topology, quadric error), then ordered for the vertex cache and compacted
/// (meshopt_optimizeVertexCache, meshopt_optimizeVertexFetch). A level the simplifier cannot
/// bring under its target without breaking the topology keeps the triangles it reached.
/// Deterministic: each level is made alone (meshoptimizer is serial), levels side by side.
/// @throw ValueError when a target is 0, exceeds the full mesh's triangles, or the targets do
/// not decrease.
std::vector<Lod> makeLods(const TriMesh& full, const std::vector<size_t>& targets, Task& task);

/// @brief Exact distances from points to a triangle mesh: triangles binned in a uniform grid
/// of cells about twice their mean edge, each query searching shells of cells outward until
/// no nearer triangle can remain. Thread-safe once built.
class TriangleDistance
{
public:
    explicit TriangleDistance(const TriMesh& mesh);
    /// Distance (m) from @a p to the nearest triangle (its index in @a nearest, when given).
    double operator()(const openvdb::Vec3d& p, uint32_t* nearest = nullptr) const;
    /// Distance (m) from @a p to triangle @a t.
    double to(const openvdb::Vec3d& p, uint32_t t) const;

private:
    const TriMesh& mMesh;
    openvdb::Vec3d mOrigin;
    double mCell = 1;
    openvdb::Coord mDims;
    std::vector<uint32_t> mStart, mItems; ///< cell c's triangles: mItems[mStart[c] .. mStart[c + 1])
};

/// How far a level of detail lies from the level set's surface, both ways (metres):
/// - lod -> surface: |phi| (trilinear, tools::BoxSampler) at its vertices and at the centroid
///   and edge midpoints of every triangle; beyond the band, where phi saturates, the exact
///   distance to the full-resolution surface mesh;
/// - surface -> lod: the exact distance from every vertex of the full-resolution surface mesh
///   (points of the zero surface) to the LOD's triangles.
/// hausdorff, the larger of the two maxima, is the (sampled) Hausdorff distance.
struct SurfaceError
{
    double mean = 0, max = 0; ///< lod -> surface
    double back = 0;          ///< surface -> lod, max
    double hausdorff = 0;     ///< max(max, back)
};
SurfaceError surfaceError(const TriMesh& lod, const TriMesh& full, const openvdb::FloatGrid& grid);

} // namespace asset
} // namespace rockvdb
