// SPDX-License-Identifier: Apache-2.0
// rockvdb — convex hulls of point clusters (the only translation unit that includes CGAL).
#pragma once

#include <rockvdb/core/Field.h>

#include <array>
#include <cstdint>
#include <vector>

namespace rockvdb {
namespace blocks {

struct Hull
{
    int dimension = -1;                        ///< affine dimension of the points, 0..3
    std::vector<std::array<double, 4>> planes; ///< dimension 3: outward unit n, d (n·p <= d)
    std::vector<double> areas;                 ///< facet area per plane (coplanar facets merged)
    std::vector<Vec3d> vertices;               ///< hull vertices (dimension 3), sorted by position
    std::vector<std::array<uint32_t, 3>> triangles; ///< dimension 3: outward (counter-clockwise
                                                    ///< seen from outside) over `vertices`
};

/// @brief Convex hull with CGAL's convex_hull_3 (exact predicates) when the points span 3D;
/// otherwise only the dimension (callers build thick polygons, segments or points).
Hull convexHull(const std::vector<Vec3d>& points, double tolerance);

} // namespace blocks
} // namespace rockvdb
