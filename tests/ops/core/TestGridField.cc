// SPDX-License-Identifier: Apache-2.0
// A baked level set as a field (core/GridField.h): values inside the band, and the band
// widened (extendBand) to true distances as far as callers read them.
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/GridField.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/VdbIO.h>

#include <gtest/gtest.h>
#include <openvdb/tools/GridOperators.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>

#include <algorithm>
#include <cmath>
#include <vector>

using namespace rockvdb;
using openvdb::FloatGrid;

TEST(WidenBand, ReachesTheRequestedWidthWithTrueDistances)
{
    initialize();
    const double dx = 0.05, R = 1.0;
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(float(R), openvdb::Vec3f(0), float(dx), 3.0f);
    const double width = 8 * dx; // well beyond the 3-voxel band
    auto wide = widenBand(grid, width);
    ASSERT_NE(wide.get(), grid.get());
    EXPECT_EQ(wide->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_GE(double(wide->background()), width);
    EXPECT_GT(wide->activeVoxelCount(), 2 * grid->activeVoxelCount());
    // Along the axes and the diagonals, within the requested width, values are distances to
    // the sphere (|p| − R) to a fraction of a voxel; beyond, at most the background.
    auto acc = wide->getConstAccessor();
    const openvdb::Vec3d dirs[] = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}, {1, 1, 1}, {-1, 2, 0.5}};
    for (openvdb::Vec3d d : dirs) {
        d.normalize();
        for (double s = -width + dx; s <= width - dx; s += 0.5 * dx) {
            const openvdb::Vec3d p = d * (R + s);
            const openvdb::Coord c = wide->transform().worldToIndexNodeCentered(p);
            const double exact = wide->transform().indexToWorld(c).length() - R;
            float v;
            const bool on = acc.probeValue(c, v);
            if (std::abs(exact) <= 3 * dx + 1e-9 || std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2]) < 1.01) {
                ASSERT_TRUE(on) << p;
                EXPECT_NEAR(v, exact, 0.25 * dx) << p;
            }
            EXPECT_EQ(v < 0, exact < 0) << p;
        }
    }
    // Inside stays inside far from the band; the original is untouched.
    EXPECT_LT(wide->tree().getValue(openvdb::Coord(0)), 0.0f);
    EXPECT_FLOAT_EQ(grid->background(), float(3 * dx));
}

TEST(WidenBand, ANarrowRequestSharesTheGridAndNonLevelSetsAreRefused)
{
    initialize();
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0), 0.05f, 3.0f);
    EXPECT_EQ(widenBand(grid, 0.1).get(), grid.get());
    EXPECT_EQ(widenBand(grid, 0.0).get(), grid.get());
    auto fog = grid->deepCopy();
    fog->setGridClass(openvdb::GRID_FOG_VOLUME);
    EXPECT_THROW(widenBand(fog, 1.0), ValueError);
    EXPECT_THROW(widenBand(nullptr, 1.0), ValueError);
}

TEST(LevelSetField, SamplesTheGridAndBoundsBeyondTheBand)
{
    initialize();
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0.2f, 0, 0), 0.05f, 3.0f);
    auto f = levelSetField(grid, 0.3);
    // Within the requested 0.3 m: the distance; beyond: a lower bound of it, at least 0.3.
    for (double x : {0.75, 0.85, 1.0, 1.15, 1.25}) {
        EXPECT_NEAR(f->eval(Vec3d(x + 0.2, 0, 0)), x - 1.0, 0.02) << x;
    }
    const float edge = f->eval(Vec3d(1.65, 0, 0)); // 0.45 m out
    EXPECT_GE(edge, 0.3f);
    EXPECT_LE(edge, 0.45f + 1e-4f);
    const float far = f->eval(Vec3d(4, 0, 0));
    EXPECT_GT(far, 0.3f);
    EXPECT_LE(far, 4.0f - 1.2f + 1e-4f);
    EXPECT_LT(f->eval(Vec3d(0.2, 0, 0)), 0.0f);
    // The bake of the field is the sphere again.
    BakeSettings s;
    s.voxelSize = 0.05;
    auto back = bake(*f, s).surface;
    auto acc = back->getConstAccessor();
    float v;
    ASSERT_TRUE(acc.probeValue(openvdb::Coord(24, 0, 0), v)); // x = 1.2: on the surface
    EXPECT_NEAR(v, 0.0, 0.01);
}

