// SPDX-License-Identifier: Apache-2.0
// Previews (core/Preview.h): the framing follows the grid's bounds, ids tint what they cover,
// the same call gives the same pixels, and bad settings or palettes are refused.
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Preview.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/Triplanar.h>
#include <rockvdb/core/VdbIO.h>

#include <gtest/gtest.h>

#include <cmath>

using namespace rockvdb;
using openvdb::FloatGrid;

namespace {

BakeResult bakeAt(const FieldPtr& f, double dx, bool ids = false)
{
    BakeSettings s;
    s.voxelSize = dx;
    s.withAttribute = ids;
    return bake(*f, s);
}

PreviewSettings smallPreview()
{
    PreviewSettings s;
    s.width = 160;
    s.height = 120;
    return s;
}

} // namespace

TEST(Preview, FramingFollowsTheBoundsAndPixelsRepeat)
{
    initialize();
    PreviewStats a, b, m;
    auto g1 = bakeAt(sphere(Vec3d(0), 1.0), 0.05).surface;
    auto g2 = bakeAt(sphere(Vec3d(0), 2.0), 0.1).surface; // the same sphere in voxels
    auto g3 = bakeAt(sphere(Vec3d(5, -3, 2), 1.0), 0.05).surface;
    const auto p1 = renderPreview(*g1, smallPreview(), nullptr, &a);
    renderPreview(*g2, smallPreview(), nullptr, &b);
    renderPreview(*g3, smallPreview(), nullptr, &m);
    ASSERT_EQ(p1.size(), size_t(160 * 120 * 3));
    EXPECT_EQ(a.pixels, size_t(160 * 120));
    // The sphere fills a good part of the frame but not all of it (sky at the corners).
    EXPECT_GT(a.surfacePixels, a.pixels / 10);
    EXPECT_LT(a.surfacePixels, a.pixels * 9 / 10);
    // Framed by its bounds: a scaled sphere covers the same pixels; a moved one about the
    // same (its band's bounding box may differ by a voxel where |d| meets the band's edge).
    EXPECT_NEAR(double(b.surfacePixels), double(a.surfacePixels), 0.01 * double(a.surfacePixels));
    EXPECT_NEAR(double(m.surfacePixels), double(a.surfacePixels), 0.08 * double(a.surfacePixels));
    // Zooming in covers more.
    PreviewSettings zoom = smallPreview();
    zoom.zoom = 1.5;
    PreviewStats c;
    renderPreview(*g1, zoom, nullptr, &c);
    EXPECT_GT(c.surfacePixels, a.surfacePixels * 3 / 2);
    // The same call, the same bytes.
    EXPECT_EQ(renderPreview(*g1, smallPreview()), p1);
}

TEST(Preview, IdsTintWhatTheyCover)
{
    initialize();
    auto f = unite(tag(sphere(Vec3d(-1.2, 0, 0), 0.8), 3), tag(sphere(Vec3d(1.2, 0, 0), 0.8), 5));
    auto r = bakeAt(f, 0.05, true);
    PreviewSettings s = smallPreview();
    s.azimuth = 90; // looking along -y: the two spheres side by side
    s.elevation = 0;
    s.palette = parsePalette("3=#ff0000,5=#0000ff");
    PreviewStats st;
    const auto px = renderPreview(*r.surface, s, r.attribute.get(), &st);
    ASSERT_EQ(st.idPixels.count(3), 1u);
    ASSERT_EQ(st.idPixels.count(5), 1u);
    EXPECT_EQ(st.idPixels[3] + st.idPixels[5], st.surfacePixels);
    // Symmetric scene: each sphere covers about half.
    EXPECT_NEAR(double(st.idPixels[3]), double(st.idPixels[5]), 0.1 * double(st.idPixels[3]));
    // Red and blue both appear, each on its own side of the image.
    size_t redLeft = 0, redRight = 0, blueLeft = 0, blueRight = 0;
    for (int j = 0; j < s.height; ++j)
        for (int i = 0; i < s.width; ++i) {
            const uint8_t* c = &px[size_t(j * s.width + i) * 3];
            const bool red = c[0] > 2 * c[2] + 20, blue = c[2] > 2 * c[0] + 20;
            (i < s.width / 2 ? redLeft : redRight) += red;
            (i < s.width / 2 ? blueLeft : blueRight) += blue;
        }
    EXPECT_GT(redLeft + redRight, 100u);
    EXPECT_GT(blueLeft + blueRight, 100u);
    EXPECT_TRUE((redLeft > 10 * redRight && blueRight > 10 * blueLeft) ||
                (redRight > 10 * redLeft && blueLeft > 10 * blueRight));
}

TEST(Preview, BadSettingsAndPalettesAreRefused)
{
    initialize();
    auto g = bakeAt(sphere(Vec3d(0), 1.0), 0.1).surface;
    PreviewSettings s = smallPreview();
    s.width = 0;
    EXPECT_THROW(renderPreview(*g, s), ValueError);
    s = smallPreview();
    s.fov = 180;
    EXPECT_THROW(renderPreview(*g, s), ValueError);
    s = smallPreview();
    s.elevation = std::nan("");
    EXPECT_THROW(renderPreview(*g, s), ValueError);
    EXPECT_THROW(parsePalette("3=red"), ValueError);
    EXPECT_THROW(parsePalette("x=#ff0000"), ValueError);
    EXPECT_THROW(parsePalette("3=#ff00"), ValueError);
    const auto pal = parsePalette("7=#ffffff,2=#000000");
    ASSERT_EQ(pal.size(), 2u);
    EXPECT_DOUBLE_EQ(pal.at(7)[0], 1.0);
    EXPECT_DOUBLE_EQ(pal.at(2)[2], 0.0);
}

