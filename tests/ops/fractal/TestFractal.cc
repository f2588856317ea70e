// SPDX-License-Identifier: Apache-2.0
// Fractal rocks (fractal/FractalRock.h, FractalStage.h; fractal-rocks-midpoint-displacement.txt):
// closed crack-free meshes with the paper's triangle counts, determinism across threads, rough
// tops and smooth bottoms, the level set's volume, the normal map of the finer model, and
// bad parameters refused.
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>
#include "GridCompare.h"

#include <rockvdb/fractal/FractalStage.h>

#include <gtest/gtest.h>
#include <openvdb/tools/LevelSetMeasure.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <tuple>

using namespace rockvdb;
using namespace rockvdb::fractal;

namespace {

const std::array<Vec3d, 3> kIdentity = {Vec3d(1, 0, 0), Vec3d(0, 1, 0), Vec3d(0, 0, 1)};

RockMesh shapeRock(int levels, Method method, uint64_t seed = 3, double hUp = 0.3, double hDown = 0.8,
               Vec3d extent = Vec3d(1), const std::array<Vec3d, 3>& R = kIdentity)
{
    RockShape s;
    s.levels = levels;
    s.method = method;
    s.seed = seed;
    s.hUp = hUp;
    s.hDown = hDown;
    s.roughness = 0.3;
    Task task;
    return buildRock(s, extent, R, task);
}

// Every directed edge once and its twin once (closed, consistently oriented, manifold
// edges); no two vertices at one position (a crack would leave duplicates); all used.
void expectClosedAndWelded(const RockMesh& m, const std::string& what)
{
    std::vector<std::pair<unsigned, unsigned>> directed;
    directed.reserve(m.triangles.size() * 3);
    std::vector<char> used(m.points.size(), 0);
    for (const auto& t : m.triangles)
        for (int e = 0; e < 3; ++e) {
            directed.emplace_back(t[e], t[(e + 1) % 3]);
            used[t[e]] = 1;
        }
    std::sort(directed.begin(), directed.end());
    const bool unique = std::adjacent_find(directed.begin(), directed.end()) == directed.end();
    EXPECT_TRUE(unique) << what << ": an edge used twice in one direction";
    size_t open = 0;
    for (const auto& e : directed) {
        if (!std::binary_search(directed.begin(), directed.end(), std::make_pair(e.second, e.first))) ++open;
    }
    EXPECT_EQ(open, 0u) << what;
    EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0) << what;
    std::vector<std::tuple<double, double, double>> pos;
    for (const auto& p : m.points) pos.emplace_back(p[0], p[1], p[2]);
    std::sort(pos.begin(), pos.end());
    EXPECT_TRUE(std::adjacent_find(pos.begin(), pos.end()) == pos.end()) << what << ": duplicate vertices";
    // Euler: a closed genus-0 surface has V − E + F = 2.
    EXPECT_EQ(int64_t(m.points.size()) - int64_t(directed.size() / 2) + int64_t(m.triangles.size()), 2) << what;
}

double angleDeg(const Vec3d& a, const Vec3d& b)
{
    return std::acos(std::min(1.0, std::max(-1.0, a.dot(b) / (a.length() * b.length())))) * 180.0 / M_PI;
}

} // namespace

TEST(FractalRock, ClosedCrackFreeWithThePapersTriangleCounts)
{
    for (Method method : {Method::Interpolating, Method::Approximating, Method::Midpoint}) {
        for (int L = 0; L <= 4; ++L) {
            const RockMesh m = shapeRock(L, method);
            const double expected = method == Method::Midpoint ? 20 * std::pow(4, L) : 20 * std::pow(16, L);
            ASSERT_EQ(double(m.triangles.size()), expected) << methodName(method) << " " << L;
            EXPECT_EQ(double(m.triangles.size()), triangleCount(L, method));
            expectClosedAndWelded(m, std::string(methodName(method)) + " level " + std::to_string(L));
        }
    }
    // The paper's sequence: 20 → 320 → 5 120 → 81 920.
    EXPECT_EQ(shapeRock(3, Method::Interpolating).triangles.size(), 81920u);
}

