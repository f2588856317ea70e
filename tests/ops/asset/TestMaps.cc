// SPDX-License-Identifier: Apache-2.0
// Maps baked from the level set (asset/Maps.h): normal maps decoded through the LOD's own
// tangent frames give the high-resolution surface's normals, which the LOD's interpolated
// normals miss; normal and occlusion maps have the same bits at any thread count.
#include <rockvdb/asset/Maps.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace rockvdb;
using namespace rockvdb::asset;
using openvdb::FloatGrid;

namespace {

// A unit sphere rippled by a*sin(kx)sin(ky)sin(kz): detail a 400-triangle LOD cannot hold.
constexpr double kA = 0.02, kK = 18.0;
double f(const openvdb::Vec3d& p)
{
    return p.length() - 1.0 - kA * std::sin(kK * p.x()) * std::sin(kK * p.y()) * std::sin(kK * p.z());
}
openvdb::Vec3d gradF(const openvdb::Vec3d& p)
{
    const double sx = std::sin(kK * p.x()), sy = std::sin(kK * p.y()), sz = std::sin(kK * p.z());
    const double cx = std::cos(kK * p.x()), cy = std::cos(kK * p.y()), cz = std::cos(kK * p.z());
    return p / p.length() - kA * kK * openvdb::Vec3d(cx * sy * sz, sx * cy * sz, sx * sy * cz);
}

FloatGrid::Ptr rippled(double dx)
{
    auto g = FloatGrid::create(float(3 * dx));
    g->setTransform(openvdb::math::Transform::createLinearTransform(dx));
    const int n = int(1.2 / dx);
    auto acc = g->getAccessor();
    for (auto it = openvdb::CoordBBox(openvdb::Coord(-n), openvdb::Coord(n)).begin(); it; ++it) {
        const double d = f(g->transform().indexToWorld(*it));
        if (std::abs(d) < 3 * dx) acc.setValue(*it, float(d));
    }
    g->setGridClass(openvdb::GRID_LEVEL_SET);
    openvdb::tools::signedFloodFill(g->tree());
    openvdb::tools::LevelSetFilter<FloatGrid>(*g).normalize();
    return g;
}

// The true normal at the surface point nearest p (Newton steps on the analytic field).
openvdb::Vec3d trueNormal(openvdb::Vec3d p)
{
    for (int i = 0; i < 4; ++i) {
        const openvdb::Vec3d g = gradF(p);
        p -= f(p) * g / g.lengthSqr();
    }
    return gradF(p).unit();
}

double degrees(const openvdb::Vec3d& a, const openvdb::Vec3d& b)
{
    return std::acos(std::clamp(a.unit().dot(b.unit()), -1.0, 1.0)) * 180.0 / M_PI;
}

struct Errors
{
    double mapMean = 0, lodMean = 0;
    size_t texels = 0;
};

// Every texel centre strictly inside a triangle of the atlas (size² texels): fn(triangle,
// texel index, barycentric coordinates, the point on the triangle).
template<typename Fn>
void forEachTexel(const UvMesh& m, int size, Fn fn)
{
    for (size_t t = 0; t < m.triangles(); ++t) {
        openvdb::Vec2d uv[3];
        openvdb::Vec3d P[3];
        for (int k = 0; k < 3; ++k) {
            uv[k] = openvdb::Vec2d(m.uvs[m.indices[3 * t + k]]) * double(size);
            P[k] = m.points[m.indices[3 * t + k]];
        }
        const double area = (uv[1] - uv[0]).x() * (uv[2] - uv[0]).y() - (uv[2] - uv[0]).x() * (uv[1] - uv[0]).y();
        for (int y = 0; y < size; ++y) {
            if (y + 0.5 < std::min({uv[0].y(), uv[1].y(), uv[2].y()}) || y + 0.5 > std::max({uv[0].y(), uv[1].y(), uv[2].y()})) continue;
            for (int x = 0; x < size; ++x) {
                const openvdb::Vec2d c(x + 0.5, y + 0.5);
                openvdb::Vec3d b;
                bool inside = true;
                for (int k = 0; k < 3; ++k) {
                    const openvdb::Vec2d a = uv[(k + 2) % 3] - uv[(k + 1) % 3], d = c - uv[(k + 1) % 3];
                    b[k] = (a.x() * d.y() - a.y() * d.x()) / area;
                    inside = inside && b[k] > 1e-6;
                }
                if (inside) fn(t, size_t(y) * size + x, b, b[0] * P[0] + b[1] * P[1] + b[2] * P[2]);
            }
        }
    }
}

// The decoded map normal and the LOD's own interpolated normal against the true one, at
// every texel centre inside a triangle.
Errors compare(const UvMesh& m, const VertexFrames& fr, const BakedMaps& map)
{
    Errors e;
    forEachTexel(m, map.size, [&](size_t t, size_t i, const openvdb::Vec3d& b, const openvdb::Vec3d& p) {
        openvdb::Vec3d n(0);
        openvdb::Vec4d tan(0);
        for (int k = 0; k < 3; ++k) {
            const uint32_t v = m.indices[3 * t + k];
            n += b[k] * openvdb::Vec3d(fr.normals[v]);
            tan += b[k] * openvdb::Vec4d(fr.tangents[v]);
        }
        const openvdb::Vec3d truth = trueNormal(p);
        EXPECT_TRUE(map.covered[i]);
        e.mapMean += degrees(decodeNormal(map.normal[i], n, tan), truth);
        e.lodMean += degrees(n, truth);
        ++e.texels;
    });
    e.mapMean /= double(e.texels);
    e.lodMean /= double(e.texels);
    return e;
}

} // namespace

