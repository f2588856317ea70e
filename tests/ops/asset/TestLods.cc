// SPDX-License-Identifier: Apache-2.0
// Asset meshes (asset/Lods.h): the level set's surface as a closed, outward, welded triangle
// mesh; LODs under their triangle budgets that keep the topology and stay near the surface.
#include <rockvdb/asset/Lods.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetSphere.h>
#include <openvdb/tools/Composite.h>

#include <cmath>
#include <map>
#include <utility>

using namespace rockvdb;
using namespace rockvdb::asset;
using openvdb::FloatGrid;

namespace {

// Every undirected edge's triangle count, and whether each directed edge appears once (two
// triangles sharing an edge walk it in opposite directions when both face outward).
struct Topology
{
    bool closedManifold = true, consistent = true;
    long euler = 0;
};

Topology topology(const TriMesh& m)
{
    std::map<std::pair<uint32_t, uint32_t>, int> directed;
    for (size_t t = 0; t < m.triangles(); ++t) {
        for (int k = 0; k < 3; ++k) {
            ++directed[{m.indices[3 * t + k], m.indices[3 * t + (k + 1) % 3]}];
        }
    }
    Topology r;
    size_t edges = 0;
    for (const auto& [e, n] : directed) {
        if (n != 1) r.consistent = false;
        const auto back = directed.find({e.second, e.first});
        if (back == directed.end() || back->second != 1) r.closedManifold = false;
        if (e.first < e.second) ++edges;
    }
    r.euler = long(m.points.size()) - long(edges) + long(m.triangles());
    return r;
}

double signedVolume(const TriMesh& m)
{
    double v = 0;
    for (size_t t = 0; t < m.triangles(); ++t) {
        const openvdb::Vec3d a = m.points[m.indices[3 * t]], b = m.points[m.indices[3 * t + 1]],
                             c = m.points[m.indices[3 * t + 2]];
        v += a.dot(b.cross(c)) / 6.0;
    }
    return v;
}

FloatGrid::Ptr lodSphere(float r, float dx)
{
    return openvdb::tools::createLevelSetSphere<FloatGrid>(r, openvdb::Vec3f(0.1f, -0.2f, 0.05f), dx, 3.0f);
}

} // namespace

TEST(Lods, SurfaceMeshIsClosedOutwardAndOnTheSurface)
{
    const float dx = 0.02f;
    auto g = lodSphere(1.0f, dx);
    const TriMesh m = surfaceMesh(*g);
    const Topology top = topology(m);
    EXPECT_TRUE(top.closedManifold);
    EXPECT_TRUE(top.consistent);
    EXPECT_EQ(top.euler, 2); // a sphere's topology
    const double v = signedVolume(m), exact = 4.0 / 3.0 * M_PI;
    EXPECT_NEAR(v, exact, 0.01 * exact) << "positive: faces wind outward";
    for (const auto& p : m.points) {
        EXPECT_NEAR((openvdb::Vec3d(p) - openvdb::Vec3d(0.1, -0.2, 0.05)).length(), 1.0, 0.5 * dx);
    }
    const SurfaceError e = surfaceError(m, m, *g);
    EXPECT_LT(e.mean, 0.05 * dx);
    EXPECT_LT(e.max, 0.2 * dx);
    EXPECT_EQ(e.back, 0.0); // every vertex is on the mesh itself
}

TEST(Lods, LevelsMeetTheirBudgetsKeepTheTopologyAndStayNearTheSurface)
{
    const float dx = 0.02f;
    auto g = lodSphere(1.0f, dx);
    const TriMesh full = surfaceMesh(*g);
    ASSERT_GT(full.triangles(), 50000u);
    Task task;
    const std::vector<size_t> targets{5000, 1500, 400};
    const auto lods = makeLods(full, targets, task);
    ASSERT_EQ(lods.size(), 3u);
    double previous = 0;
    for (size_t i = 0; i < lods.size(); ++i) {
        const TriMesh& m = lods[i].mesh;
        EXPECT_LE(m.triangles(), targets[i]) << i;
        EXPECT_GE(m.triangles(), targets[i] * 8 / 10) << i;
        const Topology top = topology(m);
        EXPECT_TRUE(top.closedManifold && top.consistent) << i;
        EXPECT_EQ(top.euler, 2) << i;
        // compacted: every point is used
        std::vector<bool> used(m.points.size());
        for (uint32_t k : m.indices) used[k] = true;
        EXPECT_EQ(std::count(used.begin(), used.end(), false), 0) << i;
        // The ideal polyhedron with this many equal triangles on the unit sphere: each face's
        // circumradius c and the sag 1 - sqrt(1 - c^2) at its centre. A good simplifier stays
        // within a few of those sags (uneven triangles sag more where they are larger).
        const double F = double(m.triangles()), side = std::sqrt(4.0 * (4.0 * M_PI / F) / std::sqrt(3.0));
        const double c = side / std::sqrt(3.0), sag = 1.0 - std::sqrt(1.0 - c * c);
        const double exact = 4.0 / 3.0 * M_PI;
        EXPECT_NEAR(signedVolume(m), exact, 4.0 * sag * exact) << i;
        const SurfaceError e = surfaceError(m, full, *g);
        // a polyhedron inscribed in the sphere: its faces sag inward, the surface's points
        // between its vertices are as far from it as its centroids from the surface
        EXPECT_NEAR(e.back, e.max, 0.5 * e.max + 0.25 * dx) << i;
        EXPECT_EQ(e.hausdorff, std::max(e.max, e.back));
        EXPECT_GE(e.max, previous) << "coarser levels lie further from the surface";
        previous = e.max;
        EXPECT_LT(e.max, 3.0 * sag + 0.25 * dx) << i;
        EXPECT_GT(e.max, 0.5 * sag) << i << ": closer than a polyhedron can be?";
    }
}