TEST(FractalRock, DisplacementIsAFunctionOfTheEdgeNotTheOrder)
{
    // A level refines the previous one: every vertex of level L is a vertex of level L + 1,
    // at the same position bit for bit (the displacement of an edge never depends on which
    // face computed it or when).
    for (Method method : {Method::Interpolating, Method::Midpoint}) {
        const RockMesh a = shapeRock(2, method), b = shapeRock(3, method);
        ASSERT_LT(a.points.size(), b.points.size());
        for (size_t i = 0; i < a.points.size(); ++i) {
            ASSERT_EQ(std::memcmp(&a.points[i], &b.points[i], sizeof(Vec3d)), 0) << i;
        }
    }
}

TEST(FractalRock, DeterministicAcrossThreadsAndSeedsDiffer)
{
    RockMesh one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = shapeRock(3, Method::Approximating, 11);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = shapeRock(3, Method::Approximating, 11);
    }
    ASSERT_EQ(one.points.size(), two.points.size());
    EXPECT_EQ(std::memcmp(one.points.data(), two.points.data(), one.points.size() * sizeof(Vec3d)), 0);
    EXPECT_EQ(std::memcmp(one.triangles.data(), two.triangles.data(), one.triangles.size() * sizeof(openvdb::Vec3I)), 0);
    const RockMesh other = shapeRock(3, Method::Approximating, 12);
    double moved = 0;
    for (size_t i = 0; i < one.points.size(); ++i) moved += (one.points[i] - other.points[i]).length();
    EXPECT_GT(moved / double(one.points.size()), 0.01);
}

TEST(FractalRock, RoughTopsAndSmoothBottomsFollowH)
{
    // Roughness: how far face normals stray from the sphere's normal at the face, per
    // hemisphere (a sphere base, no rotation: up is +z).
    auto roughness = [](const RockMesh& m, bool up) {
        double sum = 0;
        size_t n = 0;
        for (const auto& t : m.triangles) {
            const Vec3d a = m.points[t[0]], b = m.points[t[1]], c = m.points[t[2]];
            const Vec3d centre = (a + b + c) / 3.0;
            const Vec3d dir = centre.unit();
            if (up ? dir[2] < 0.6 : dir[2] > -0.6) continue;
            sum += angleDeg((b - a).cross(c - a), dir);
            ++n;
        }
        return sum / double(n);
    };
    for (Method method : {Method::Interpolating, Method::Midpoint}) {
        const int L = method == Method::Midpoint ? 5 : 3;
        const RockMesh m = shapeRock(L, method, 5, 0.2, 0.9);
        EXPECT_GT(roughness(m, true), 1.3 * roughness(m, false)) << methodName(method);
        const RockMesh swapped = shapeRock(L, method, 5, 0.9, 0.2);
        EXPECT_GT(roughness(swapped, false), 1.3 * roughness(swapped, true)) << methodName(method);
    }
}

