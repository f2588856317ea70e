// SPDX-License-Identifier: Apache-2.0
// The generic baker against OpenVDB's own sphere, analytic measures, determinism, chunking.
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/VdbIO.h>

#include "GridCompare.h"

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Diagnostics.h>
#include <openvdb/tools/LevelSetMeasure.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace rockvdb;
using rockvdb::test::bitwiseEqual;
using openvdb::FloatGrid;

namespace {

BakeSettings bakeSettings(double dx, double hw = 3.0)
{
    BakeSettings s;
    s.voxelSize = dx;
    s.halfWidth = hw;
    return s;
}


} // namespace

TEST(Bake, SphereMatchesCreateLevelSetSphere)
{
    initialize();
    const double dx = 0.05, R = 1.5; // 30 voxels
    const Vec3d c(0.3, -0.2, 0.1);
    auto ours = bake(*sphere(c, R), bakeSettings(dx)).surface;
    auto ref = openvdb::tools::createLevelSetSphere<FloatGrid>(float(R), Vec3f(c), float(dx), 3.0f);

    EXPECT_EQ(ours->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_FLOAT_EQ(ours->background(), float(3 * dx));
    EXPECT_EQ(ours->getName(), "surface");
    const double na = double(ours->activeVoxelCount()), nb = double(ref->activeVoxelCount());
    EXPECT_NEAR(na / nb, 1.0, 0.01) << na << " vs " << nb;

    double maxDiff = 0;
    size_t common = 0;
    auto racc = ref->getConstAccessor();
    for (auto it = ours->cbeginValueOn(); it; ++it) {
        float rv;
        if (!racc.probeValue(it.getCoord(), rv)) continue;
        maxDiff = std::max(maxDiff, double(std::abs(*it - rv)));
        ++common;
    }
    EXPECT_GT(common, size_t(0.98 * na));
    EXPECT_LT(maxDiff, 0.05 * dx);

    // Inside / outside signs away from the band.
    auto acc = ours->getConstAccessor();
    EXPECT_LT(acc.getValue(ours->transform().worldToIndexCellCentered(c)), 0.0f);
    EXPECT_GT(acc.getValue(ours->transform().worldToIndexCellCentered(c + Vec3d(R + 1, 0, 0))), 0.0f);
}

TEST(Bake, SphereAreaAndVolumeMatchFormula)
{
    initialize();
    const double R = 1.0, dx = 0.025;
    auto g = bake(*sphere(Vec3d(0), R), bakeSettings(dx)).surface;
    openvdb::tools::LevelSetMeasure<FloatGrid> m(*g);
    EXPECT_NEAR(m.area(true), 4 * M_PI * R * R, 0.01 * 4 * M_PI * R * R);
    EXPECT_NEAR(m.volume(true), 4.0 / 3.0 * M_PI * R * R * R, 0.01 * 4.0 / 3.0 * M_PI);
}

TEST(Bake, RoundedBoxAreaAndVolumeMatchFormula)
{
    initialize();
    // Rounded box: inner box a'b'c' swept by a ball of radius r.
    const double a = 1.0, b = 1.5, c = 2.0, r = 0.1;
    const double ai = a - 2 * r, bi = b - 2 * r, ci = c - 2 * r;
    const double area = 2 * (ai * bi + bi * ci + ci * ai) + 2 * M_PI * r * (ai + bi + ci) +
                        4 * M_PI * r * r;
    const double vol = ai * bi * ci + 2 * r * (ai * bi + bi * ci + ci * ai) +
                       M_PI * r * r * (ai + bi + ci) + 4.0 / 3.0 * M_PI * r * r * r;
    auto g = bake(*box(Vec3d(0.1, 0.2, 0.3), Vec3d(a, b, c) * 0.5, r), bakeSettings(0.02)).surface;
    openvdb::tools::LevelSetMeasure<FloatGrid> m(*g);
    EXPECT_NEAR(m.volume(true), vol, 0.01 * vol);
    EXPECT_NEAR(m.area(true), area, 0.01 * area);
}

TEST(Bake, DeterministicAcrossThreadCounts)
{
    initialize();
    // A warped, renormalised field exercises every code path.
    auto f = warp(unite(sphere(Vec3d(0), 1.0), box(Vec3d(0.8, 0, 0), Vec3d(0.5), 0.1), 0.2),
                  noiseDisplacement(0.08, 2.0, 3, 42));
    BakeSettings s = bakeSettings(0.04);
    s.withAttribute = true;
    FloatGrid::Ptr one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = bake(*f, s).surface;
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = bake(*f, s).surface;
    }
    EXPECT_GT(one->activeVoxelCount(), 1000u);
    EXPECT_TRUE(bitwiseEqual(*one, *two));
}

