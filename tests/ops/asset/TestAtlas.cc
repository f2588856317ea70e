// SPDX-License-Identifier: Apache-2.0
// UV atlas (asset/Atlas.h): every uv in the texture, no texel covered twice (charts apart by
// their padding, no chart folded onto itself), no flipped triangle, an even texel density.
#include <rockvdb/asset/Atlas.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/LevelSetFilter.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace rockvdb;
using namespace rockvdb::asset;
using openvdb::FloatGrid;

namespace {

double cross(const openvdb::Vec2d& a, const openvdb::Vec2d& b) { return a.x() * b.y() - a.y() * b.x(); }

// A lumpy rock: a sphere pushed in and out by a few smooth bumps (folds and concavities).
FloatGrid::Ptr lumpyRock(float dx)
{
    auto g = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0), dx, 3.0f);
    std::vector<openvdb::Vec3f> c{{1, 0.2f, 0.1f}, {-0.3f, 0.9f, 0.3f}, {0.1f, -0.4f, 0.9f},
                                  {-0.7f, -0.6f, -0.2f}, {0.2f, 0.1f, -1.0f}};
    std::vector<float> amp{0.35f, -0.25f, 0.3f, -0.2f, 0.25f};
    auto rebuilt = FloatGrid::create(3.0f * dx);
    rebuilt->setTransform(g->transform().copy());
    openvdb::CoordBBox box(openvdb::Coord(int(-1.6f / dx)), openvdb::Coord(int(1.6f / dx)));
    auto acc = rebuilt->getAccessor();
    for (auto it = box.begin(); it; ++it) {
        const openvdb::Vec3f p = g->transform().indexToWorld(*it);
        float d = p.length() - 1.0f;
        for (size_t i = 0; i < c.size(); ++i) d -= amp[i] * std::exp(-(p - c[i]).lengthSqr() / 0.15f);
        if (std::abs(d) < 3.0f * dx) acc.setValue(*it, d);
    }
    rebuilt->setGridClass(openvdb::GRID_LEVEL_SET);
    openvdb::tools::signedFloodFill(rebuilt->tree());
    openvdb::tools::LevelSetFilter<FloatGrid> f(*rebuilt);
    f.normalize(); // the bumps are not exact distances
    return rebuilt;
}

// Rasterise every triangle's interior texel centres; return false on any texel covered twice.
bool noTexelTwice(const UvMesh& m, int size, std::string& why)
{
    std::vector<int> owner(size_t(size) * size, -1);
    for (size_t t = 0; t < m.triangles(); ++t) {
        openvdb::Vec2d p[3];
        for (int k = 0; k < 3; ++k) p[k] = openvdb::Vec2d(m.uvs[m.indices[3 * t + k]]) * size;
        const double area = cross(p[1] - p[0], p[2] - p[0]);
        if (area <= 0) {
            why = "triangle " + std::to_string(t) + " is flipped or empty in uv";
            return false;
        }
        const int x0 = std::max(0, int(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()}))));
        const int x1 = std::min(size - 1, int(std::ceil(std::max({p[0].x(), p[1].x(), p[2].x()}))));
        const int y0 = std::max(0, int(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()}))));
        const int y1 = std::min(size - 1, int(std::ceil(std::max({p[0].y(), p[1].y(), p[2].y()}))));
        for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) {
                const openvdb::Vec2d c(x + 0.5, y + 0.5);
                const double e = 1e-9;
                if (cross(p[1] - p[0], c - p[0]) > e && cross(p[2] - p[1], c - p[1]) > e &&
                    cross(p[0] - p[2], c - p[2]) > e) {
                    int& o = owner[size_t(y) * size + x];
                    if (o != -1) {
                        why = "texel " + std::to_string(x) + "," + std::to_string(y) + " in triangles " +
                              std::to_string(o) + " and " + std::to_string(t) + " (charts " +
                              std::to_string(m.chartOf[o]) + ", " + std::to_string(m.chartOf[t]) + ")";
                        for (size_t tt : {size_t(o), t})
                            for (int k = 0; k < 3; ++k) {
                                const auto q = m.points[m.indices[3 * tt + k]];
                                const auto u = m.uvs[m.indices[3 * tt + k]] * float(size);
                                why += " [" + std::to_string(q[0]) + " " + std::to_string(q[1]) + " " +
                                       std::to_string(q[2]) + " | " + std::to_string(u[0]) + " " +
                                       std::to_string(u[1]) + "]";
                            }
                        return false;
                    }
                    o = int(t);
                }
            }
        }
    }
    return true;
}