TEST(FractalRock, LevelSetEnclosesTheMeshVolume)
{
    initialize();
    FractalRockParams p;
    p.shape.levels = 2;
    p.voxelSize = 0.01;
    p.shape.seed = 7;
    Task task;
    const RockResult r = runRock(p, true, false, task);
    ASSERT_TRUE(r.surface);
    EXPECT_EQ(r.surface->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_EQ(r.surface->getName(), "surface");
    openvdb::tools::LevelSetMeasure<openvdb::FloatGrid> measure(*r.surface);
    const double vGrid = measure.volume(true), vMesh = signedVolume(r.mesh);
    EXPECT_GT(vMesh, 0.05);
    EXPECT_NEAR(vGrid, vMesh, 0.02 * vMesh);
    // The rock has the asked size: its bounds about the ellipsoid's (1 × 0.8 × 0.5 m, tilted).
    openvdb::BBoxd box;
    for (const auto& q : r.mesh.points) box.expand(openvdb::Vec3d(q));
    const openvdb::Vec3d ext = box.extents();
    EXPECT_GT(ext[0] * ext[1] * ext[2], 0.5 * 0.4);
    EXPECT_LT(ext[0] * ext[1] * ext[2], 2.5 * 0.4);
    // The entry (runFractal) makes the same grid and stamps the one provenance, which the
    // table reads back as the same parameters; the step leaves stamping to it.
    EXPECT_FALSE(provenance(*r.surface).has_value());
    const FractalResult entry = runFractal(p, FractalInputs{}, task);
    ASSERT_EQ(entry.grids.size(), 1u);
    EXPECT_TRUE(test::bitwiseEqual(*r.surface, *openvdb::gridPtrCast<openvdb::FloatGrid>(entry.grids[0])));
    const auto prov = provenance(*entry.grids[0]);
    ASSERT_TRUE(prov.has_value());
    EXPECT_EQ(rockSchema().toJson(rockSchema().fromJson(nlohmann::json::parse(prov->params))),
              rockSchema().toJson(p));
}

TEST(FractalRock, NormalMapReproducesTheFinerModel)
{
    FractalRockParams p;
    p.shape.levels = 1;
    p.normalLevels = 2;
    p.normalMapSize = 256;
    p.shape.seed = 2;
    Task task;
    const RockResult r = runRock(p, false, true, task);
    ASSERT_EQ(r.normalMapWidth, 5 * 256);
    ASSERT_EQ(r.normalMapHeight, 2 * 256);
    // The finer model, as the stage built it (same seed, same orientation: same hash).
    FractalRockParams fineP = p;
    fineP.shape.levels = 3;
    const RockResult fine = runRock(fineP, false, false, task);
    const std::vector<Vec3d> world = [&] {
        std::vector<Vec3d> w;
        for (const auto& q : fine.mesh.points) w.emplace_back(q);
        return w;
    }();
    const std::vector<Vec3d> normals = vertexNormals(world, fine.rock.triangles);
    // Decode the map on the coarse model's UV layout at each fine vertex (bilinear).
    const UvLayout layout;
    const int W = r.normalMapWidth, H = r.normalMapHeight;
    auto texel = [&](int x, int y) {
        x = std::min(W - 1, std::max(0, x));
        y = std::min(H - 1, std::max(0, y));
        const float* c = &r.normalMap[(size_t(y) * W + x) * 3];
        return Vec3d(2.0 * c[0] - 1.0, 2.0 * c[1] - 1.0, 2.0 * c[2] - 1.0);
    };
    double sum = 0;
    size_t n = 0;
    const uint32_t N = fine.rock.lattice;
    for (size_t t = 0; t < fine.rock.triangles.size(); t += 7) {
        const auto& c = fine.rock.corners[t];
        const openvdb::Vec2d uv = layout.uv(fine.rock.baseFace[t], double(c[0]) / N, double(c[1]) / N);
        const double x = uv[0] * W - 0.5, y = (1.0 - uv[1]) * H - 0.5;
        const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
        const double fx = x - x0, fy = y - y0;
        const Vec3d m = texel(x0, y0) * (1 - fx) * (1 - fy) + texel(x0 + 1, y0) * fx * (1 - fy) +
                        texel(x0, y0 + 1) * (1 - fx) * fy + texel(x0 + 1, y0 + 1) * fx * fy;
        sum += angleDeg(m, normals[fine.rock.triangles[t][0]]);
        ++n;
    }
    EXPECT_LT(sum / double(n), 10.0);
    // And it is not the coarse model's own normals (those stray further).
    const std::vector<Vec3d> coarse = [&] {
        std::vector<Vec3d> w;
        for (const auto& q : r.mesh.points) w.emplace_back(q);
        return vertexNormals(w, r.rock.triangles);
    }();
    double coarseSum = 0;
    size_t cn = 0;
    for (size_t t = 0; t < fine.rock.triangles.size(); t += 7) {
        // The coarse vertex at the same lattice point, when there is one.
        const auto& c = fine.rock.corners[t];
        const uint32_t scale = N / r.rock.lattice;
        if (c[0] % scale || c[1] % scale) continue;
        for (size_t u = 0; u < r.rock.triangles.size(); ++u) {
            if (r.rock.baseFace[u] != fine.rock.baseFace[t]) continue;
            const auto& d = r.rock.corners[u];
            for (int q = 0; q < 3; ++q) {
                if (d[size_t(2 * q)] * scale == c[0] && d[size_t(2 * q + 1)] * scale == c[1]) {
                    coarseSum += angleDeg(coarse[r.rock.triangles[u][q]], normals[fine.rock.triangles[t][0]]);
                    ++cn;
                    q = 3;
                    u = r.rock.triangles.size();
                }
            }
        }
    }
    ASSERT_GT(cn, 10u);
    EXPECT_GT(coarseSum / double(cn), sum / double(n));
}

TEST(FractalRock, RotationsAndQuaternionsAgree)
{
    for (uint64_t s = 0; s < 50; ++s) {
        const auto R = randomOrientation(s, 180.0); // any rotation
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) EXPECT_NEAR(R[size_t(i)].dot(R[size_t(j)]), i == j ? 1.0 : 0.0, 1e-12);
        EXPECT_NEAR(R[0].cross(R[1]).dot(R[2]), 1.0, 1e-12); // proper rotation
        const auto q = quaternionOf(R);
        const double x = q[0], y = q[1], z = q[2], w = q[3];
        EXPECT_NEAR(x * x + y * y + z * z + w * w, 1.0, 1e-12);
        EXPECT_NEAR(R[0][0], 1 - 2 * (y * y + z * z), 1e-9);
        EXPECT_NEAR(R[0][1], 2 * (x * y - w * z), 1e-9);
        EXPECT_NEAR(R[2][1], 2 * (y * z + w * x), 1e-9);
    }
}

