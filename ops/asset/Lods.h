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
/// Deterministic (meshoptimizer is serial).
/// @throw ValueError when a target is 0, exceeds the full mesh's triangles, or the targets do
/// not decrease.
std::vector<Lod> makeLods(const TriMesh& full, const std::vector<size_t>& targets, Task& task);

/// How far a mesh lies from a level set's surface: |phi| (trilinear, tools::BoxSampler) at
/// its vertices and at the centroid and edge midpoints of every triangle, in metres. This is
/// the mesh-to-surface half of the Hausdorff distance (points outside the band read the
/// background: an upper bound there).
struct SurfaceError
{
    double mean = 0, max = 0;
};
SurfaceError surfaceError(const TriMesh& mesh, const openvdb::FloatGrid& grid);

} // namespace asset
} // namespace rockvdb