TEST(Bake, CostFollowsSurfaceNotVolume)
{
    initialize();
    // Doubling the radius multiplies evaluations by ~4 (area), not ~8 (volume).
    auto r1 = bake(*sphere(Vec3d(0), 1.0), bakeSettings(0.05));
    auto r2 = bake(*sphere(Vec3d(0), 2.0), bakeSettings(0.05));
    const double ratio = double(r2.stats.fieldEvaluations) / double(r1.stats.fieldEvaluations);
    EXPECT_GT(ratio, 3.0);
    EXPECT_LT(ratio, 5.5);
}

TEST(Bake, OutputsAreWellFormedLevelSets)
{
    initialize();
    // OpenVDB's own diagnostics (all nine checks: class, uniform scale, background, no
    // active tiles, finite values, active values within ±background, inactive values exactly
    // ±background, |∇φ| = 1 at the zero crossing) on a plain bake, a region-clipped bake and
    // a renormalised warped bake.
    const double dx = 0.05;
    auto plain = bake(*sphere(Vec3d(0.1, 0.2, -0.3), 1.2), bakeSettings(dx)).surface;
    EXPECT_EQ(openvdb::tools::checkLevelSet(*plain, 9), "");
    BakeSettings clipped = bakeSettings(dx);
    clipped.region = BBoxd(Vec3d(-2, -2, -2), Vec3d(0.33, 2, 2)); // not leaf-aligned
    auto clip = bake(*sphere(Vec3d(0.1, 0.2, -0.3), 1.2), clipped).surface;
    EXPECT_EQ(openvdb::tools::checkLevelSet(*clip, 8), "");
    auto warped = bake(*warp(sphere(Vec3d(0), 1.0), noiseDisplacement(0.08, 2.0, 3, 5)),
                       bakeSettings(dx)).surface;
    EXPECT_EQ(openvdb::tools::checkLevelSet(*warped, 8), "");
}

TEST(Bake, InsideTilesAreFilledAcrossInternalNodes)
{
    initialize();
    // A sphere of 200 voxels centred on the origin spans eight level-2 nodes and holds whole
    // level-1 nodes inside: its centre is an inside tile (-background), far points outside.
    const double dx = 0.01;
    auto g = bake(*sphere(Vec3d(0), 2.0), bakeSettings(dx)).surface;
    auto acc = g->getConstAccessor();
    const float bg = g->background();
    for (const auto& ijk : {openvdb::Coord(0, 0, 0), openvdb::Coord(-1, -1, -1),
                            openvdb::Coord(120, -40, 30), openvdb::Coord(-150, 0, 0)}) {
        EXPECT_EQ(acc.getValue(ijk), -bg) << ijk;
        EXPECT_FALSE(acc.isValueOn(ijk)) << ijk;
    }
    for (const auto& ijk : {openvdb::Coord(300, 0, 0), openvdb::Coord(-180, -180, 0),
                            openvdb::Coord(5000, 5000, 5000)}) {
        EXPECT_EQ(acc.getValue(ijk), bg) << ijk;
    }
    // The tree holds tiles at levels 1 and 2 (not only leaves): the fill reached them.
    size_t insideTiles = 0;
    for (auto it = g->tree().cbeginValueOff(); it; ++it) {
        if (!it.isVoxelValue() && *it < 0) ++insideTiles;
    }
    EXPECT_GT(insideTiles, 0u);
}

TEST(Bake, LeafAlignedChunksEqualWholeBake)
{
    initialize();
    const double dx = 0.05;
    auto f = warp(sphere(Vec3d(0), 1.0), noiseDisplacement(0.05, 2.0, 2, 3));
    BakeSettings whole = bakeSettings(dx);
    auto full = bake(*f, whole).surface;
    // Split at x = 0 (a multiple of 8 voxels): [-2, 0) and [0, 2).
    BakeSettings left = whole, right = whole;
    left.region = BBoxd(Vec3d(-2), Vec3d(0, 2, 2));
    right.region = BBoxd(Vec3d(0, -2, -2), Vec3d(2));
    auto a = bake(*f, left).surface;
    auto b = bake(*f, right).surface;
    EXPECT_EQ(a->activeVoxelCount() + b->activeVoxelCount(), full->activeVoxelCount());
    // Every active voxel of each chunk equals the whole bake bitwise.
    auto facc = full->getConstAccessor();
    for (const auto& g : {a, b}) {
        for (auto it = g->cbeginValueOn(); it; ++it) {
            float v;
            ASSERT_TRUE(facc.probeValue(it.getCoord(), v));
            ASSERT_EQ(v, *it);
        }
    }
}

