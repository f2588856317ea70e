// SPDX-License-Identifier: Apache-2.0
// The look of material-stack walls (issue 38 item 1, arches Fig. 11 / 20 / 22): a wall at any
// angle to the stack grid is planar, and the features the paper keeps (overhang lips, tunnel
// roofs) stay where its box puts them.
#include <rockvdb/arches/Edits.h>
#include <rockvdb/arches/StackBake.h>
#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Task.h>
#include "StackFixtures.h"

#include <gtest/gtest.h>
#include <openvdb/math/Operators.h>
#include <openvdb/tools/Interpolation.h>

#include <cmath>
#include <cstdio>

using namespace rockvdb;
using namespace rockvdb::arches;
using nlohmann::json;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A 50 m square block of bedrock 20 m thick (0.5 m stacks, 1 cm quanta) with a straight V crack
// 40 m long through its middle at 30° to the grid, its profile [[−w, 1], [w, 1], [0, −depth]]:
// at the top the V is 2·half wide, half = w·depth / (depth + 1), and its walls rise at
// atan(depth / half).
struct VCrack
{
    static constexpr double kCell = 0.5, kTop = 20.0, kLength = 40.0;
    static constexpr double kAngle = 30.0 * kPi / 180.0;
    const double depth, half;
    const Vec3d c{25.0, 25.0, 0.0};
    const Vec3d along{std::cos(kAngle), std::sin(kAngle), 0.0};
    const Vec3d across{-std::sin(kAngle), std::cos(kAngle), 0.0};
    Stacks stacks;

    VCrack(double w, double d) : depth(d), half(w * d / (d + 1.0))
    {
        Task task;
        stacks = Stacks::build(test::stackGeometry(100, 100, kCell), [](int, int, std::vector<Layer>& layers) {
            layers.push_back(Layer{Material::Bedrock, uint32_t(std::lround(kTop / 0.01))});
        }, task);
        const Vec3d a = c - along * (kLength / 2), b = c + along * (kLength / 2);
        const json crack = {{"tool", "crack"}, {"nodes", {{a[0], a[1]}, {b[0], b[1]}}}, {"spline", false},
                            {"profile", {{-w, 1.0}, {w, 1.0}, {0.0, -depth}}}};
        EditContext ctx;
        ctx.sigma = 0.25;
        applyEdit(stacks, crack, 0, ctx, task);
    }
    double slope() const { return std::atan(depth / half) * 180.0 / kPi; }

    // The share of wall voxels whose normal is within 5° of the ideal wall's, and how many.
    // Wall voxels: the band's voxels within a voxel of the surface that lie over a wall at
    // least a cell (horizontally) from the rim and the bottom and 2 m from the crack's ends.
    std::pair<double, size_t> wallShare(const openvdb::FloatGrid& g) const
    {
        const double dx = g.voxelSize()[0];
        const double cosMax = std::cos(5.0 * kPi / 180.0);
        size_t wall = 0, good = 0;
        openvdb::FloatGrid::ConstAccessor acc = g.getConstAccessor();
        for (auto it = g.cbeginValueOn(); it; ++it) {
            if (std::abs(*it) >= dx) continue;
            const Vec3d p = g.indexToWorld(it.getCoord()) - c;
            const double u = p.dot(along), n = p.dot(across);
            if (std::abs(u) > kLength / 2 - 2.0) continue;
            if (std::abs(n) < kCell || std::abs(n) > half - kCell) continue;
            if (p[2] > kTop - 0.1 || p[2] < kTop - depth - 1.0) continue; // the top beside the rim, the floor
            const double side = n < 0 ? -1.0 : 1.0;
            // The wall z = top − depth (1 − |n| / half): its outward normal.
            Vec3d ideal = across * (-side * depth / half) + Vec3d(0, 0, 1);
            ideal.normalize();
            const openvdb::Vec3f grad =
                openvdb::math::ISGradient<openvdb::math::CD_2ND>::result(acc, it.getCoord());
            const double len = grad.length();
            ++wall;
            if (len > 0 && Vec3d(grad[0], grad[1], grad[2]).dot(ideal) / len >= cosMax) ++good;
        }
        return {wall ? double(good) / double(wall) : 0.0, wall};
    }
};

// Stacks of 0.5 m over 20 x 10 m (nx x ny stacks): bedrock up to 5 m everywhere; where x < 10 m a slab of
// bedrock @a slab thick over an air gap from 5 to 7 m (an overhang whose lip is at x = 10);
// where 4 <= y < 6 m (and x >= 10) a tunnel from 2 to 4 m high, 2 m wide.
Stacks overhangAndTunnel(double slab, int nx = 40, int ny = 20)
{
    Task task;
    return Stacks::build(test::stackGeometry(nx, ny, 0.5), [&](int i, int j, std::vector<Layer>& layers) {
        auto q = [](double m) { return uint32_t(std::lround(m / 0.01)); };
        if (i < 20) {
            layers = {{Material::Bedrock, q(5)}, {Material::Air, q(2)}, {Material::Bedrock, q(slab)}};
        } else if (j >= 8 && j < 12) {
            layers = {{Material::Bedrock, q(2)}, {Material::Air, q(2)}, {Material::Bedrock, q(1)}};
        } else {
            layers = {{Material::Bedrock, q(5)}};
        }
    }, task);
}

