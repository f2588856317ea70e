// SPDX-License-Identifier: Apache-2.0
// rockvdb — analytic primitive fields (world units: metres; negative inside).
#pragma once

#include <rockvdb/core/Field.h>

#include <vector>

namespace rockvdb {

/// @brief Exact distance to a sphere.
/// @param center  world position (m)
/// @param radius  radius (m), > 0
FieldPtr sphere(const Vec3d& center, double radius);

/// @brief Exact distance to an axis-aligned box with rounded edges.
/// @param center    world position (m)
/// @param halfSize  half extents (m), each > 0
/// @param rounding  edge radius (m), 0 <= rounding <= min(halfSize)
FieldPtr box(const Vec3d& center, const Vec3d& halfSize, double rounding = 0.0);

/// @brief Exact distance to a capsule: all points within @a radius of segment [a, b].
/// A degenerate segment (a == b) is a sphere.
FieldPtr capsule(const Vec3d& a, const Vec3d& b, double radius);

/// @brief Exact signed distance to the plane through @a point with outward @a normal;
/// the half-space behind the normal is inside. Unbounded: bake it with a region.
FieldPtr halfSpace(const Vec3d& point, const Vec3d& normal);

/// @brief A plane n·p = d; the half-space n·p < d is inside. @c normal need not be unit.
struct Plane
{
    Vec3d normal;
    double offset;
};

/// @brief Intersection of half-spaces: max_k h_k(p), or with @a smoothRadius > 0 the smooth
/// intersection of implicit-blocks-rocky-scenery §4.2 folded over the planes in order.
/// Bounds come from the polytope's vertices; an unbounded set of planes is unbounded.
/// Not exact outside near edges and corners (max of planes is a lower bound there).
/// At most kMaxPolytopePlanes planes (the bounds' vertex enumeration is cubic in them).
FieldPtr convexPolytope(const std::vector<Plane>& planes, double smoothRadius = 0.0);
constexpr size_t kMaxPolytopePlanes = 512;

/// @brief Vertices of the convex polytope {n_k·p <= d_k} (empty when empty or unbounded).
std::vector<Vec3d> polytopeVertices(const std::vector<Plane>& planes);

} // namespace rockvdb