TEST(Maps, ALowPolyLodCarriesTheLevelSetsDetail)
{
    auto g = rippled(0.01);
    const TriMesh full = surfaceMesh(*g);
    Task task;
    const auto lods = makeLods(full, {400}, task);
    const int size = 256;
    const UvMesh m = atlas(lods[0].mesh, size, 2);
    const VertexFrames fr = vertexFrames(m);
    const BakedMaps map = bakeMaps(m, fr, *g, size, nullptr, task);
    const Errors e = compare(m, fr, map);
    ASSERT_GT(e.texels, 10000u);
    // the ripples tilt the normal by up to atan(a k) = 20 degrees: the LOD alone misses them
    EXPECT_GT(e.lodMean, 7.0);
    EXPECT_LT(e.mapMean, 1.0) << "LOD alone: " << e.lodMean << " degrees";
    // normalMapError (the stage's statistic) agrees: bilinear reads between texel centres,
    // against the level set's own normals rather than the analytic ones
    const NormalMapError s = normalMapError(m, fr, map, *g);
    EXPECT_EQ(s.samples, 4 * m.triangles());
    EXPECT_NEAR(s.meshDegrees, e.lodMean, 1.5);
    EXPECT_LT(s.mapDegrees, 2.0);
    // a map baked for another LOD is far off: the statistic can fail
    const UvMesh other = atlas(makeLods(full, {1500}, task)[0].mesh, size, 2);
    const VertexFrames ofr = vertexFrames(other);
    EXPECT_GT(normalMapError(m, fr, bakeMaps(other, ofr, *g, size, nullptr, task), *g).mapDegrees, 5.0 * std::max(s.mapDegrees, 1.0));
    // dilation leaves no texel at the flat default
    size_t flat = 0;
    for (const auto& c : map.normal) flat += c == openvdb::Vec3f(0.5f, 0.5f, 1.0f);
    EXPECT_LT(flat, map.normal.size() / 100);
}

TEST(Maps, SameBitsAtOneAndTwoThreads)
{
    auto g = rippled(0.02);
    const TriMesh full = surfaceMesh(*g);
    Task task;
    const TriMesh lod = makeLods(full, {800}, task)[0].mesh;
    const UvMesh m = atlas(lod, 128, 2);
    const VertexFrames fr = vertexFrames(m);
    BakedMaps one;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        const Occlusion occ = occlusion(lod, 0.02, 0.3, task);
        one = bakeMaps(m, fr, *g, 128, &occ, task);
    }
    const Occlusion occ = occlusion(lod, 0.02, 0.3, task);
    const BakedMaps two = bakeMaps(m, fr, *g, 128, &occ, task);
    EXPECT_EQ(one.normal, two.normal);
    EXPECT_EQ(one.covered, two.covered);
    ASSERT_EQ(one.occlusion.size(), size_t(128 * 128));
    EXPECT_EQ(one.occlusion, two.occlusion);
    EXPECT_TRUE(bakeMaps(m, fr, *g, 128, nullptr, task).occlusion.empty());
    FloatGrid fog(0.0f);
    EXPECT_THROW(bakeMaps(m, fr, fog, 128, nullptr, task), ValueError);
}

TEST(Maps, AnIdMaskTakesTheIdWhereEachTexelLies)
{
    const double dx = 0.02;
    auto g = rippled(dx);
    // material ids on the band: 3 above z = 0, 7 below (background -1, as rockvdb's id grids)
    auto ids = FloatGrid::create(-1.0f);
    ids->setTransform(g->transform().copy());
    ids->setName("material");
    auto acc = ids->getAccessor();
    for (auto it = g->cbeginValueOn(); it; ++it) {
        if (!it.isVoxelValue()) continue;
        acc.setValue(it.getCoord(), it.getCoord().z() > 0 ? 3.0f : 7.0f);
    }
    Task task;
    const TriMesh lod = makeLods(surfaceMesh(*g), {600}, task)[0].mesh;
    const int size = 128;
    const UvMesh m = atlas(lod, size, 2);
    const VertexFrames fr = vertexFrames(m);
    const BakedMaps map = bakeMaps(m, fr, SurfaceField(*g, ids.get()), size, nullptr, task);
    ASSERT_EQ(map.mask.size(), size_t(size * size));
    size_t checked = 0;
    forEachTexel(m, size, [&](size_t, size_t i, const openvdb::Vec3d&, const openvdb::Vec3d& p) {
        if (std::abs(p.z()) < 3 * dx) return;
        EXPECT_EQ(map.mask[i], p.z() > 0 ? 3 : 7) << p.z();
        ++checked;
    });
    EXPECT_GT(checked, 3000u);
    // dilation: every texel holds an id
    EXPECT_EQ(std::count(map.mask.begin(), map.mask.end(), -1), 0);
    // without a mask grid, no mask; a mask on other voxels is refused
    EXPECT_TRUE(bakeMaps(m, fr, *g, size, nullptr, task).mask.empty());
    auto shifted = ids->deepCopy();
    shifted->setTransform(openvdb::math::Transform::createLinearTransform(2 * dx));
    EXPECT_THROW(SurfaceField(*g, shifted.get()), ValueError);
}
