// SPDX-License-Identifier: Apache-2.0
// rockvdb — ambient occlusion from a signed distance field, by cone tracing (issue 37).
//
// A game asset's occlusion map says how much of the sky each surface point sees, within a
// distance D (nearer geometry occludes, farther does not). It is computed from a distance
// field, not by casting rays at a mesh:
//   - the field: the asset's LOD0 mesh as a signed distance field (tools::meshToSignedDistanceField) at a coarse voxel
//     hc = max(h, D / 12) with an exterior band reaching D, so a cone can be traced through it
//     (the stage's own narrow band is 3 voxels wide: a ray leaves it at once);
//   - the occlusion at a surface point p with normal n: kCones cones of half angle θ = 20°
//     around directions d_i spread evenly (in solid angle) over the part of the hemisphere
//     whose cones clear the tangent plane (elevation ≥ θ). Each cone is traced from
//     o = p + hc·n by sphere tracing; its visibility is min over the steps of
//     φ(o + t·d) / (t·sin θ), clamped to [0, 1] (the share of the cone's cross-section left
//     open, as in soft-shadow cone tracing). The occlusion is the cosine-weighted mean of the
//     visibilities: 1 on a flat or convex surface, lower in creases and pits;
//   - occlusion is smooth at the scale of hc, so it is computed once per coarse voxel next to
//     the surface (from the surface point nearest the voxel) into a grid, and every LOD's
//     texels sample that grid trilinearly at their point on the level set.
// Deterministic: each voxel's value is a pure function of the field.
#pragma once

#include <rockvdb/asset/Lods.h>
#include <rockvdb/core/Task.h>

#include <openvdb/openvdb.h>

namespace rockvdb {
namespace asset {

struct Occlusion
{
    double distance = 0;            ///< D, metres
    double voxel = 0;               ///< hc, metres
    openvdb::FloatGrid::Ptr field;  ///< the mesh's distance, exterior band ≥ D
    /// occlusion (1 = open sky) at voxels within 2 hc of the surface, background 1: sampled
    /// trilinearly at a point on the surface, its eight voxels are all there
    openvdb::FloatGrid::Ptr value;
};

/// @brief Cone-traced occlusion of the closed mesh @a mesh within @a distance metres, on a
/// field of voxel max(@a fineVoxel, distance / 12).
/// @throw ValueError for a distance that is not positive and finite or a mesh without triangles.
Occlusion occlusion(const TriMesh& mesh, double fineVoxel, double distance, Task& task);

/// @brief The cone-traced occlusion at surface point @a p with outward unit normal @a n, in
/// [0, 1] (exposed for tests: the grid `value` holds this at voxels' surface points).
double traceOcclusion(const Occlusion& occ, const openvdb::Vec3d& p, const openvdb::Vec3d& n);

} // namespace asset
} // namespace rockvdb