TEST(Lods, TheErrorIsMeasuredBothWaysAndBeyondTheBand)
{
    const float dx = 0.04f;
    auto g = lodSphere(1.0f, dx);
    const TriMesh full = surfaceMesh(*g);
    const openvdb::Vec3d c(0.1, -0.2, 0.05);
    // The surface scaled by 1.2 about its centre: 0.2 m out, far beyond the band (3 dx = 0.12 m)
    // where phi reads the background: the exact distance to the full mesh is measured there.
    TriMesh big = full;
    for (auto& p : big.points) p = openvdb::Vec3f(c + (openvdb::Vec3d(p) - c) * 1.2);
    const SurfaceError out = surfaceError(big, full, *g);
    EXPECT_NEAR(out.max, 0.2, 0.01);
    EXPECT_NEAR(out.mean, 0.2, 0.01);
    EXPECT_NEAR(out.back, 0.2, 0.01);
    // Half the triangles dropped (those with a centroid above the centre's plane z = 0.05):
    // what is left still lies on the surface, but the top of the surface is far from it, up
    // to the sphere's pole, about the radius away from the cut's rim.
    TriMesh half;
    half.points = full.points;
    for (size_t t = 0; t < full.triangles(); ++t) {
        double z = 0;
        for (int k = 0; k < 3; ++k) z += full.points[full.indices[3 * t + k]].z() / 3.0;
        if (z > 0.05) continue;
        half.indices.insert(half.indices.end(), full.indices.begin() + 3 * t, full.indices.begin() + 3 * t + 3);
    }
    const SurfaceError cut = surfaceError(half, full, *g);
    EXPECT_LT(cut.max, 0.2 * dx);
    EXPECT_NEAR(cut.back, std::sqrt(2.0), 0.05); // the pole to the rim's nearest point
    EXPECT_EQ(cut.hausdorff, cut.back);
    // The index agrees with brute force.
    const TriangleDistance dist(half);
    for (const openvdb::Vec3d p : {openvdb::Vec3d(0, 0, 3), openvdb::Vec3d(0.3, 0.2, 0.4), openvdb::Vec3d(-5, 1, -2)}) {
        double brute = 1e300;
        for (size_t t = 0; t < half.triangles(); ++t) {
            TriMesh one;
            one.points = {half.points[half.indices[3 * t]], half.points[half.indices[3 * t + 1]],
                          half.points[half.indices[3 * t + 2]]};
            one.indices = {0, 1, 2};
            brute = std::min(brute, TriangleDistance(one)(p));
        }
        EXPECT_NEAR(dist(p), brute, 1e-9);
    }
}

TEST(Lods, TheSameInputGivesTheSameLevels)
{
    auto g = lodSphere(0.5f, 0.02f);
    const TriMesh full = surfaceMesh(*g);
    Task task;
    const auto a = makeLods(full, {2000, 300}, task), b = makeLods(full, {2000, 300}, task);
    for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].mesh.indices, b[i].mesh.indices);
        EXPECT_EQ(a[i].mesh.points, b[i].mesh.points);
    }
}

TEST(Lods, BadBudgetsAndGridsAreRefused)
{
    auto g = lodSphere(0.5f, 0.05f);
    const TriMesh full = surfaceMesh(*g);
    Task task;
    EXPECT_THROW(makeLods(full, {0}, task), ValueError);
    EXPECT_THROW(makeLods(full, {full.triangles() + 1}, task), ValueError);
    EXPECT_THROW(makeLods(full, {100, 200}, task), ValueError);
    try {
        makeLods(full, {full.triangles() + 1}, task);
    } catch (const ValueError& e) {
        EXPECT_NE(std::string(e.what()).find("more than the"), std::string::npos) << e.what();
    }
    FloatGrid fog(0.0f);
    EXPECT_THROW(surfaceMesh(fog), ValueError); // not a level set
    auto empty = FloatGrid::create(0.15f);
    empty->setGridClass(openvdb::GRID_LEVEL_SET);
    EXPECT_THROW(surfaceMesh(*empty), ValueError); // no surface
}
