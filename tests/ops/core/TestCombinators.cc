// SPDX-License-Identifier: Apache-2.0
// Smooth operator of implicit-blocks §4.2, primitives' analytic distances, transforms, warps,
// noise bounds, CSG identities on grids.
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridCsg.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/core/VdbIO.h>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetMeasure.h>

#include <cmath>

using namespace rockvdb;
using openvdb::FloatGrid;

namespace {
double volume(const FloatGrid& g)
{
    openvdb::tools::LevelSetMeasure<FloatGrid> m(g);
    return m.volume(true);
}
BakeSettings csgSettings(double dx)
{
    BakeSettings s;
    s.voxelSize = dx;
    return s;
}
} // namespace

TEST(Smooth, MatchesPaperFormula)
{
    // Paper: k = max(1 - |a-b|/R, 0), blend R·k³/6; negative-inside intersection adds it.
    const float R = 0.25f;
    for (int i = 0; i < 1000; ++i) {
        const float a = float(random::uniform(1, 0, i, -1, 1));
        const float b = float(random::uniform(1, 1, i, -1, 1));
        const float k = std::max(1.0f - std::abs(a - b) / R, 0.0f);
        EXPECT_NEAR(smoothIntersection(a, b, R), std::max(a, b) + R * k * k * k / 6.0f, 1e-6f);
        EXPECT_NEAR(smoothUnion(a, b, R), std::min(a, b) - R * k * k * k / 6.0f, 1e-6f);
    }
    // Far apart the operators are exact; at a == b the blend is R/6.
    EXPECT_EQ(smoothIntersection(0.0f, 1.0f, R), 1.0f);
    EXPECT_FLOAT_EQ(smoothIntersection(0.3f, 0.3f, R), 0.3f + R / 6);
    // Continuity of the gradient across |a - b| = R (the reason the paper uses it).
    const float e = 1e-3f;
    const float d1 = (smoothIntersection(0.0f, R + e, R) - smoothIntersection(0.0f, R - e, R)) / (2 * e);
    EXPECT_NEAR(d1, 1.0f, 1e-2f);
}

TEST(Smooth, IntersectionRoundsEdgesOfAPolytope)
{
    initialize();
    // A unit cube as 6 planes: the smooth intersection removes material along edges.
    std::vector<Plane> cube;
    for (int a = 0; a < 3; ++a)
        for (int s : {-1, 1}) {
            Vec3d n(0);
            n[a] = s;
            cube.push_back({n, 0.5});
        }
    auto hard = bake(*convexPolytope(cube, 0.0), csgSettings(0.02)).surface;
    auto soft = bake(*convexPolytope(cube, 0.25), csgSettings(0.02)).surface;
    EXPECT_NEAR(volume(*hard), 1.0, 0.01);
    EXPECT_LT(volume(*soft), volume(*hard) - 0.01);
    EXPECT_GT(volume(*soft), 0.8);
    // Face centres are untouched.
    EXPECT_NEAR(convexPolytope(cube, 0.25)->eval(Vec3d(0.5, 0, 0)), 0.0, 1e-6);
}

TEST(Primitives, AnalyticDistances)
{
    auto s = sphere(Vec3d(1, 2, 3), 2.0);
    EXPECT_NEAR(s->eval(Vec3d(1, 2, 3)), -2.0, 1e-6);
    EXPECT_NEAR(s->eval(Vec3d(5, 2, 3)), 2.0, 1e-6);
    auto b = box(Vec3d(0), Vec3d(1, 2, 3), 0.0);
    EXPECT_NEAR(b->eval(Vec3d(2, 0, 0)), 1.0, 1e-6);
    EXPECT_NEAR(b->eval(Vec3d(2, 3, 0)), std::sqrt(2.0), 1e-6);
    EXPECT_NEAR(b->eval(Vec3d(0.5, 0, 0)), -0.5, 1e-6);
    auto rb = box(Vec3d(0), Vec3d(1), 0.25);
    EXPECT_NEAR(rb->eval(Vec3d(2, 0, 0)), 1.0, 1e-6);
    // Corner region: distance to the rounded edge = |(1.25, 1.25)| - 0.25.
    EXPECT_NEAR(rb->eval(Vec3d(2, 2, 0)), std::hypot(1.25, 1.25) - 0.25, 1e-5);
    auto c = capsule(Vec3d(0), Vec3d(0, 0, 2), 0.5);
    EXPECT_NEAR(c->eval(Vec3d(1, 0, 1)), 0.5, 1e-6);
    EXPECT_NEAR(c->eval(Vec3d(0, 0, 3)), 0.5, 1e-6);
    auto h = halfSpace(Vec3d(0, 0, 1), Vec3d(0, 0, 2));
    EXPECT_NEAR(h->eval(Vec3d(5, 5, 3)), 2.0, 1e-6);
    EXPECT_FALSE(isBounded(h->bounds()));
}