TEST(FractalRock, BadParametersAreRefused)
{
    auto error = [](const std::string& text) {
        try {
            rockSchema().fromJson(nlohmann::json::parse(text));
        } catch (const ValueError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_NE(error(R"({"levels": -1})").find("levels"), std::string::npos);
    EXPECT_NE(error(R"({"size": [1, 0, 1]})").find("size"), std::string::npos);
    EXPECT_NE(error(R"({"h-up": 1.0})").find("h-up"), std::string::npos);
    EXPECT_NE(error(R"({"h-down": 0})").find("h-down"), std::string::npos);
    EXPECT_NE(error(R"({"method": "cubic"})").find("method"), std::string::npos);
    EXPECT_NE(error(R"({"levle": 2})").find("levels"), std::string::npos); // did you mean
    // NaN cannot be written in JSON; the table refuses it in C++.
    FractalRockParams p;
    p.size = Vec3d(1, std::nan(""), 1);
    EXPECT_THROW(rockSchema().validate(p), ValueError);
    // Too many triangles for the memory limit: refused with the estimate, before any work.
    FractalRockParams big;
    big.shape.levels = 8;
    Task task;
    try {
        runRock(big, false, false, task);
        FAIL() << "8 levels accepted";
    } catch (const ValueError& e) {
        EXPECT_NE(std::string(e.what()).find("--levels"), std::string::npos) << e.what();
    }
    FractalRockParams fine;
    fine.voxelSize = 1e-5;
    EXPECT_THROW(runRock(fine, true, false, task), ValueError);
}

// ---- the direct bake (fractal/MeshBake.h) ------------------------------------------------------

#include <openvdb/tools/MeshToVolume.h>
#include <rockvdb/fractal/MeshBake.h>

namespace {

struct WorldRock
{
    RockMesh rock;
    std::vector<Vec3d> world;
};

WorldRock worldRock(int levels, uint64_t seed, const Vec3d& centre)
{
    WorldRock w;
    RockShape s;
    s.levels = levels;
    s.seed = seed;
    s.roughness = 0.12; // the table's default: no folds
    s.hUp = 0.65;
    s.hDown = 0.9;
    Task task;
    w.rock = buildRock(s, Vec3d(0.5, 0.4, 0.3), kIdentity, task);
    w.world = toWorld(w.rock, Vec3d(0.5, 0.4, 0.3), kIdentity, centre);
    return w;
}

} // namespace

TEST(MeshBake, IsTheExactSignedDistanceNearTheSurfaceAndBeatsMeshToVolumeBeyond)
{
    initialize();
    const WorldRock r = worldRock(2, 4, Vec3d(0.013, -0.02, 0.007));
    const double dx = 0.02;
    Task task;
    auto ours = bakeMeshes({MeshPart{&r.world, &r.rock.triangles}}, dx, 3.0, true, task);
    auto xf = openvdb::math::Transform::createLinearTransform(dx);
    std::vector<openvdb::Vec3s> idx;
    for (const auto& q : r.world) idx.emplace_back(xf->worldToIndex(q));
    openvdb::tools::QuadAndTriangleDataAdapter<openvdb::Vec3s, openvdb::Vec3I> ad(idx, r.rock.triangles);
    auto ref = openvdb::tools::meshToVolume<openvdb::FloatGrid>(ad, *xf, 3.0f, 3.0f);
    // Against brute force: the distance to the nearest of all triangles, signed by the
    // winding number (Σ solid angles / 4π: 1 inside, 0 outside), on every 5th band voxel.
    auto solidAngle = [](const Vec3d& a, const Vec3d& b, const Vec3d& c) {
        const double la = a.length(), lb = b.length(), lc = c.length();
        const double num = a.dot(b.cross(c));
        const double den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
        return 2.0 * std::atan2(num, den);
    };
    const double exactTo = 1e-5; // m: float storage
    size_t checked = 0, n = 0, inexact = 0, refChecked = 0, refInexact = 0;
    double worst = 0, worstNear = 0, refWorst = 0;
    auto refAcc = ref->getConstAccessor();
    for (auto it = ours->cbeginValueOn(); it; ++it) {
        if (n++ % 5) continue;
        const Vec3d p = xf->indexToWorld(it.getCoord());
        double best = 1e30, winding = 0;
        for (const auto& tri : r.rock.triangles) {
            const Vec3d& A = r.world[tri[0]];
            const Vec3d& B = r.world[tri[1]];
            const Vec3d& C = r.world[tri[2]];
            // Closest point by projection and clamping to the edges (exact, slow).
            const Vec3d nrm = (B - A).cross(C - A).unit();
            const Vec3d q = p - nrm * nrm.dot(p - A);
            auto inside = [&](const Vec3d& x) {
                return (B - A).cross(x - A).dot(nrm) >= 0 && (C - B).cross(x - B).dot(nrm) >= 0 &&
                       (A - C).cross(x - C).dot(nrm) >= 0;
            };
            double d2;
            if (inside(q)) {
                d2 = (p - q).lengthSqr();
            } else {
                auto seg = [&](const Vec3d& s0, const Vec3d& s1) {
                    const Vec3d e = s1 - s0;
                    const double t = std::min(1.0, std::max(0.0, e.dot(p - s0) / e.lengthSqr()));
                    return (p - (s0 + e * t)).lengthSqr();
                };
                d2 = std::min({seg(A, B), seg(B, C), seg(C, A)});
            }
            best = std::min(best, d2);
            winding += solidAngle(A - p, B - p, C - p);
        }
        const double exact = (winding / (4 * M_PI) > 0.5 ? -1 : 1) * std::sqrt(best);
        const double err = std::abs(exact - double(*it));
        worst = std::max(worst, err);
        if (std::abs(exact) < dx) worstNear = std::max(worstNear, err);
        inexact += err > exactTo;
        ++checked;
        float theirs;
        if (refAcc.probeValue(it.getCoord(), theirs)) {
            const double e = std::abs(exact - double(theirs));
            refWorst = std::max(refWorst, e);
            refInexact += e > exactTo;
            ++refChecked;
        }
    }
    EXPECT_GT(checked, 1000u);
    // Within a voxel of the surface (the zero crossing and its neighbours): exact.
    EXPECT_LT(worstNear, exactTo);
    // Beyond, propagated: nearly all exact, none off by half a voxel...
    EXPECT_LT(double(inexact), 0.03 * double(checked)) << inexact << " of " << checked;
    EXPECT_LT(worst, 0.5 * dx);
    // ... and closer to the truth than OpenVDB's meshToVolume on the same voxels.
    EXPECT_GT(refChecked, checked * 9 / 10);
    EXPECT_LT(double(inexact) / double(checked), 0.25 * double(refInexact) / double(refChecked));
    EXPECT_LT(worst, refWorst);
    // About the same band as meshToVolume's.
    EXPECT_NEAR(double(ours->activeVoxelCount()), double(ref->activeVoxelCount()), 0.01 * double(ref->activeVoxelCount()));
    // Inside beyond the band: the flood fill's tiles.
    EXPECT_LT(ours->tree().getValue(openvdb::Coord(0)), 0.0f);
}

TEST(MeshBake, AnySplitIntoUnitsGivesTheSameBits)
{
    initialize();
    // 1 m across at 1 cm: ~110 voxels along x, which the bake splits into units itself.
    const WorldRock r = worldRock(2, 7, Vec3d(0.31, 0.02, -0.1));
    const std::vector<MeshPart> parts{{&r.world, &r.rock.triangles}};
    Task task;
    openvdb::FloatGrid::Ptr ids;
    auto whole = bakeMeshes(parts, 0.01, 3.0, true, task, &ids, 4096);
    EXPECT_GT(whole->activeVoxelCount(), 50000);
    for (int width : {0, 8, 24}) {
        openvdb::FloatGrid::Ptr splitIds;
        auto split = bakeMeshes(parts, 0.01, 3.0, true, task, &splitIds, width);
        EXPECT_TRUE(test::bitwiseEqual(*whole, *split)) << "unit width " << width;
        EXPECT_TRUE(test::bitwiseEqual(*ids, *splitIds)) << "unit width " << width;
    }
    // And the carve path (per-part flood fill, union of full values).
    auto carved = bakeMeshes(parts, 0.01, 3.0, false, task, nullptr, 4096);
    auto carvedSplit = bakeMeshes(parts, 0.01, 3.0, false, task, nullptr, 8);
    EXPECT_TRUE(test::bitwiseEqual(*carved, *carvedSplit));
}

TEST(MeshBake, OverlappingPartsUniteByTheirFullValuesAtAnyThreadCount)
{
    initialize();
    const WorldRock a = worldRock(1, 1, Vec3d(0)), b = worldRock(1, 2, Vec3d(0.25, 0.05, 0));
    const double dx = 0.02;
    Task task;
    auto bakeAll = [&](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        return bakeMeshes({MeshPart{&a.world, &a.rock.triangles}, MeshPart{&b.world, &b.rock.triangles}},
                          dx, 3.0, false, task);
    };
    auto both = bakeAll(2);
    auto one = bakeMeshes({MeshPart{&a.world, &a.rock.triangles}}, dx, 3.0, true, task);
    auto two = bakeMeshes({MeshPart{&b.world, &b.rock.triangles}}, dx, 3.0, true, task);
    auto ua = one->getConstAccessor(), ub = two->getConstAccessor(), u = both->getConstAccessor();
    // Every voxel of the union's box: min of the two full values (tiles included).
    const openvdb::CoordBBox box = both->evalActiveVoxelBoundingBox();
    size_t checked = 0;
    for (auto ijk = box.begin(); ijk; ++ijk) {
        const float expect = std::min(ua.getValue(*ijk), ub.getValue(*ijk));
        ASSERT_EQ(u.getValue(*ijk), expect) << *ijk;
        ASSERT_EQ(u.isValueOn(*ijk), std::abs(expect) < float(3 * dx)) << *ijk;
        ++checked;
    }
    EXPECT_GT(checked, 10000u);
    // The overlap's middle (inside both, far from both surfaces) is inside.
    EXPECT_LT(u.getValue(openvdb::Coord(6, 1, 0)), 0.0f);
    auto serial = bakeAll(1);
    EXPECT_TRUE(test::bitwiseEqual(*serial, *both));
}

#include <openvdb/points/AttributeArray.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>

TEST(FractalScatter, PointsCopyARadiusOnePieceOntoEachRock)
{
    // Houdini's Copy to Points puts piece point x at P + orient·(pscale·scale·x): with the
    // rock's own unit-extent mesh as the piece, that is the scattered rock, vertex for vertex.
    initialize();
    FractalRockParams p;
    p.count = 8;
    p.shape.levels = 1;
    p.size = Vec3d(0.6, 0.5, 0.35);
    p.tilt = 40.0;
    p.voxelSize = 0.05;
    p.area = std::array<double, 4>{-2.0, -2.0, 2.0, 2.0};
    Task task;
    const ScatterResult r = runScatter(p, *planeGround(), true, false, task);
    ASSERT_GE(r.rocks.size(), size_t(4));
    auto points = openvdb::gridPtrCast<openvdb::points::PointDataGrid>(r.points);
    ASSERT_TRUE(points);
    ASSERT_EQ(openvdb::points::pointCount(points->tree()), r.rocks.size());
    size_t vertices = 0;
    for (auto leaf = points->tree().cbeginLeaf(); leaf; ++leaf) {
        using namespace openvdb::points;
        AttributeHandle<openvdb::Vec3f> P(leaf->constAttributeArray("P"));
        AttributeHandle<openvdb::math::Quats> orient(leaf->constAttributeArray("orient"));
        AttributeHandle<float> pscale(leaf->constAttributeArray("pscale"));
        AttributeHandle<openvdb::Vec3f> scale(leaf->constAttributeArray("scale"));
        AttributeHandle<int32_t> id(leaf->constAttributeArray("id"));
        AttributeHandle<int32_t> variant(leaf->constAttributeArray("variant"));
        for (auto idx = leaf->beginIndexOn(); idx; ++idx) {
            const Placed& rock = r.rocks.at(size_t(id.get(*idx)));
            EXPECT_EQ(variant.get(*idx), 0);
            const Vec3d at = points->transform().indexToWorld(P.get(*idx) + idx.getCoord().asVec3d());
            RockShape shape = p.shape;
            shape.seed = rock.seed;
            Task quiet;
            const RockMesh mesh = buildRock(shape, rock.extent, rock.rotation, quiet);
            const std::vector<Vec3d> world = toWorld(mesh, rock.extent, rock.rotation, rock.position);
            const openvdb::Vec3f s = scale.get(*idx) * pscale.get(*idx);
            for (size_t k = 0; k < mesh.points.size(); ++k) {
                const Vec3d x = mesh.points[k];
                const openvdb::Vec3f local(float(x[0]) * s[0], float(x[1]) * s[1], float(x[2]) * s[2]);
                const Vec3d copied = at + Vec3d(orient.get(*idx).rotateVector(local));
                ASSERT_LT((copied - world[k]).length(), 1e-4) << "rock " << id.get(*idx) << " vertex " << k;
                ++vertices;
            }
        }
    }
    EXPECT_GT(vertices, size_t(100));
}
