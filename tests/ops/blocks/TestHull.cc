// SPDX-License-Identifier: Apache-2.0
// Convex hulls (blocks/Hull.h, CGAL): planes, areas and vertices of known polytopes, every
// point inside, and the degenerate dimensions callers branch on.
#include <rockvdb/blocks/Hull.h>
#include <rockvdb/core/Random.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace rockvdb;
using namespace rockvdb::blocks;

namespace {

double side(const std::array<double, 4>& h, const Vec3d& p)
{
    return h[0] * p[0] + h[1] * p[1] + h[2] * p[2] - h[3];
}

} // namespace

TEST(Hull, CubeWithInteriorPointsHasSixUnitFaces)
{
    std::vector<Vec3d> pts;
    for (int i = 0; i < 8; ++i) pts.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    for (int i = 0; i < 50; ++i) {
        pts.emplace_back(random::uniform(5, 0, uint64_t(i), 0.1, 0.9), random::uniform(5, 1, uint64_t(i), 0.1, 0.9),
                         random::uniform(5, 2, uint64_t(i), 0.1, 0.9));
    }
    // Points on the faces (coplanar facets must merge into one plane per face).
    pts.emplace_back(0.5, 0.5, 1.0);
    pts.emplace_back(0.0, 0.3, 0.7);
    const Hull h = convexHull(pts, 1e-9);
    ASSERT_EQ(h.dimension, 3);
    ASSERT_EQ(h.planes.size(), 6u);
    ASSERT_EQ(h.areas.size(), 6u);
    EXPECT_EQ(h.vertices.size(), 8u);
    double total = 0;
    for (size_t k = 0; k < 6; ++k) {
        const auto& q = h.planes[k];
        EXPECT_NEAR(std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]), 1.0, 1e-12);
        // An axis-aligned unit normal, outward: d = 1 on the far faces, 0 on the near ones.
        const double m = std::max({std::abs(q[0]), std::abs(q[1]), std::abs(q[2])});
        EXPECT_NEAR(m, 1.0, 1e-12);
        const double s = q[0] + q[1] + q[2];
        EXPECT_NEAR(q[3], s > 0 ? 1.0 : 0.0, 1e-12);
        EXPECT_NEAR(h.areas[k], 1.0, 1e-9);
        total += h.areas[k];
    }
    EXPECT_NEAR(total, 6.0, 1e-9);
    for (const Vec3d& p : pts)
        for (const auto& q : h.planes) EXPECT_LE(side(q, p), 1e-9);
}

TEST(Hull, RandomCloudContainsEveryPointAndVerticesLieOnPlanes)
{
    std::vector<Vec3d> pts;
    for (int i = 0; i < 400; ++i) {
        const Vec3d p(random::uniform(6, 0, uint64_t(i), -1, 1), random::uniform(6, 1, uint64_t(i), -1, 1),
                      random::uniform(6, 2, uint64_t(i), -1, 1));
        if (p.length() < 1.0) pts.push_back(p * 2.0 + Vec3d(3, -1, 0.5));
    }
    const Hull h = convexHull(pts, 1e-9);
    ASSERT_EQ(h.dimension, 3);
    EXPECT_GE(h.planes.size(), 20u);
    for (const Vec3d& p : pts)
        for (const auto& q : h.planes) EXPECT_LE(side(q, p), 1e-9);
    for (const Vec3d& v : h.vertices) {
        int on = 0;
        for (const auto& q : h.planes) on += std::abs(side(q, v)) < 1e-9;
        EXPECT_GE(on, 3); // a hull vertex is on at least three facets
    }
    // Area is below the circumscribed sphere's (4π·2²) and above half of it.
    double area = 0;
    for (double a : h.areas) area += a;
    EXPECT_LT(area, 4 * M_PI * 4);
    EXPECT_GT(area, 2 * M_PI * 4);
}

TEST(Hull, ItsMeshIsClosedOutwardAndTheSameForShuffledPoints)
{
    std::vector<Vec3d> pts;
    for (int i = 0; i < 300; ++i) {
        pts.emplace_back(random::uniform(8, 0, uint64_t(i), -1, 1), random::uniform(8, 1, uint64_t(i), -1, 1),
                         random::uniform(8, 2, uint64_t(i), -1, 1));
    }
    const Hull h = convexHull(pts, 1e-9);
    ASSERT_EQ(h.dimension, 3);
    // closed: Euler's formula for a triangulated sphere; outward: positive volume
    EXPECT_EQ(h.triangles.size(), 2 * h.vertices.size() - 4);
    double volume = 0;
    for (const auto& t : h.triangles) {
        volume += h.vertices[t[0]].dot(h.vertices[t[1]].cross(h.vertices[t[2]])) / 6.0;
    }
    EXPECT_GT(volume, 2.0); // the cube [-1, 1]³ holds 8; 300 points hull most of it
    EXPECT_LT(volume, 8.0);
    // the mesh is a function of the point set (CGAL's own order follows memory addresses)
    std::vector<Vec3d> shuffled(pts.rbegin(), pts.rend());
    std::rotate(shuffled.begin(), shuffled.begin() + 77, shuffled.end());
    const Hull again = convexHull(shuffled, 1e-9);
    EXPECT_EQ(again.vertices, h.vertices);
    EXPECT_EQ(again.triangles, h.triangles);
}

TEST(Hull, DegenerateCloudsReportTheirDimension)
{
    EXPECT_EQ(convexHull({Vec3d(1, 2, 3)}, 1e-9).dimension, 0);
    EXPECT_EQ(convexHull({Vec3d(1, 2, 3), Vec3d(1, 2, 3)}, 1e-9).dimension, 0);
    EXPECT_EQ(convexHull({Vec3d(0), Vec3d(1, 1, 1), Vec3d(2, 2, 2)}, 1e-9).dimension, 1);
    std::vector<Vec3d> flat;
    for (int i = 0; i < 20; ++i) flat.emplace_back(std::cos(i * 0.3), std::sin(i * 0.7), 0.0);
    const Hull h = convexHull(flat, 1e-9);
    EXPECT_EQ(h.dimension, 2);
    EXPECT_TRUE(h.planes.empty());
}