TEST(Primitives, PolytopeBoundsAndUnboundedness)
{
    // Tetrahedron x,y,z >= 0, x+y+z <= 1.
    std::vector<Plane> tet = {{Vec3d(-1, 0, 0), 0}, {Vec3d(0, -1, 0), 0}, {Vec3d(0, 0, -1), 0},
                              {Vec3d(1, 1, 1), 1}};
    auto t = convexPolytope(tet);
    EXPECT_TRUE(isBounded(t->bounds()));
    EXPECT_NEAR(t->bounds().max()[0], 1.0, 1e-9);
    EXPECT_NEAR(t->bounds().min()[2], 0.0, 1e-9);
    // Drop the slanted plane: an infinite octant.
    tet.pop_back();
    tet.push_back({Vec3d(-1, -1, -1), 5});
    EXPECT_FALSE(isBounded(convexPolytope(tet)->bounds()));
}

TEST(Primitives, BadParametersNameTheOp)
{
    try {
        sphere(Vec3d(0), -1);
        FAIL();
    } catch (const ValueError& e) {
        EXPECT_STREQ(e.what(), "sphere: radius must be > 0 (got -1)");
    }
    EXPECT_THROW(box(Vec3d(0), Vec3d(1, 0, 1)), ValueError);
    EXPECT_THROW(box(Vec3d(0), Vec3d(1), 2.0), ValueError);
    EXPECT_THROW(capsule(Vec3d(0), Vec3d(1), std::nan("")), ValueError);
    EXPECT_THROW(halfSpace(Vec3d(0), Vec3d(0)), ValueError);
    EXPECT_THROW(tag(sphere(Vec3d(0), 1), 0.5f), ValueError);
    EXPECT_THROW(transform(sphere(Vec3d(0), 1), openvdb::math::Mat4d::zero()), ValueError);
}

TEST(Transform, RigidMotionKeepsDistanceAndScaleScalesIt)
{
    auto s = sphere(Vec3d(0), 1.0);
    auto moved = transform(s, makeTransform(Vec3d(2, 0, 0), Vec3d(0, 0, 90), Vec3d(1)));
    EXPECT_NEAR(moved->eval(Vec3d(2, 0, 0)), -1.0, 1e-5);
    EXPECT_NEAR(moved->eval(Vec3d(4, 0, 0)), 1.0, 1e-5);
    EXPECT_TRUE(moved->exact());
    auto scaled = transform(s, makeTransform(Vec3d(0), Vec3d(0), Vec3d(3)));
    EXPECT_NEAR(scaled->eval(Vec3d(5, 0, 0)), 2.0, 1e-5);
    auto squashed = transform(s, makeTransform(Vec3d(0), Vec3d(0), Vec3d(2, 1, 1)));
    EXPECT_FALSE(squashed->exact());
    // Lower bound of the distance: ellipsoid x²/4 + y² + z² = 1, point (0, 3, 0) is 2 away.
    EXPECT_LE(squashed->eval(Vec3d(0, 3, 0)), 2.0 + 1e-5);
}

