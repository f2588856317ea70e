// SPDX-License-Identifier: Apache-2.0
// Band extension (core/ExtendBand.h): whole voxel layers of first-order upwind distances, the
// topology of tools::dilateSdf and its values to within rounding.
#include <rockvdb/core/Error.h>
#include <rockvdb/core/ExtendBand.h>
#include <rockvdb/core/VdbIO.h>

#include "GridCompare.h"

#include <gtest/gtest.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace rockvdb;
using openvdb::FloatGrid;

namespace {

// A sphere off the voxel grid: both sides of its band (convex outside, concave inside).
FloatGrid::Ptr offGridSphere(float radius, float dx)
{
    return openvdb::tools::createLevelSetSphere<FloatGrid>(
        radius, openvdb::Vec3f(0.3f * dx, 0.1f * dx, 0.45f * dx), dx, 3.0f);
}

} // namespace

TEST(ExtendBand, NewLayersHoldDistancesAsAccurateAsFastSweeping)
{
    initialize();
    const float dx = 0.5f, R = 25.0f;
    const int layers = 12;
    auto grid = offGridSphere(R, dx);
    auto wide = extendBand(*grid, layers);
    auto swept = openvdb::tools::dilateSdf(*grid, layers);
    EXPECT_EQ(wide->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_EQ(wide->background(), grid->background());
    // Fast sweeping's topology: face-neighbour layers.
    openvdb::MaskTree a(wide->tree(), false, openvdb::TopologyCopy());
    openvdb::MaskTree b(swept->tree(), false, openvdb::TopologyCopy());
    EXPECT_TRUE(a.hasSameTopology(b));
    const openvdb::Vec3d centre(0.3 * dx, 0.1 * dx, 0.45 * dx);
    auto in = grid->getConstAccessor();
    auto sw = swept->getConstAccessor();
    double sumErr = 0, maxErr = 0, sumSweepErr = 0, maxSweepErr = 0, maxDiff = 0;
    size_t added = 0, flips = 0, changedInput = 0;
    for (auto it = wide->cbeginValueOn(); it; ++it) {
        const openvdb::Coord c = it.getCoord();
        float v0;
        if (in.probeValue(c, v0)) {
            if (*it != v0) ++changedInput; // the input's own voxels are kept, bit for bit
            continue;
        }
        const double exact = (wide->indexToWorld(c) - centre).length() - R;
        if ((*it < 0) != (exact < 0)) ++flips;
        const double err = std::abs(*it - exact) / dx;
        sumErr += err;
        maxErr = std::max(maxErr, err);
        const double sweepErr = std::abs(sw.getValue(c) - exact) / dx;
        sumSweepErr += sweepErr;
        maxSweepErr = std::max(maxSweepErr, sweepErr);
        maxDiff = std::max(maxDiff, double(std::abs(*it - sw.getValue(c))) / dx);
        ++added;
    }
    ASSERT_GT(added, grid->activeVoxelCount());
    EXPECT_EQ(changedInput, 0u);
    EXPECT_EQ(flips, 0u);
    // First-order upwind distances off a 3-voxel band: a few hundredths of a voxel on average,
    // at most fast sweeping's worst (both 0.037 / 0.123 voxel here; one-neighbour updates
    // alone, |x| + h along an axis, are far off on the sphere's diagonals), and within a
    // tenth of a voxel of fast sweeping's values everywhere (0.06 here).
    EXPECT_LT(sumErr / added, 0.04);
    EXPECT_LT(sumErr / added, 1.02 * sumSweepErr / added);
    EXPECT_LE(maxErr, maxSweepErr + 0.005);
    EXPECT_LT(maxDiff, 0.1);
}

TEST(ExtendBand, SameBitsAtOneAndTwoThreads)
{
    initialize();
    auto grid = offGridSphere(12.0f, 0.25f);
    FloatGrid::Ptr one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = extendBand(*grid, 4);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = extendBand(*grid, 4);
    }
    EXPECT_TRUE(test::bitwiseEqual(*one, *two));
    // No layers: a copy of the input.
    EXPECT_TRUE(test::bitwiseEqual(*extendBand(*grid, 0), *grid));
}

TEST(ExtendBand, RefusesAFogVolume)
{
    initialize();
    auto fog = FloatGrid::create(0.0f);
    fog->tree().setValue(openvdb::Coord(0), 1.0f);
    EXPECT_THROW(extendBand(*fog, 2), ValueError);
}
