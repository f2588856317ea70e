// SPDX-License-Identifier: Apache-2.0
// The relief of the gradient-based warp (relief/Relief.h, implicit-blocks §4.2): bounded by
// its amplitude, the tabulated turbulence equal to the direct one, its slope under the bound
// the bake's culling trusts, images tiled with bright = bump, and the triplanar weights.
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Random.h>
#include <rockvdb/relief/Relief.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <unistd.h>

using namespace rockvdb;
using namespace rockvdb::relief;

namespace {

ReliefParams turbulence(double amplitude)
{
    ReliefParams p;
    p.amplitude = amplitude;
    p.scale = 1.5;
    p.octaves = 4;
    return p;
}

} // namespace

TEST(Relief, BoundedByAmplitudeAndZeroWhenOff)
{
    const Relief r(turbulence(0.05), 3, -10, 10);
    float lo = 1, hi = -1;
    for (int i = 0; i < 20000; ++i) {
        const float u = float(random::uniform(9, 0, uint64_t(i), -10, 10));
        const float v = float(random::uniform(9, 1, uint64_t(i), -10, 10));
        const float d = r(u, v);
        ASSERT_LE(std::abs(d), 0.05f + 1e-6f);
        lo = std::min(lo, d);
        hi = std::max(hi, d);
    }
    // It uses the range: grooves (+A) and bumps.
    EXPECT_GT(hi, 0.04f);
    EXPECT_LT(lo, 0.0f);
    const Relief off(turbulence(0.0), 3, -10, 10);
    EXPECT_EQ(off(1.25f, -3.5f), 0.0f);
    EXPECT_EQ(off.slopeBound(), 0.0);
}

TEST(Relief, TableMatchesDirectTurbulenceAndSeedsDiffer)
{
    // A small coordinate range is tabulated; a huge one (> 16 M texels) evaluates directly.
    const Relief table(turbulence(0.05), 3, -4, 4);
    const Relief direct(turbulence(0.05), 3, -1e5f, 1e5f);
    const Relief other(turbulence(0.05), 4, -4, 4);
    double err = 0, maxErr = 0, seedDiff = 0;
    const int n = 5000;
    for (int i = 0; i < n; ++i) {
        const float u = float(random::uniform(10, 0, uint64_t(i), -3, 3));
        const float v = float(random::uniform(10, 1, uint64_t(i), -3, 3));
        const double e = std::abs(table(u, v) - direct(u, v));
        err += e;
        maxErr = std::max(maxErr, e);
        seedDiff += std::abs(table(u, v) - other(u, v));
    }
    // Bilinear on scale/64 texels: a few per cent of the amplitude at worst.
    EXPECT_LT(err / n, 0.002);
    EXPECT_LT(maxErr, 0.01);
    EXPECT_GT(seedDiff / n, 0.005);
    // Same parameters and seed: the same values.
    const Relief again(turbulence(0.05), 3, -4, 4);
    EXPECT_EQ(again(0.37f, -1.2f), table(0.37f, -1.2f));
}

TEST(Relief, SlopeStaysUnderTheBound)
{
    const Relief r(turbulence(0.05), 1, -1e5f, 1e5f); // direct: no interpolation kinks
    const double bound = r.slopeBound();
    ASSERT_GT(bound, 0.0);
    const float h = 1e-3f;
    double steepest = 0;
    for (int i = 0; i < 20000; ++i) {
        const float u = float(random::uniform(11, 0, uint64_t(i), -5, 5));
        const float v = float(random::uniform(11, 1, uint64_t(i), -5, 5));
        const double gu = (r(u + h, v) - r(u - h, v)) / (2 * h);
        const double gv = (r(u, v + h) - r(u, v - h)) / (2 * h);
        steepest = std::max(steepest, std::sqrt(gu * gu + gv * gv));
    }
    EXPECT_LE(steepest, bound);
    EXPECT_GT(steepest, 0.05 * bound); // the bound is not vacuous
}

TEST(Relief, ImageIsTiledWithBrightAsBump)
{
    // A 16×8 ramp in u: dark at i = 0, bright at i = 15.
    GrayImage img;
    img.width = 16;
    img.height = 8;
    for (int j = 0; j < img.height; ++j)
        for (int i = 0; i < img.width; ++i) img.pixels.push_back(float(i) / 15.0f);
    const std::string path = "/tmp/rockvdb_relief_" + std::to_string(::getpid()) + ".exr";
    writeGrayImage(path, img);
    ReliefParams p;
    p.amplitude = 0.1;
    p.scale = 2.0; // one image tile per 2 m
    p.image = path;
    const Relief r(p, 0, 0, 1);
    std::remove(path.c_str());
    // Texel i sits at u = i·scale/width; darkest: a groove (+A), brightest: a bump (−A).
    EXPECT_NEAR(r(0.0f, 0.3f), 0.1f, 1e-5f);
    EXPECT_NEAR(r(15 * 2.0f / 16, 0.3f), -0.1f, 1e-5f);
    // Tiled: one scale further along either axis is the same value.
    for (float u : {0.13f, 0.77f, 1.41f})
        for (float v : {0.05f, 0.9f}) {
            EXPECT_NEAR(r(u + 2.0f, v), r(u, v), 1e-5f);
            EXPECT_NEAR(r(u, v - 2.0f), r(u, v), 1e-5f);
        }
}

TEST(Relief, TriplanarWeightsFollowTheNormal)
{
    // An axis normal reads its own projection only: z → xy, y → xz, x → yz.
    EXPECT_FLOAT_EQ(triplanar(0, 0, 1, 0.3f, 0.7f, 0.9f, 1), 0.3f);
    EXPECT_FLOAT_EQ(triplanar(0, -1, 0, 0.3f, 0.7f, 0.9f, 1), 0.7f);
    EXPECT_FLOAT_EQ(triplanar(1, 0, 0, 0.3f, 0.7f, 0.9f, 8), 0.9f);
    // A convex combination: never beyond the projections' range.
    for (int i = 0; i < 1000; ++i) {
        const float gx = float(random::uniform(12, 0, uint64_t(i), -1, 1));
        const float gy = float(random::uniform(12, 1, uint64_t(i), -1, 1));
        const float gz = float(random::uniform(12, 2, uint64_t(i), -1, 1));
        for (float p : {1.0f, 3.0f, 8.0f}) {
            const float t = triplanar(gx, gy, gz, -0.2f, 0.1f, 0.5f, p);
            EXPECT_GE(t, -0.2f - 1e-6f);
            EXPECT_LE(t, 0.5f + 1e-6f);
        }
        // p = 8 by squaring equals the pow form.
        const float ax = std::pow(std::abs(gx), 8.0f), ay = std::pow(std::abs(gy), 8.0f),
                    az = std::pow(std::abs(gz), 8.0f);
        const float ref = (az * -0.2f + ay * 0.1f + ax * 0.5f) / std::max(ax + ay + az, 1e-12f);
        EXPECT_NEAR(triplanar(gx, gy, gz, -0.2f, 0.1f, 0.5f, 8), ref, 1e-5f);
    }
    // Sharper weights lean harder on the dominant axis.
    const float soft = triplanar(0.3f, 0.1f, 0.95f, 1.0f, 0.0f, 0.0f, 1);
    const float sharp = triplanar(0.3f, 0.1f, 0.95f, 1.0f, 0.0f, 0.0f, 8);
    EXPECT_GT(sharp, soft);
}
