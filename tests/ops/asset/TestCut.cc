// SPDX-License-Identifier: Apache-2.0
// One block or rock cut out by its id (asset/Cut.h): a rock standing apart keeps its band
// bit for bit; two blocks fused without a gap are parted at the face where their ids meet;
// a thin layer between two big blocks keeps its inside; an id that is not there is named
// with the ids that are.
#include <rockvdb/asset/Cut.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/LevelSetUtil.h>

using namespace rockvdb;
using namespace rockvdb::asset;
using openvdb::FloatGrid;
using openvdb::Vec3d;

namespace {

// An id grid on the surface's active voxels: id(world position).
template<typename IdOf>
FloatGrid::Ptr ids(const FloatGrid& surface, const IdOf& idOf)
{
    auto g = FloatGrid::create(-1.0f);
    g->setTransform(surface.transform().copy());
    g->setName("rock_id");
    auto acc = g->getAccessor();
    for (auto it = surface.cbeginValueOn(); it; ++it) {
        if (!it.isVoxelValue()) continue;
        acc.setValueOn(it.getCoord(), float(idOf(surface.transform().indexToWorld(it.getCoord()))));
    }
    return g;
}

double cutPhiAt(const FloatGrid& g, const Vec3d& p)
{
    auto acc = g.getConstAccessor();
    return openvdb::tools::BoxSampler::sample(acc, g.transform().worldToIndex(p));
}

} // namespace

