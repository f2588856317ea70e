// SPDX-License-Identifier: Apache-2.0
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

namespace {

FloatGrid::Ptr bakeChunk(const Field& f, double dx, const std::string& chunks, const std::string& chunk)
{
    BakeSettings s;
    s.voxelSize = dx;
    s.chunk = ChunkSpec::parse(chunks, chunk, "test");
    return bake(f, s).surface;
}

} // namespace

TEST(Chunks, BoxesPartitionTheWholeOnLeafFaces)
{
    const openvdb::CoordBBox whole(openvdb::Coord(-37, -5, 3), openvdb::Coord(250, 99, 60));
    for (const std::array<int, 3> dims : {std::array<int, 3>{{4, 4, 1}}, {{3, 5, 2}}, {{64, 1, 1}}}) {
        const int n = dims[0] * dims[1] * dims[2];
        openvdb::Index64 volume = 0;
        for (int i = 0; i < n; ++i) {
            const auto b = chunkBox(whole, dims, i);
            if (b.empty()) continue;
            volume += b.volume();
            EXPECT_TRUE(whole.isInside(b));
            for (int a = 0; a < 3; ++a) {
                // Inner faces fall on leaf faces; outer ones are the whole's.
                if (b.min()[a] != whole.min()[a]) EXPECT_EQ(b.min()[a] % 8, 0);
                if (b.max()[a] != whole.max()[a]) EXPECT_EQ((b.max()[a] + 1) % 8, 0);
            }
            for (int j = 0; j < i; ++j) {
                EXPECT_FALSE(b.hasOverlap(chunkBox(whole, dims, j))) << i << " " << j;
            }
        }
        EXPECT_EQ(volume, whole.volume());
    }
    // 12 chunks of a long box are cut along its length first.
    const openvdb::CoordBBox slab(openvdb::Coord(0), openvdb::Coord(799, 199, 49));
    EXPECT_EQ(autoChunkDims(slab, 12), (std::array<int, 3>{{6, 2, 1}}));
}

TEST(Chunks, ParseRefusesWhatDoesNotNameAChunk)
{
    EXPECT_FALSE(ChunkSpec::parse("", "", "t").active());
    const ChunkSpec s = ChunkSpec::parse("2x3x1", "5/6", "t");
    EXPECT_TRUE(s.active());
    EXPECT_EQ(s.index, 5);
    for (const auto& [chunks, chunk] : std::vector<std::pair<std::string, std::string>>{
             {"2x2", ""}, {"0x1x1", ""}, {"2x2x-1", ""}, {"", "8/8"}, {"", "1"}, {"", "-1/4"},
             {"2x2x2", "1/4"}, {"", "0/0"}, {"a", ""}, {"4096x4096x4096", ""}}) {
        EXPECT_THROW(ChunkSpec::parse(chunks, chunk, "t"), ValueError) << chunks << " " << chunk;
    }
}

TEST(Chunks, ASolidStraddlingSixtyFourChunksMergesToTheWholeBake)
{
    // A sphere whose inside spans many chunks: each chunk's flood fill sees only its box, so
    // inside tiles next to the boxes' faces are the merge's to restore.
    initialize();
    const double dx = 0.02;
    auto f = sphere(Vec3d(0.03, -0.01, 0.02), 1.7);
    BakeSettings s;
    s.voxelSize = dx;
    auto whole = bake(*f, s).surface;
    ChunkMerger merger;
    for (int i = 0; i < 64; ++i) merger.add(*bakeChunk(*f, dx, "4x4x4", std::to_string(i) + "/64"));
    auto merged = merger.finish();
    EXPECT_TRUE(test::bitwiseEqual(*merged, *whole));
    EXPECT_TRUE(test::bitwiseEqual(*whole, *merged));
    EXPECT_LT(merged->tree().getValue(openvdb::Coord(0)), 0.0f);
    // The same split chosen for the count alone (chunk i/N without chunks).
    ChunkMerger automatic;
    for (int i = 0; i < 8; ++i) automatic.add(*bakeChunk(*f, dx, "", std::to_string(i) + "/8"));
    EXPECT_TRUE(test::bitwiseEqual(*automatic.finish(), *whole));
}

TEST(Chunks, AWholeBakesParametersComeBackFromAChunks)
{
    std::string chunk;
    const nlohmann::json p = {{"voxel-size", 0.1}, {"chunks", "2x2x2"}, {"chunk", "3/8"}};
    EXPECT_EQ(wholeBakeParams(p, &chunk), (nlohmann::json{{"voxel-size", 0.1}, {"chunks", ""}, {"chunk", ""}}));
    EXPECT_EQ(chunk, "3/8");
    const nlohmann::json pile = {{"pile", {{"seed", 1}, {"chunks", ""}, {"chunk", "0/2"}}}};
    EXPECT_EQ(wholeBakeParams(pile, &chunk)["pile"]["chunk"], "");
    EXPECT_EQ(chunk, "0/2");
}