void checkAtlas(const TriMesh& mesh, int size, int pad)
{
    const UvMesh m = atlas(mesh, size, pad);
    ASSERT_EQ(m.triangles(), mesh.triangles());
    for (const auto& uv : m.uvs) {
        ASSERT_GE(uv.x(), 0.0f);
        ASSERT_LE(uv.x(), 1.0f);
        ASSERT_GE(uv.y(), 0.0f);
        ASSERT_LE(uv.y(), 1.0f);
    }
    std::string why;
    EXPECT_TRUE(noTexelTwice(m, size, why)) << why;
    // Charts' texel boxes, grown by half the padding, do not meet: bilinear and mip-level-1
    // reads of one chart never reach another.
    std::vector<openvdb::Vec4d> box(m.charts, openvdb::Vec4d(1e9, 1e9, -1e9, -1e9));
    for (size_t t = 0; t < m.triangles(); ++t) {
        auto& b = box[m.chartOf[t]];
        for (int k = 0; k < 3; ++k) {
            const openvdb::Vec2d p = openvdb::Vec2d(m.uvs[m.indices[3 * t + k]]) * size;
            b = openvdb::Vec4d(std::min(b[0], p.x()), std::min(b[1], p.y()), std::max(b[2], p.x()),
                               std::max(b[3], p.y()));
        }
    }
    for (size_t a = 0; a < m.charts; ++a) {
        for (size_t b = a + 1; b < m.charts; ++b) {
            const bool apart = box[a][2] + pad <= box[b][0] || box[b][2] + pad <= box[a][0] ||
                               box[a][3] + pad <= box[b][1] || box[b][3] + pad <= box[a][1];
            ASSERT_TRUE(apart) << "charts " << a << " and " << b;
        }
    }
    // Even density: uv area / 3D area = density² · cos(angle to the chart's axis), cos in
    // [1/sqrt(3), 1]; and the texture is reasonably used.
    double used = 0;
    for (size_t t = 0; t < m.triangles(); ++t) {
        const openvdb::Vec3d a = m.points[m.indices[3 * t]], b = m.points[m.indices[3 * t + 1]],
                             c = m.points[m.indices[3 * t + 2]];
        const openvdb::Vec2d u = openvdb::Vec2d(m.uvs[m.indices[3 * t]]) * size,
                             v = openvdb::Vec2d(m.uvs[m.indices[3 * t + 1]]) * size,
                             w = openvdb::Vec2d(m.uvs[m.indices[3 * t + 2]]) * size;
        const double a3 = 0.5 * (b - a).cross(c - a).length(), a2 = 0.5 * cross(v - u, w - u);
        used += a2;
        if (a3 < 1e-12) continue;
        const double ratio = a2 / (a3 * m.texelsPerMetre * m.texelsPerMetre);
        EXPECT_GT(ratio, 1.0 / std::sqrt(3.0) - 1e-3) << t;
        EXPECT_LT(ratio, 1.0 + 1e-3) << t;
    }
    EXPECT_GT(used / (double(size) * size), 0.25) << m.charts << " charts";
    // Seams only: each input vertex appears once per chart that holds it, at the same place.
    for (size_t i = 0; i < m.points.size(); ++i) EXPECT_EQ(m.points[i], mesh.points[m.source[i]]);
}

} // namespace

TEST(Atlas, SphereLodsPackWithoutOverlapFlipOrUnevenDensity)
{
    auto g = openvdb::tools::createLevelSetSphere<FloatGrid>(1.0f, openvdb::Vec3f(0), 0.02f, 3.0f);
    const TriMesh full = surfaceMesh(*g);
    Task task;
    for (const Lod& lod : makeLods(full, {5000, 400}, task)) checkAtlas(lod.mesh, 1024, 4);
}

TEST(Atlas, ALumpyRockFullAndSimplifiedPacksToo)
{
    auto g = lumpyRock(0.03f);
    const TriMesh full = surfaceMesh(*g);
    checkAtlas(full, 2048, 2);
    Task task;
    for (const Lod& lod : makeLods(full, {3000, 300}, task)) checkAtlas(lod.mesh, 512, 3);
}

TEST(Atlas, SameMeshSameAtlasAndBadSizesAreRefused)
{
    auto g = openvdb::tools::createLevelSetSphere<FloatGrid>(0.5f, openvdb::Vec3f(0), 0.05f, 3.0f);
    const TriMesh m = surfaceMesh(*g);
    const UvMesh a = atlas(m, 256, 2), b = atlas(m, 256, 2);
    EXPECT_EQ(a.uvs, b.uvs);
    EXPECT_EQ(a.indices, b.indices);
    EXPECT_THROW(atlas(m, 0, 2), ValueError);
    EXPECT_THROW(atlas(m, 1000000, 2), ValueError);
    EXPECT_THROW(atlas(m, 256, -1), ValueError);
    EXPECT_THROW(atlas(TriMesh{}, 256, 2), ValueError);
}