TEST(Bake, AttributeGridFollowsNearestTaggedPrimitive)
{
    initialize();
    auto f = unite(tag(sphere(Vec3d(-1, 0, 0), 0.6), 7), tag(sphere(Vec3d(1, 0, 0), 0.6), 9));
    BakeSettings s = bakeSettings(0.05);
    s.withAttribute = true;
    s.attributeName = "block_id";
    auto r = bake(*f, s);
    ASSERT_TRUE(r.attribute);
    EXPECT_EQ(r.attribute->getName(), "block_id");
    EXPECT_EQ(r.attribute->getGridClass(), openvdb::GRID_UNKNOWN);
    EXPECT_EQ(r.attribute->background(), -1.0f);
    EXPECT_EQ(r.attribute->activeVoxelCount(), r.surface->activeVoxelCount());
    for (auto it = r.attribute->cbeginValueOn(); it; ++it) {
        const double x = r.attribute->transform().indexToWorld(it.getCoord())[0];
        ASSERT_EQ(*it, x < 0 ? 7.0f : 9.0f);
    }
}

TEST(Bake, RenormalisationRestoresDistance)
{
    initialize();
    // A sphere scaled by 3 in value (not a distance): renormalised it is the sphere again.
    auto f = transform(sphere(Vec3d(0), 1.0), openvdb::math::Mat4d::identity());
    struct Scaled final : Field {
        FieldPtr c;
        void evalBatch(const Batch& b, float* out) const override {
            c->evalBatch(b, out);
            for (int i = 0; i < b.n; ++i) out[i] *= 3.0f;
        }
        BBoxd bounds() const override { return c->bounds(); }
        double lipschitz() const override { return 3.0; }
        bool exact() const override { return false; }
    } scaled;
    scaled.c = f;
    BakeSettings s = bakeSettings(0.05);
    auto g = bake(scaled, s).surface;
    auto ref = bake(*f, s).surface;
    EXPECT_NEAR(double(g->activeVoxelCount()) / double(ref->activeVoxelCount()), 1.0, 0.01);
    auto racc = ref->getConstAccessor();
    double maxDiff = 0;
    for (auto it = g->cbeginValueOn(); it; ++it) {
        float v;
        if (racc.probeValue(it.getCoord(), v)) maxDiff = std::max(maxDiff, double(std::abs(v - *it)));
    }
    EXPECT_LT(maxDiff, 0.05 * 0.05);
}

TEST(Bake, BadSettingsAreRejected)
{
    auto s = sphere(Vec3d(0), 1.0);
    for (double dx : {0.0, -1.0, std::nan("")}) {
        BakeSettings bs = bakeSettings(dx);
        try {
            bake(*s, bs);
            FAIL() << "voxel size " << dx << " accepted";
        } catch (const ValueError& e) {
            EXPECT_NE(std::string(e.what()).find("voxel size"), std::string::npos) << e.what();
        }
    }
    BakeSettings hw = bakeSettings(0.1, 0.5);
    EXPECT_THROW(bake(*s, hw), ValueError);
    // Unbounded field without a region.
    EXPECT_THROW(bake(*halfSpace(Vec3d(0), Vec3d(0, 0, 1)), bakeSettings(0.1)), ValueError);
}

TEST(Bake, HugeResolutionRefusedWithEstimate)
{
    auto s = sphere(Vec3d(0), 1000.0);
    BakeSettings bs = bakeSettings(1e-4);
    try {
        bake(*s, bs);
        FAIL() << "accepted";
    } catch (const ValueError& e) {
        const std::string msg = e.what();
        EXPECT_NE(msg.find("refusing"), std::string::npos) << msg;
        EXPECT_NE(msg.find("B needed"), std::string::npos) << msg;
    }
}

TEST(Bake, PlaneWithRegionIsExact)
{
    initialize();
    BakeSettings s = bakeSettings(0.1);
    s.region = BBoxd(Vec3d(-1), Vec3d(1));
    const Vec3d n = Vec3d(1, 2, 2).unit();
    auto g = bake(*halfSpace(Vec3d(0.05, 0, 0), n), s).surface;
    ASSERT_GT(g->activeVoxelCount(), 100u);
    for (auto it = g->cbeginValueOn(); it; ++it) {
        const Vec3d p = g->transform().indexToWorld(it.getCoord());
        ASSERT_NEAR(*it, (p - Vec3d(0.05, 0, 0)).dot(n), 1e-5);
    }
}