TEST(Preview, TheTriplanarBlendTakesEachAxisProjectionWithItsLpWeight)
{
    // A normal along an axis sees the projection along it only (the plane of the other two):
    // a wall facing x is textured by (y, z), whatever its x. p = 8: 0.8 against 0.6 weighs
    // 0.8^8 / (0.8^8 + 0.6^8) = 0.909.
    EXPECT_FLOAT_EQ(triplanar(1, 0, 0, 1.0f, 2.0f, 3.0f, 8.0f), 3.0f);
    EXPECT_FLOAT_EQ(triplanar(0, -1, 0, 1.0f, 2.0f, 3.0f, 8.0f), 2.0f);
    EXPECT_FLOAT_EQ(triplanar(0, 0, 1, 1.0f, 2.0f, 3.0f, 8.0f), 1.0f);
    const double a = std::pow(0.8, 8) / (std::pow(0.8, 8) + std::pow(0.6, 8));
    EXPECT_NEAR(triplanar(0.8f, 0, 0.6f, 1.0f, 2.0f, 3.0f, 8.0f), a * 3 + (1 - a) * 1, 1e-5);
    EXPECT_NEAR(triplanar(0.8f, 0, 0.6f, 1.0f, 2.0f, 3.0f, 1.0f), (0.8 * 3 + 0.6 * 1) / 1.4, 1e-5);
    // The bedrock's texture on a wall facing x: bands along z, nothing along x (depth).
    PreviewMaterial bedrock;
    bedrock.name = "bedrock";
    const Vec3d nx(1, 0, 0);
    const auto t0 = materialTexture(bedrock, Vec3d(0.0, 1.0, 2.0), nx);
    EXPECT_EQ(materialTexture(bedrock, Vec3d(5.0, 1.0, 2.0), nx), t0);
    double lo = 1e9, hi = -1e9;
    for (double z = 0; z < 1; z += 0.02) {
        const double v = materialTexture(bedrock, Vec3d(0.0, 1.0, z), nx)[0];
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    EXPECT_GT(hi - lo, 0.1 * bedrock.colour[0]) << "strata across a metre of wall";
}

TEST(Preview, TextureBlendsTheMaterialsByTheirWeights)
{
    initialize();
    auto g = bakeAt(sphere(Vec3d(0), 1.0), 0.05).surface;
    // Weight grids on the band: all sand, then all bedrock; then half each.
    auto weight = [&](const char* name, float v) {
        auto w = FloatGrid::create(0.0f);
        w->setTransform(g->transform().copy());
        w->topologyUnion(*g);
        for (auto it = w->beginValueOn(); it; ++it) it.setValue(v);
        w->setName(name);
        return w;
    };
    PreviewSettings s = smallPreview();
    s.texture = true;
    auto mean = [&](const std::vector<PreviewMaterial>& m, PreviewStats* st) {
        const auto plain = renderPreview(*g, smallPreview());
        const auto rgb = renderPreview(*g, s, nullptr, st, &m);
        std::array<double, 3> sum{{0, 0, 0}};
        size_t n = 0;
        for (size_t p = 0; p < rgb.size(); p += 3) {
            if (plain[p] == rgb[p] && plain[p + 1] == rgb[p + 1] && plain[p + 2] == rgb[p + 2]) continue; // sky
            for (int k = 0; k < 3; ++k) sum[size_t(k)] += rgb[p + size_t(k)];
            ++n;
        }
        EXPECT_GT(n, 1000u);
        return std::array<double, 3>{{sum[0] / double(n), sum[1] / double(n), sum[2] / double(n)}};
    };
    PreviewStats ss, sb, sh;
    const openvdb::GridPtrVec sandOnly{weight("weight_sand", 1.0f)}, bedrockOnly{weight("weight_bedrock", 1.0f)};
    const auto sand = mean(previewMaterials(sandOnly), &ss);
    const auto rock = mean(previewMaterials(bedrockOnly), &sb);
    EXPECT_GT(sand[0] - sand[2], rock[0] - rock[2] + 30) << "sand is yellow, bedrock grey";
    EXPECT_EQ(ss.materialPixels.at("sand"), ss.surfacePixels);
    // Both at once, sand weighing 3 to bedrock's 1: between the two, nearer the sand.
    const openvdb::GridPtrVec both{weight("weight_sand", 0.75f), weight("weight_bedrock", 0.25f)};
    const auto mix = mean(previewMaterials(both), &sh);
    const double t = (mix[0] - mix[2] - (rock[0] - rock[2])) / (sand[0] - sand[2] - (rock[0] - rock[2]));
    EXPECT_GT(t, 0.55);
    EXPECT_LT(t, 0.95);
    EXPECT_EQ(sh.materialPixels.at("sand"), sh.surfacePixels);
    EXPECT_EQ(sh.materialPixels.count("bedrock"), 0u);
    // No weight grids: refused.
    EXPECT_THROW(renderPreview(*g, s), ValueError);
}