openvdb::FloatGrid::Ptr bakeWith(const Stacks& stacks, Kernel kernel, double voxel)
{
    Task task;
    SkeletonBake b;
    b.sigma = 0.25;
    b.voxelSize = voxel;
    b.kernel = kernel;
    b.reach = kernel == Kernel::Interpolate ? kDefaultReachCells * stacks.geometry().cell : 0.0;
    return bakeSkeleton(Skeleton(stacks, kGroundMask), b, task);
}

double phiAt(const openvdb::FloatGrid& g, const Vec3d& p)
{
    return openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler>(g).wsSample(p);
}

// Where φ changes sign from a to b (bisection on the trilinear φ; a and b on either side).
Vec3d crossing(const openvdb::FloatGrid& g, Vec3d a, Vec3d b)
{
    const bool inA = phiAt(g, a) < 0;
    EXPECT_NE(inA, phiAt(g, b) < 0) << "no crossing between " << a << " and " << b;
    for (int k = 0; k < 40; ++k) {
        const Vec3d m = (a + b) * 0.5;
        ((phiAt(g, m) < 0) == inA ? a : b) = m;
    }
    return (a + b) * 0.5;
}

} // namespace

TEST(Walls, OverhangLipsAndTunnelRoofsStayWhereTheBoxPutsThem)
{
    // A 0.5 m slab: the lip's edge at mid-height, where the box puts it (its cells' edge), and
    // the tunnel's roof, floor and walls where the stacks have them.
    const Stacks s = overhangAndTunnel(0.5);
    const auto box = bakeWith(s, Kernel::Box, 0.125), interp = bakeWith(s, Kernel::Interpolate, 0.125);
    for (const auto* g : {box.get(), interp.get()}) {
        const char* name = g == box.get() ? "box" : "interpolate";
        EXPECT_NEAR(crossing(*g, {8, 2, 7.25}, {12, 2, 7.25})[0], 10.0, 0.07) << name << ": the lip's edge";
        EXPECT_LT(phiAt(*g, {9.0, 2, 7.25}), 0.0) << name << ": the slab";
        EXPECT_GT(phiAt(*g, {9.0, 2, 6.0}), 0.0) << name << ": the air under the lip";
        EXPECT_NEAR(crossing(*g, {15, 5, 3}, {15, 5, 4.6})[2], 4.0, 0.02) << name << ": the tunnel's roof";
        EXPECT_NEAR(crossing(*g, {15, 5, 3}, {15, 5, 1.4})[2], 2.0, 0.02) << name << ": the tunnel's floor";
        EXPECT_NEAR(crossing(*g, {15, 5, 3}, {15, 3, 3})[1], 4.0, 0.07) << name << ": the tunnel's wall";
        EXPECT_NEAR(crossing(*g, {15, 5, 3}, {15, 7, 3})[1], 6.0, 0.07) << name << ": the tunnel's wall";
    }
    // A 0.2 m slab (thinner than σ = 0.25 m) is smoothed away by both, as §3.3 does
    // (σ − 0.2 > 0 at its middle); a 0.3 m one stays in both, its lip where the box has it
    // (a third of a cell back from its cells' edge: inside σ − 0.3, outside σ).
    double lip[2];
    for (const auto kernel : {Kernel::Box, Kernel::Interpolate}) {
        // (13 x 6 m of the scene: the lip and what is around it, at 5 cm.)
        const auto thin = bakeWith(overhangAndTunnel(0.2, 26, 12), kernel, 0.05);
        EXPECT_GT(phiAt(*thin, {5.0, 2, 7.1}), 0.0) << int(kernel) << ": the 0.2 m slab is gone";
        const auto kept = bakeWith(overhangAndTunnel(0.3, 26, 12), kernel, 0.05);
        EXPECT_LT(phiAt(*kept, {5.0, 2, 7.15}), -0.02) << int(kernel) << ": the 0.3 m slab stays";
        lip[int(kernel)] = crossing(*kept, {8, 2, 7.15}, {12, 2, 7.15})[0];
    }
    EXPECT_NEAR(lip[0], 10.0 - 0.5 / 3, 0.03);
    EXPECT_NEAR(lip[1], lip[0], 0.01);
}

TEST(Walls, AVCrackAt30DegreesToTheGridHasPlanarWalls)
{
    Task task;
    // 53° walls (the criterion's), and 72°.
    for (const auto& [w, depth] : {std::pair{3.0, 3.0}, std::pair{3.0, 8.0}}) {
        const VCrack crack(w, depth);
        SkeletonBake b;
        b.sigma = 0.25;      // the default: half the cell
        b.voxelSize = 0.25;  // cell / 2
        // §3.3's box (kernel box): measured to report the gain, and asserted to be worse, so
        // that the test cannot pass for a wall that is not at an angle to the grid.
        b.kernel = Kernel::Box;
        const auto [boxShare, boxWall] = crack.wallShare(*bakeSkeleton(Skeleton(crack.stacks, kGroundMask), b, task));
        // The stage's default (kernel interpolate, its default reach).
        b.kernel = Kernel::Interpolate;
        b.reach = kDefaultReachCells * VCrack::kCell;
        const auto [share, wall] = crack.wallShare(*bakeSkeleton(Skeleton(crack.stacks, kGroundMask), b, task));
        std::printf("V crack at 30 deg to the grid, %.0f deg walls: normals within 5 deg on %.1f %% of %zu wall "
                    "voxels (box: %.1f %% of %zu)\n", crack.slope(), 100 * share, wall, 100 * boxShare, boxWall);
        EXPECT_GT(wall, 1000u);
        EXPECT_GE(share, 0.95);
        EXPECT_LT(boxShare, 0.9);
    }
}