TEST(Noise, AnalyticBoundsHold)
{
    // |n| <= 2 and |∇n| <= 14.73 everywhere; sample densely and check.
    double maxV = 0, maxG = 0;
    const float h = 1e-3f;
    for (int i = 0; i < 20000; ++i) {
        const float x = float(random::uniform(5, 0, i, -50, 50));
        const float y = float(random::uniform(5, 1, i, -50, 50));
        const float z = float(random::uniform(5, 2, i, -50, 50));
        const float v = noise::gradient3(9, x, y, z);
        maxV = std::max(maxV, double(std::abs(v)));
        const double gx = (noise::gradient3(9, x + h, y, z) - noise::gradient3(9, x - h, y, z)) / (2 * h);
        const double gy = (noise::gradient3(9, x, y + h, z) - noise::gradient3(9, x, y - h, z)) / (2 * h);
        const double gz = (noise::gradient3(9, x, y, z + h) - noise::gradient3(9, x, y, z - h)) / (2 * h);
        maxG = std::max(maxG, std::sqrt(gx * gx + gy * gy + gz * gz));
    }
    EXPECT_LE(maxV, noise::kValueBound);
    EXPECT_LE(maxG, noise::kGradientBound3);
    EXPECT_GT(maxV, 0.3);  // not degenerate
    // Deterministic and seed-dependent.
    EXPECT_EQ(noise::gradient3(1, 0.3f, 0.4f, 0.5f), noise::gradient3(1, 0.3f, 0.4f, 0.5f));
    EXPECT_NE(noise::gradient3(1, 0.3f, 0.4f, 0.5f), noise::gradient3(2, 0.3f, 0.4f, 0.5f));
    noise::Fbm fbm;
    EXPECT_GE(noise::turbulence2(3, fbm, 1.3f, 2.7f), 0.0f);
    EXPECT_NE(noise::fbm2(3, fbm, 1.3f, 2.7f), noise::fbm2(4, fbm, 1.3f, 2.7f));
}

TEST(Warp, DisplacementStaysWithinBoundAndZeroAmplitudeIsIdentity)
{
    initialize();
    auto s = sphere(Vec3d(0), 1.0);
    auto same = warp(s, noiseDisplacement(0.0, 2.0, 3, 1));
    for (int i = 0; i < 100; ++i) {
        const Vec3d p(random::uniform(2, 0, i, -2, 2), random::uniform(2, 1, i, -2, 2),
                      random::uniform(2, 2, i, -2, 2));
        EXPECT_EQ(same->eval(p), s->eval(p));
    }
    auto d = noiseDisplacement(0.1, 2.0, 3, 1);
    auto w = warp(s, d);
    EXPECT_GT(w->lipschitz(), 1.0);
    EXPECT_FALSE(w->exact());
    // Baked surface stays within max|δ| of the sphere.
    auto g = bake(*w, csgSettings(0.03)).surface;
    double maxDev = 0;
    for (auto it = g->cbeginValueOn(); it; ++it) {
        if (std::abs(*it) > 0.5 * 0.03) continue;
        const Vec3d p = g->transform().indexToWorld(it.getCoord());
        maxDev = std::max(maxDev, std::abs(p.length() - 1.0));
    }
    EXPECT_LT(maxDev, d->maxMagnitude() + 0.03);
    EXPECT_GT(maxDev, 0.01); // it did move
}

TEST(GridCsg, IdentitiesOnGrids)
{
    initialize();
    BakeSettings s = csgSettings(0.04);
    auto a = bake(*sphere(Vec3d(-0.3, 0, 0), 0.7), s).surface;
    auto b = bake(*sphere(Vec3d(0.3, 0, 0), 0.7), s).surface;
    const double va = volume(*a), vb = volume(*b);
    auto u = csgGrids(CsgOp::Union, {a, b});
    auto i = csgGrids(CsgOp::Intersection, {a, b});
    auto d = csgGrids(CsgOp::Difference, {a, b});
    // Inclusion-exclusion and A = (A - B) + (A ∩ B).
    EXPECT_NEAR(volume(*u) + volume(*i), va + vb, 0.01 * (va + vb));
    EXPECT_NEAR(volume(*d) + volume(*i), va, 0.01 * va);
    // Union is commutative; inputs untouched.
    EXPECT_NEAR(volume(*csgGrids(CsgOp::Union, {b, a})), volume(*u), 1e-3);
    EXPECT_NEAR(volume(*a), va, 1e-9);
    // The union grid equals the union field baked directly.
    auto direct = bake(*unite(sphere(Vec3d(-0.3, 0, 0), 0.7), sphere(Vec3d(0.3, 0, 0), 0.7)), s).surface;
    EXPECT_NEAR(volume(*direct), volume(*u), 0.002 * volume(*u));
    // Smooth union adds a fillet (more volume) and matches the smooth field bake.
    auto su = csgGrids(CsgOp::Union, {a, b}, 0.2);
    auto sdirect = bake(*unite(sphere(Vec3d(-0.3, 0, 0), 0.7), sphere(Vec3d(0.3, 0, 0), 0.7), 0.2), s).surface;
    EXPECT_GT(volume(*su), volume(*u) + 1e-3);
    EXPECT_NEAR(volume(*su), volume(*sdirect), 0.005 * volume(*su));
    EXPECT_EQ(su->getGridClass(), openvdb::GRID_LEVEL_SET);
}
