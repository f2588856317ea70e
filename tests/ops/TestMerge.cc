// Merging the leaf-aligned chunks of one bake (core/Merge.h): bit-identical to the whole bake,
// inside tiles restored by the flood fill, and chunks that do not belong together refused.
#include "GridCompare.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Merge.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/VdbIO.h>

#include <gtest/gtest.h>

using namespace rockvdb;
using openvdb::FloatGrid;

namespace {

FloatGrid::Ptr bakeRegion(const Field& f, double dx, std::optional<BBoxd> region)
{
    BakeSettings s;
    s.voxelSize = dx;
    s.region = region;
    return bake(f, s).surface;
}

} // namespace

TEST(Merge, EightChunksEqualTheWholeBake)
{
    initialize();
    const double dx = 0.05; // leaves are 0.4 m: chunk faces at multiples of 0.4
    auto f = warp(sphere(Vec3d(0.1, -0.05, 0.02), 1.3), noiseDisplacement(0.05, 2.0, 2, 3));
    auto whole = bakeRegion(*f, dx, std::nullopt);
    std::vector<FloatGrid::ConstPtr> chunks;
    for (int i = 0; i < 8; ++i) {
        const Vec3d lo(i & 1 ? 0.0 : -2.0, i & 2 ? 0.4 : -2.0, i & 4 ? -0.8 : -2.0);
        const Vec3d hi(i & 1 ? 2.0 : 0.0, i & 2 ? 2.0 : 0.4, i & 4 ? 2.0 : -0.8);
        chunks.push_back(bakeRegion(*f, dx, BBoxd(lo, hi)));
    }
    auto merged = mergeChunks(chunks);
    EXPECT_TRUE(test::bitwiseEqual(*merged, *whole));
    EXPECT_TRUE(test::bitwiseEqual(*whole, *merged));
    EXPECT_EQ(merged->getGridClass(), openvdb::GRID_LEVEL_SET);
    // The centre is inside although no chunk holds a leaf there (flood-filled tiles).
    EXPECT_LT(merged->tree().getValue(openvdb::Coord(0)), 0.0f);
    // Any order gives the same grid.
    std::reverse(chunks.begin(), chunks.end());
    EXPECT_TRUE(test::bitwiseEqual(*mergeChunks(chunks), *whole));
}

TEST(Merge, ChunksThatDoNotBelongTogetherAreRefused)
{
    initialize();
    auto f = sphere(Vec3d(0), 1.0);
    auto a = bakeRegion(*f, 0.05, BBoxd(Vec3d(-2), Vec3d(0, 2, 2)));
    auto b = bakeRegion(*f, 0.05, BBoxd(Vec3d(0, -2, -2), Vec3d(2)));
    EXPECT_NO_THROW(mergeChunks({a, b}));
    auto coarse = bakeRegion(*f, 0.1, BBoxd(Vec3d(0, -2, -2), Vec3d(2)));
    EXPECT_THROW(mergeChunks({a, coarse}), ValueError); // transforms differ
    auto renamed = b->deepCopy();
    renamed->setName("other");
    EXPECT_THROW(mergeChunks({a, renamed}), ValueError);
    // Two different values for one voxel: not chunks of one bake.
    auto shifted = bakeRegion(*sphere(Vec3d(0.01, 0, 0), 1.0), 0.05, BBoxd(Vec3d(-2), Vec3d(0, 2, 2)));
    EXPECT_THROW(mergeChunks({a, shifted}), ValueError);
    EXPECT_THROW(mergeChunks({}), ValueError);
}
