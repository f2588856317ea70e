// SPDX-License-Identifier: Apache-2.0
// Ambient occlusion by cone tracing (asset/Occlusion.h): open sky on a sphere and on a flat
// top, dark at the bottom of a narrow slot and deep on its wall, lighter near its rim, as the cosine-weighted
// view of the sky says; the baked grid agrees with the traced value at surface points.
#include <rockvdb/asset/Occlusion.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/MeshToVolume.h>

#include <cmath>

using namespace rockvdb;
using namespace rockvdb::asset;
using openvdb::FloatGrid;
using openvdb::Vec3d;

namespace {

FloatGrid::Ptr box(const Vec3d& lo, const Vec3d& hi, double h)
{
    return openvdb::tools::createLevelSetBox<FloatGrid>(openvdb::BBoxd(lo, hi),
        *openvdb::math::Transform::createLinearTransform(h), 3.0f);
}

double sampled(const Occlusion& occ, const Vec3d& p)
{
    auto acc = occ.value->getConstAccessor();
    return openvdb::tools::BoxSampler::sample(acc, occ.value->transform().worldToIndex(p));
}

} // namespace

TEST(Occlusion, ASphereSeesTheWholeSky)
{
    auto g = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0), 0.02f, 3.0f);
    Task task;
    const Occlusion occ = occlusion(surfaceMesh(*g), 0.02, 0.5, task);
    EXPECT_NEAR(occ.voxel, 0.5 / 12, 1e-12);
    for (const Vec3d n : {Vec3d(0, 0, 1), Vec3d(1, 0, 0), Vec3d(0, -1, 0), Vec3d(0.6, 0.48, -0.64)}) {
        EXPECT_GE(traceOcclusion(occ, n, n), 0.98) << n;
        EXPECT_GE(sampled(occ, n), 0.97) << n;
    }
}

TEST(Occlusion, ASlotIsDarkAtItsBottomAndOpenAboveIt)
{
    // a 2 x 2 x 1 m block with a slot 0.1 m wide and 0.4 m deep along x through its top
    const double h = 0.01;
    auto g = box(Vec3d(-1, -1, 0), Vec3d(1, 1, 1), h);
    openvdb::tools::csgDifference(*g, *box(Vec3d(-1.5, -0.05, 0.6), Vec3d(1.5, 0.05, 1.5), h));
    Task task;
    const Occlusion occ = occlusion(surfaceMesh(*g), h, 0.5, task);
    const double bottom = traceOcclusion(occ, Vec3d(0, 0, 0.6), Vec3d(0, 0, 1));
    // the wall 5 cm below the rim: the sky above 27 degrees (atan(0.05 / 0.1)) of elevation,
    // a cosine-weighted share of about (1 - sin 27°) / 2 = 0.28; deeper on the wall it is dark
    const double wall = traceOcclusion(occ, Vec3d(0, 0.05, 0.95), Vec3d(0, -1, 0));
    const double deepWall = traceOcclusion(occ, Vec3d(0, 0.05, 0.7), Vec3d(0, -1, 0));
    const double top = traceOcclusion(occ, Vec3d(0, 0.6, 1.0), Vec3d(0, 0, 1));
    // the bottom's cosine-weighted view of the sky through the slot is sin(atan(0.05 / 0.4))
    // = 0.12; the cones, 20 degrees wide, see a little more
    EXPECT_LT(bottom, 0.35);
    EXPECT_LT(bottom, wall);
    EXPECT_LT(deepWall, wall);
    EXPECT_GT(wall, 0.1);
    EXPECT_LT(wall, 0.6);
    EXPECT_GE(top, 0.97);
    EXPECT_NEAR(sampled(occ, Vec3d(0, 0, 0.6)), bottom, 0.15);
    EXPECT_GE(sampled(occ, Vec3d(0, 0.6, 1.0)), 0.95);
    // beyond the distance nothing occludes: a slot deeper than D sees more at its bottom
    const Occlusion near = occlusion(surfaceMesh(*g), h, 0.12, task);
    EXPECT_GT(traceOcclusion(near, Vec3d(0, 0, 0.6), Vec3d(0, 0, 1)), bottom);
}

TEST(Occlusion, RefusesABadDistance)
{
    auto g = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0), 0.1f, 3.0f);
    Task task;
    const TriMesh m = surfaceMesh(*g);
    EXPECT_THROW(occlusion(m, 0.1, 0.0, task), ValueError);
    EXPECT_THROW(occlusion(m, 0.1, std::nan(""), task), ValueError);
    EXPECT_THROW(occlusion(TriMesh(), 0.1, 1.0, task), ValueError);
}