TEST(LevelSetField, GradientIsTheGridsCentralDifferenceOnAndOffItsVoxels)
{
    initialize();
    const float dx = 0.05f;
    auto grid = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0.2f, 0, 0), dx, 3.0f);
    auto f = levelSetField(grid);
    auto reference = openvdb::tools::gradient(*grid);
    auto racc = reference->getConstAccessor();
    // Every active voxel (leaf interiors, faces, edges) and a layer of inactive ones around
    // the band, at float positions as a bake makes them (i·dx, off by up to ~1e-5 voxel).
    std::vector<openvdb::Coord> voxels;
    for (auto it = grid->cbeginValueOn(); it; ++it) voxels.push_back(it.getCoord());
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        const openvdb::Coord c = it.getCoord().offsetBy(4, 0, 0);
        if (!grid->tree().isValueOn(c)) voxels.push_back(c);
    }
    size_t checked = 0, inactive = 0;
    BatchBuffer b;
    float gx[kMaxBatch], gy[kMaxBatch], gz[kMaxBatch];
    for (size_t start = 0; start < voxels.size(); start += kMaxBatch) {
        b.n = int(std::min<size_t>(kMaxBatch, voxels.size() - start));
        for (int i = 0; i < b.n; ++i) {
            const openvdb::Coord& c = voxels[start + size_t(i)];
            b.x[i] = float(c.x()) * dx;
            b.y[i] = float(c.y()) * dx;
            b.z[i] = float(c.z()) * dx;
        }
        f->gradientBatch(b.view(), dx, gx, gy, gz);
        for (int i = 0; i < b.n; ++i) {
            const openvdb::Coord& c = voxels[start + size_t(i)];
            const openvdb::Vec3f want = racc.getValue(c); // zero off the band
            ASSERT_EQ(gx[i], want[0]) << c;
            ASSERT_EQ(gy[i], want[1]) << c;
            ASSERT_EQ(gz[i], want[2]) << c;
            inactive += !grid->tree().isValueOn(c);
            ++checked;
        }
    }
    EXPECT_GT(inactive, 1000u);
    // Between voxels: the trilinear sample of the gradient grid.
    BatchBuffer q;
    q.n = 3;
    const openvdb::Vec3d pts[3] = {{1.2 + 0.3 * dx, 0.01, 0.02}, {0.2, 1.0 - 0.4 * dx, 0.013}, {-0.79, 0.1, 0.1}};
    for (int i = 0; i < 3; ++i) {
        q.x[i] = float(pts[i][0]);
        q.y[i] = float(pts[i][1]);
        q.z[i] = float(pts[i][2]);
    }
    f->gradientBatch(q.view(), dx, gx, gy, gz);
    for (int i = 0; i < 3; ++i) {
        const openvdb::Vec3d idx = grid->worldToIndex(openvdb::Vec3d(q.x[i], q.y[i], q.z[i]));
        const openvdb::Vec3f want = openvdb::tools::BoxSampler::sample(racc, idx);
        EXPECT_NEAR(gx[i], want[0], 1e-5f);
        EXPECT_NEAR(gy[i], want[1], 1e-5f);
        EXPECT_NEAR(gz[i], want[2], 1e-5f);
        // A unit normal of the sphere, as the band is a distance.
        EXPECT_NEAR(openvdb::Vec3f(gx[i], gy[i], gz[i]).length(), 1.0f, 0.05f);
    }
}
