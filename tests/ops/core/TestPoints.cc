// SPDX-License-Identifier: Apache-2.0
// Instance points (core/Points.h): the attributes Houdini's Copy to Points reads survive a
// real .vdb file, orient is stored (x, y, z, w) and turns a piece the way its angle says.
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Points.h>

#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/points/AttributeArray.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>

#include <cmath>
#include <map>

using namespace rockvdb;

namespace {

InstancePoints three()
{
    InstancePoints p;
    p.positions = {{0.25, 0.5, 0.75}, {-3.0, 2.0, 1.0}, {10.0, -4.5, 0.0}};
    // A quarter turn about z: (x, y, z, w) = (0, 0, sin 45°, cos 45°).
    const float s = float(std::sqrt(0.5));
    p.orient = {{0, 0, 0, 1}, {0, 0, s, s}, {s, 0, 0, s}};
    p.pscale = {1.0f, 0.5f, 2.0f};
    p.variant = {4, 0, 7};
    p.ints = {{"rock", {4, 0, 7}}, {"tile", {1, 1, 2}}};
    return p;
}

} // namespace

TEST(Points, AttributesSurviveAFileInTheirOrder)
{
    openvdb::initialize();
    const InstancePoints p = three();
    const std::string path = ::testing::TempDir() + "/points.vdb";
    {
        openvdb::io::File f(path);
        f.write({instancePointsGrid(p, 0.5, "rocks")});
    }
    openvdb::io::File f(path);
    f.open();
    auto points = openvdb::gridPtrCast<openvdb::points::PointDataGrid>(f.readGrid("rocks"));
    ASSERT_TRUE(points);
    ASSERT_EQ(openvdb::points::pointCount(points->tree()), p.positions.size());
    std::map<int, int> seen;
    for (auto leaf = points->tree().cbeginLeaf(); leaf; ++leaf) {
        using namespace openvdb::points;
        AttributeHandle<openvdb::Vec3f> P(leaf->constAttributeArray("P"));
        AttributeHandle<openvdb::math::Quats> orient(leaf->constAttributeArray("orient"));
        AttributeHandle<float> pscale(leaf->constAttributeArray("pscale"));
        AttributeHandle<int32_t> variant(leaf->constAttributeArray("variant"));
        AttributeHandle<int32_t> id(leaf->constAttributeArray("id"));
        AttributeHandle<int32_t> rock(leaf->constAttributeArray("rock"));
        AttributeHandle<int32_t> tile(leaf->constAttributeArray("tile"));
        for (auto idx = leaf->beginIndexOn(); idx; ++idx) {
            const int i = id.get(*idx);
            ASSERT_GE(i, 0);
            ASSERT_LT(size_t(i), p.positions.size());
            ++seen[i];
            const openvdb::Vec3d w =
                points->transform().indexToWorld(P.get(*idx) + idx.getCoord().asVec3d());
            EXPECT_LT((w - p.positions[i]).length(), 1e-5);
            EXPECT_EQ(orient.get(*idx), p.orient[i]);
            EXPECT_EQ(pscale.get(*idx), p.pscale[i]);
            EXPECT_EQ(variant.get(*idx), p.variant[i]);
            EXPECT_EQ(rock.get(*idx), p.ints[0].second[i]);
            EXPECT_EQ(tile.get(*idx), p.ints[1].second[i]);
        }
    }
    EXPECT_EQ(seen, (std::map<int, int>{{0, 1}, {1, 1}, {2, 1}}));
}

TEST(Points, OrientIsXyzwAndTurnsByItsAngle)
{
    const InstancePoints p = three();
    // Stored as Houdini's orient: w last. A quarter turn about z takes +x to +y, about x takes
    // +y to +z (a (w, x, y, z) reading would turn about other axes).
    EXPECT_FLOAT_EQ(p.orient[1].w(), float(std::sqrt(0.5)));
    const auto a = p.orient[1].rotateVector(openvdb::Vec3s(1, 0, 0));
    EXPECT_LT((a - openvdb::Vec3s(0, 1, 0)).length(), 1e-6f);
    const auto b = p.orient[2].rotateVector(openvdb::Vec3s(0, 1, 0));
    EXPECT_LT((b - openvdb::Vec3s(0, 0, 1)).length(), 1e-6f);
}

TEST(Points, AttributesOfDifferentLengthsAreRefused)
{
    openvdb::initialize();
    InstancePoints p = three();
    p.pscale.pop_back();
    EXPECT_THROW(instancePointsGrid(p, 0.5, "rocks"), ValueError);
    p = three();
    p.ints[1].second.push_back(3);
    EXPECT_THROW(instancePointsGrid(p, 0.5, "rocks"), ValueError);
}