TEST(Cut, ARockApartKeepsItsBandBitForBit)
{
    const float h = 0.05f;
    auto s = openvdb::tools::createLevelSetSphere<FloatGrid>(0.5f, openvdb::Vec3f(0), h, 3.0f);
    openvdb::tools::csgUnion(*s, *openvdb::tools::createLevelSetSphere<FloatGrid>(0.5f, openvdb::Vec3f(2, 0, 0), h, 3.0f));
    const auto id = ids(*s, [](const Vec3d& p) { return p.x() < 1 ? 1 : 2; });
    EXPECT_EQ(surfaceIdList(*s, *id), (std::vector<int>{1, 2}));
    Task task;
    const CutResult c = cutId(*s, *id, 2, 1u << 26, task);
    EXPECT_FALSE(c.rebuilt);
    EXPECT_GT(cutPhiAt(*c.grid, Vec3d(0, 0, 0)), 0.0);   // rock 1 is gone
    EXPECT_LT(cutPhiAt(*c.grid, Vec3d(2, 0, 0)), 0.0);   // rock 2 is there
    EXPECT_EQ(c.grid->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_EQ(c.grid->background(), s->background());
    auto in = s->getConstAccessor();
    size_t band = 0;
    for (auto it = c.grid->cbeginValueOn(); it; ++it) {
        if (!it.isVoxelValue() || !(std::abs(*it) < s->background())) continue;
        const Vec3d p = c.grid->transform().indexToWorld(it.getCoord());
        ASSERT_GT(p.x(), 1.0);
        ASSERT_EQ(*it, in.getValue(it.getCoord()));
        ++band;
    }
    EXPECT_GT(band, 1000u);
}

TEST(Cut, FusedBlocksArePartedWhereTheirIdsMeet)
{
    // one 2 x 1 x 1 box whose halves are blocks 7 (x < 1) and 9: no gap, no surface between
    const double h = 0.05;
    auto g = openvdb::tools::createLevelSetBox<FloatGrid>(openvdb::BBoxd(Vec3d(0), Vec3d(2, 1, 1)),
        *openvdb::math::Transform::createLinearTransform(h), 3.0f);
    const auto id = ids(*g, [](const Vec3d& p) { return p.x() < 1 ? 7 : 9; });
    Task task;
    const CutResult c = cutId(*g, *id, 7, 1u << 26, task);
    EXPECT_TRUE(c.rebuilt);
    EXPECT_LT(cutPhiAt(*c.grid, Vec3d(0.5, 0.5, 0.5)), 0.0);
    EXPECT_GT(cutPhiAt(*c.grid, Vec3d(1.5, 0.5, 0.5)), 0.0);
    // the cut face lies at x = 1 within a voxel, and the rest of block 7 is where it was
    EXPECT_NEAR(cutPhiAt(*c.grid, Vec3d(0.9, 0.5, 0.5)), -0.1, 1.5 * h);
    EXPECT_NEAR(cutPhiAt(*c.grid, Vec3d(1.1, 0.5, 0.5)), 0.1, 1.5 * h);
    EXPECT_NEAR(cutPhiAt(*c.grid, Vec3d(0.5, 0.5, 1.0)), 0.0, 0.5 * h);
    EXPECT_NEAR(cutPhiAt(*c.grid, Vec3d(0.0, 0.5, 0.5)), 0.0, 0.5 * h);
    const CutResult other = cutId(*g, *id, 9, 1u << 26, task);
    EXPECT_GT(cutPhiAt(*other.grid, Vec3d(0.5, 0.5, 0.5)), 0.0);
    EXPECT_LT(cutPhiAt(*other.grid, Vec3d(1.5, 0.5, 0.5)), 0.0);
}

TEST(Cut, AnIdThatIsNotThereIsNamed)
{
    auto s = openvdb::tools::createLevelSetSphere<FloatGrid>(0.5f, openvdb::Vec3f(0), 0.05f, 3.0f);
    const auto id = ids(*s, [](const Vec3d& p) { return p.x() < 0 ? 3 : 4; });
    Task task;
    try {
        cutId(*s, *id, 12, 1u << 26, task);
        FAIL() << "no error";
    } catch (const ValueError& e) {
        EXPECT_STREQ(e.what(), "asset: id 12 is not in 'rock_id' (it holds 2 ids from 3 to 4)");
    }
    EXPECT_THROW(cutId(*s, *id, 3, 100, task), ValueError); // box over the limit
    auto moved = id->deepCopy();
    moved->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    EXPECT_THROW(cutId(*s, *moved, 3, 1u << 26, task), ValueError);
}

TEST(Cut, AThinLayerBetweenTwoBigBlocksKeepsItsInside)
{
    // a 4 x 4 x 3 m box in three fused layers: 0 below z = 1.2, 1 up to z = 1.5 (6 voxels
    // thick), 2 above. Cutting 1 drops the big blocks, which span whole leaves: their space
    // must come out as outside and the layer's as inside (a sign guessed by flood filling the
    // emptied leaves loses it)
    const double h = 0.05;
    auto g = openvdb::tools::createLevelSetBox<FloatGrid>(openvdb::BBoxd(Vec3d(0), Vec3d(4, 4, 3)),
        *openvdb::math::Transform::createLinearTransform(h), 3.0f);
    const auto id = ids(*g, [](const Vec3d& p) { return p.z() < 1.2 ? 0 : (p.z() < 1.5 ? 1 : 2); });
    Task task;
    const CutResult c = cutId(*g, *id, 1, 1u << 26, task);
    EXPECT_TRUE(c.rebuilt);
    for (const Vec3d xy : {Vec3d(2, 2, 0), Vec3d(0.3, 0.3, 0), Vec3d(3.7, 0.4, 0), Vec3d(1.1, 3.3, 0)}) {
        EXPECT_LT(cutPhiAt(*c.grid, xy + Vec3d(0, 0, 1.35)), -0.1) << xy;
        // the faces lie half way between the last voxel centre of one id and the first of the
        // next (centres at multiples of h: layer 1 holds z = 1.20 ... 1.45)
        EXPECT_NEAR(cutPhiAt(*c.grid, xy + Vec3d(0, 0, 1.175)), 0.0, 0.25 * h) << xy;
        EXPECT_NEAR(cutPhiAt(*c.grid, xy + Vec3d(0, 0, 1.475)), 0.0, 0.25 * h) << xy;
        EXPECT_GT(cutPhiAt(*c.grid, xy + Vec3d(0, 0, 0.6)), 0.0) << xy;
        EXPECT_GT(cutPhiAt(*c.grid, xy + Vec3d(0, 0, 2.3)), 0.0) << xy;
    }
}
