// SPDX-License-Identifier: Apache-2.0
// Editing material stacks (arches §4): local rewrites of the encoding, local stabilisation,
// sculpting, deposits and erosion.
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/Edits.h>
#include <rockvdb/arches/Stabilize.h>
#include <rockvdb/arches/StackBake.h>
#include <rockvdb/arches/Stacks.h>
#include <rockvdb/arches/Weights.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>
#include "StackFixtures.h"

#include <gtest/gtest.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/global_control.h>

#include <cmath>
#include <set>

using namespace rockvdb;
using namespace rockvdb::arches;
using nlohmann::json;
using rockvdb::random::uniform;

namespace {

StackGeometry editsGeometry(int nx, int ny, double cell, double quantum = 0.01)
{
    return test::stackGeometry(nx, ny, cell, quantum);
}

// Bedrock up to a smooth hill over a plateau at 5 m (0.5 m cells, 1 cm quanta), optionally
// under sand.
Stacks hill(int n = 80, double sand = 0.0)
{
    Task task;
    return Stacks::build(editsGeometry(n, n, 0.5), [&](int i, int j, std::vector<Layer>& layers) {
        const double x = (i + 0.5) * 0.5 - n * 0.25, y = (j + 0.5) * 0.5 - n * 0.25;
        const double h = 5.0 + 3.0 * std::exp(-(x * x + y * y) / 30.0);
        layers.push_back(Layer{Material::Bedrock, uint32_t(std::lround(h / 0.01))});
        if (sand > 0) layers.push_back(Layer{Material::Sand, uint32_t(std::lround(sand / 0.01))});
    }, task);
}

using test::randomStacks;

double topOf(const Stacks& s, int i, int j, Material m)
{
    std::vector<Layer> layers;
    s.layers(i, j, layers);
    uint64_t z = 0, top = 0;
    for (const Layer& l : layers) {
        z += l.thickness;
        if (l.material == m) top = z;
    }
    return s.geometry().z0 + double(top) * s.geometry().quantum;
}

EditContext context()
{
    EditContext c;
    c.sigma = 0.25;
    return c;
}

} // namespace

TEST(StacksEdit, AWindowRewriteEqualsBuildingTheWholeAgain)
{
    Task task;
    const Stacks base = randomStacks(11, 150); // 22 500 stacks: ~350 blocks
    auto change = [](int i, int j, std::vector<Layer>& layers) {
        if ((i * 7 + j * 3) % 5 == 0) return false; // some stacks of the window left as they are
        layers.push_back(Layer{Material::Sand, uint32_t(1 + (i + j) % 90)});
        if (!layers.empty() && (i + j) % 3 == 0) layers.front().thickness += 70; // a delta out of range
        return true;
    };
    Stacks edited = base;
    const size_t n = edited.edit(20, 30, 83, 61, change);
    const Stacks expected = Stacks::build(base.geometry(), [&](int i, int j, std::vector<Layer>& layers) {
        base.layers(i, j, layers);
        if (i >= 20 && i <= 83 && j >= 30 && j <= 61) change(i, j, layers);
    }, task);
    EXPECT_TRUE(edited == expected);
    EXPECT_EQ(edited.layerCount(), expected.layerCount());
    EXPECT_GT(n, 1000u);
    // Every stack decodes the same, including those after the window (block offsets moved).
    std::vector<Layer> a, b;
    for (int j = 0; j < 150; j += 7)
        for (int i = 0; i < 150; i += 5) {
            edited.layers(i, j, a);
            expected.layers(i, j, b);
            ASSERT_EQ(a, b) << i << "," << j;
        }
    // A window: the same stacks, its origin moved.
    const Stacks w = edited.window(140, 140, 200, 200, task);
    EXPECT_EQ(w.geometry().nx, 10);
    EXPECT_DOUBLE_EQ(w.geometry().x0, 140 * 0.5);
    w.layers(3, 4, a);
    edited.layers(143, 144, b);
    EXPECT_EQ(a, b);
    // A change that fails (too many codes) leaves the stacks as they were.
    Stacks failing = base;
    EXPECT_THROW(failing.edit(0, 0, 5, 5, [](int, int, std::vector<Layer>& l) {
        for (int k = 0; k < 300; ++k) l.push_back(Layer{Material(k % 2 ? 2 : 3), 1});
        return true;
    }), ValueError);
    EXPECT_TRUE(failing == base);
}

TEST(StabilizeLocal, SandDroppedOnAHillSettlesWithinItsAngleAndKeepsItsMass)
{
    Task task;
    Stacks s = stabilizeStacks(hill(80, 0.3), ReposeAngles(), task);
    ASSERT_LT(largestExcess(s, Material::Sand, 33.0), 1.0);
    const uint64_t sand0 = s.volumeQuanta(Material::Sand), bed0 = s.volumeQuanta(Material::Bedrock);
    const Stacks before = s;
    // A 3 m column of sand on the hill's flank: it must spread far beyond its 3 x 3 stacks.
    s.edit(50, 40, 52, 42, [](int, int, std::vector<Layer>& l) {
        l.push_back(Layer{Material::Sand, 300});
        return true;
    });
    const StabilizeStats st = stabilizeLocal(s, ReposeAngles(), 50, 40, 52, 42, task);
    EXPECT_GT(st.moves, 100u);
    EXPECT_EQ(s.volumeQuanta(Material::Sand), sand0 + 9 * 300);
    EXPECT_EQ(s.volumeQuanta(Material::Bedrock), bed0);
    EXPECT_LT(largestExcess(s, Material::Sand, 33.0), 1.0) << "unstable after the local run";
    // Far from the drop nothing changed.
    std::vector<Layer> a, b;
    for (int j = 0; j < 80; j += 3) {
        s.layers(2, j, a);
        before.layers(2, j, b);
        EXPECT_EQ(a, b);
    }
    // The same at 1 and 2 threads.
    auto run = [&](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        Stacks t = before;
        t.edit(50, 40, 52, 42, [](int, int, std::vector<Layer>& l) {
            l.push_back(Layer{Material::Sand, 300});
            return true;
        });
        stabilizeLocal(t, ReposeAngles(), 50, 40, 52, 42, task);
        return t;
    };
    EXPECT_TRUE(run(1) == run(2));
    EXPECT_TRUE(run(1) == s);
}

TEST(Sculpt, AddThenCarveAtTheSameCentreGivesBackTheBedrockAndNothingMovesOutsideR)
{
    Task task;
    const Stacks s0 = hill(60);
    const EditContext ctx = context();
    const double R = 2.0;
    // On the plateau (z = 5), away from the hill.
    const json add = {{"tool", "sculpt"}, {"mode", "add"}, {"at", "center"}, {"radius", R}, {"points", {{4.0, 5.0, 5.0}}}};
    json carve = add;
    carve["mode"] = "carve";
    Stacks s = s0;
    const EditStats a = applyEdit(s, add, 0, ctx, task);
    EXPECT_GT(a.bedrock, 0);
    EXPECT_GT(a.stacks, 20u);
    // Nothing outside R: stacks whose axis is R or more from the centre are untouched.
    double grew = 0;
    for (int j = 0; j < 60; ++j)
        for (int i = 0; i < 60; ++i) {
            const double x = (i + 0.5) * 0.5, y = (j + 0.5) * 0.5;
            const double d = std::hypot(x - 4.0, y - 5.0);
            const double t0 = topOf(s0, i, j, Material::Bedrock), t1 = topOf(s, i, j, Material::Bedrock);
            if (d >= R) EXPECT_EQ(t0, t1) << i << "," << j;
            grew = std::max(grew, t1 - t0);
        }
    // The primitive adds up to about σ at its centre (f has slope ~1/σ, f* = 1 there).
    EXPECT_GT(grew, 0.5 * ctx.sigma);
    EXPECT_LT(grew, 2.5 * ctx.sigma);
    applyEdit(s, carve, 1, ctx, task);
    double worst = 0;
    for (int j = 0; j < 60; ++j)
        for (int i = 0; i < 60; ++i) {
            worst = std::max(worst, std::abs(topOf(s, i, j, Material::Bedrock) - topOf(s0, i, j, Material::Bedrock)));
        }
    EXPECT_LT(worst, 0.5) << "add then carve should give back the surface within a voxel (0.5 m)";
}

TEST(Sculpt, ACarvedStrokeCutsAlongItsPointsAndAStrongCarveMakesAnOverhang)
{
    Task task;
    const Stacks s0 = hill(60);
    Stacks s = s0;
    // A stroke of targets on the plateau's surface (z = 5): the surface goes down under each.
    json stroke = {{"tool", "sculpt"}, {"mode", "carve"}, {"radius", 1.5}, {"points", json::array()}};
    for (int k = 0; k < 6; ++k) stroke["points"].push_back({3.0 + k * 0.8, 3.0, 5.0});
    const EditStats st = applyEdit(s, stroke, 0, context(), task);
    EXPECT_LT(st.bedrock, 0);
    for (int k = 0; k < 6; ++k) {
        const int i = int((3.0 + k * 0.8) / 0.5), j = int(3.0 / 0.5);
        EXPECT_LT(topOf(s, i, j, Material::Bedrock), 5.0 - 0.05) << k;
    }
    // Strength 3 at a centre just under the flank's surface: a hollow with rock above it.
    Stacks t = s0;
    const json deep = {{"tool", "sculpt"}, {"mode", "carve"}, {"at", "center"}, {"radius", 1.5}, {"strength", 3.0},
                       {"points", {{15.0, 15.0, 6.0}}}};
    applyEdit(t, deep, 0, context(), task);
    std::vector<Layer> layers;
    t.layers(30, 30, layers); // the axis through the centre
    ASSERT_GE(layers.size(), 3u);
    EXPECT_EQ(layers[0].material, Material::Bedrock);
    EXPECT_EQ(layers[1].material, Material::Air);
    EXPECT_EQ(layers[2].material, Material::Bedrock);
}

TEST(DepositAndErode, MassIsConservedExactlyAndSlopesEndWithinTheirAngles)
{
    Task task;
    Stacks s = hill(80);
    const EditContext ctx = context();
    const uint64_t bed0 = s.volumeQuanta(Material::Bedrock);
    const EditStats d = applyEdit(s, {{"tool", "deposit"}, {"center", {20.0, 20.0}}, {"radius", 4.0}, {"amount", 2.0}},
                                  0, ctx, task);
    EXPECT_GT(d.sand, 0);
    EXPECT_EQ(int64_t(s.volumeQuanta(Material::Sand)), d.sand);
    EXPECT_EQ(s.volumeQuanta(Material::Bedrock), bed0);
    EXPECT_GT(d.stabilize.moves, 0u);
    EXPECT_LT(largestExcess(s, Material::Sand, 33.0), 1.0);
    // Collapse: the bedrock in a sphere on the hill's flank turns into rocks (rho) and sand.
    const uint64_t sand1 = s.volumeQuanta(Material::Sand);
    const EditStats e = applyEdit(s, {{"tool", "erode"}, {"mode", "collapse"}, {"center", {24.0, 20.0, 6.5}},
                                      {"radius", 2.0}, {"rho", 0.7}}, 1, ctx, task);
    EXPECT_LT(e.bedrock, 0);
    EXPECT_EQ(-e.bedrock, e.sand + e.rocks);
    EXPECT_NEAR(double(e.rocks) / double(-e.bedrock), 0.7, 0.01);
    EXPECT_EQ(int64_t(s.volumeQuanta(Material::Bedrock)), int64_t(bed0) + e.bedrock);
    EXPECT_EQ(int64_t(s.volumeQuanta(Material::Sand)), int64_t(sand1) + e.sand);
    EXPECT_EQ(int64_t(s.volumeQuanta(Material::Rocks)), e.rocks);
    EXPECT_LT(largestExcess(s, Material::Sand, 33.0), 1.0);
    EXPECT_LT(largestExcess(s, Material::Rocks, 42.0), 1.0);
    // Surface erosion: only a skin of `depth` under exposed faces turns into sand.
    Stacks h = hill(60);
    const EditStats f = applyEdit(h, {{"tool", "erode"}, {"center", {15.0, 15.0, 8.0}}, {"radius", 3.0}, {"depth", 0.2}},
                                  0, ctx, task);
    EXPECT_LT(f.bedrock, 0);
    EXPECT_EQ(-f.bedrock, f.sand);
    EXPECT_EQ(f.rocks, 0);
    // At most 20 quanta per stack within the sphere's footprint (π R² / s² ≈ 113 stacks).
    EXPECT_LE(-f.bedrock, 20 * 120);
}

TEST(Edits, BadEditsNameTheirIndexAndKeyAndChangeNothing)
{
    Task task;
    const Stacks s0 = hill(20);
    const EditContext ctx = context();
    auto fails = [&](const json& e, const std::string& needle) {
        Stacks s = s0;
        try {
            applyEdit(s, e, 4, ctx, task);
            ADD_FAILURE() << "accepted " << e.dump();
        } catch (const ValueError& x) {
            const std::string m = x.what();
            EXPECT_NE(m.find("edits[4]"), std::string::npos) << m;
            EXPECT_NE(m.find(needle), std::string::npos) << m;
        }
        EXPECT_TRUE(s == s0);
    };
    fails({{"tool", "smash"}}, "unknown tool 'smash'");
    fails({{"tool", "sculpt"}, {"radius", 0}, {"points", {{1, 1, 5}}}}, "radius must be > 0");
    // Ranges and values are the tool table's: what editTools() publishes is what is enforced.
    fails({{"tool", "sculpt"}, {"radius", 1}, {"strength", -1}, {"points", {{1, 1, 5}}}}, "strength must be > 0");
    fails({{"tool", "deposit"}, {"center", {1, 1}}, {"radius", 1}, {"amount", 1}, {"material", "gold"}},
          "material must be one of sand, rocks (got 'gold')");
    fails({{"tool", "sculpt"}, {"radius", 1}}, "points is required");
    fails({{"tool", "sculpt"}, {"radius", 1}, {"points", {{1, 1}}}}, "points[0]");
    fails({{"tool", "sculpt"}, {"radius", 1}, {"points", {{50, 1, 5}}}}, "outside the terrain");
    fails({{"tool", "deposit"}, {"center", {1, 1}}, {"radius", 1}, {"amount", 1}, {"materiel", "sand"}},
          "did you mean 'material'");
    fails({{"tool", "deposit"}, {"center", {1, 1}}, {"radius", 1}, {"amount", 1}, {"material", "lava"}}, "lava");
    fails({{"tool", "erode"}, {"center", {1, 1, 5}}, {"radius", 1}, {"rho", 0.5}}, "rho applies to mode collapse");
    fails({{"tool", "erode"}, {"mode", "collapse"}, {"center", {1, 1, 5}}, {"radius", 1}, {"rho", 2}}, "rho must be in [0, 1]");
}

TEST(Edits, DefaultsRangesAndValuesComeFromTheToolTable)
{
    // withDefaults fills exactly the keys the table gives a default, with that default; the
    // published range is the one enforced.
    const nlohmann::json& tools = editTools();
    for (const auto& [tool, spec] : tools.items()) {
        const nlohmann::json full = withDefaults({{"tool", tool}});
        size_t withDefault = 0;
        for (const auto& k : spec.at("keys")) {
            const std::string name = k.at("name");
            if (k.at("default").is_null()) {
                EXPECT_FALSE(full.contains(name)) << tool << "." << name;
            } else {
                ++withDefault;
                EXPECT_EQ(full.at(name), k.at("default")) << tool << "." << name;
            }
            if (!k.at("choices").empty()) EXPECT_EQ(k.at("default"), k.at("choices")[0]) << tool << "." << name;
        }
        EXPECT_EQ(full.size(), withDefault + 1) << tool;
    }
    const auto strength = tools.at("sculpt").at("keys")[4];
    ASSERT_EQ(strength.at("name"), "strength");
    EXPECT_EQ(strength.at("range"), "> 0");
    const auto rho = tools.at("erode").at("keys")[5];
    ASSERT_EQ(rho.at("name"), "rho");
    EXPECT_EQ(rho.at("range"), "in [0, 1]");
    // A given key is kept.
    EXPECT_EQ(withDefaults({{"tool", "erode"}, {"mode", "collapse"}}).at("mode"), "collapse");
}

TEST(Edits, TheSameAtAnyThreadCountAndThroughTheScene)
{
    const json edits = json::array({{{"tool", "sculpt"}, {"radius", 1.5}, {"points", {{8.0, 8.0, 0.0}, {9.0, 8.5, 0.0}}}},
                                    {{"tool", "deposit"}, {"center", {10.0, 10.0}}, {"radius", 3.0}, {"amount", 1.0}},
                                    {{"tool", "erode"}, {"mode", "collapse"}, {"center", {12.0, 10.0, 0.0}}, {"radius", 2.0}}});
    auto run = [&](int threads) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        Task task;
        ArchesParams p;
        p.terrain = {{"type", "noise_terrain"}, {"samples", {48, 48}}, {"cell_size", 0.5}, {"amplitude", 3.0}};
        p.sandDepth = 0.2;
        p.edits = edits;
        p.voxelSize = 0.5;
        return runStacks(p, buildStacks(p, task), task);
    };
    const ArchesResult a = run(1), b = run(2);
    EXPECT_TRUE(a.stacks == b.stacks);
    ASSERT_EQ(a.stats.edits.size(), 3u);
    EXPECT_NE(a.stats.edits[0].bedrock, 0);
    EXPECT_GT(a.stats.edits[1].sand, 0);
    EXPECT_LT(a.stats.edits[2].bedrock, 0);
    // Provenance lists the edits: the scene replays.
    const json prov = json::parse(a.surface->metaValue<std::string>("rockvdb:params"));
    EXPECT_EQ(prov.at("edits"), edits);
}

namespace {

// A ridge along y: bedrock up to 5 m, rising to 11 m along x = 15 (60 x 40 stacks of 0.5 m).
Stacks ridge()
{
    Task task;
    return Stacks::build(editsGeometry(60, 40, 0.5), [&](int i, int, std::vector<Layer>& layers) {
        const double x = (i + 0.5) * 0.5;
        const double h = 5.0 + 6.0 * std::max(0.0, 1.0 - std::abs(x - 15.0) / 6.0);
        layers.push_back(Layer{Material::Bedrock, uint32_t(std::lround(h / 0.01))});
    }, task);
}

json circle(double r)
{
    json p = json::array();
    for (int k = 0; k < 8; ++k) p.push_back({r * std::cos(k * M_PI / 4), r * std::sin(k * M_PI / 4)});
    return p;
}

// V - E + F of the zero isosurface of a level set (volumeToMesh, quads and triangles).
long eulerCharacteristic(const openvdb::FloatGrid& grid)
{
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(grid, points, tris, quads, 0.0);
    std::set<std::pair<unsigned, unsigned>> edges;
    auto edge = [&](unsigned a, unsigned b) { edges.insert({std::min(a, b), std::max(a, b)}); };
    for (const auto& t : tris) {
        edge(t[0], t[1]);
        edge(t[1], t[2]);
        edge(t[2], t[0]);
    }
    for (const auto& q : quads) {
        edge(q[0], q[1]);
        edge(q[1], q[2]);
        edge(q[2], q[3]);
        edge(q[3], q[0]);
    }
    return long(points.size()) - long(edges.size()) + long(tris.size() + quads.size());
}

} // namespace

TEST(Tunnel, ThroughARidgeLeavesAnAirAxisFourCrossingsAndGenusOne)
{
    Task task;
    const Stacks s0 = ridge();
    Stacks s = s0;
    const json tunnel = {{"tool", "tunnel"}, {"nodes", {{6.0, 10.0, 7.0}, {15.0, 10.5, 7.2}, {24.0, 10.0, 7.0}}},
                         {"profile", circle(1.2)}};
    const EditStats st = applyEdit(s, tunnel, 0, context(), task);
    EXPECT_LT(st.bedrock, 0);
    // Along the axis, inside the ridge (x in 11..19), the stacks hold air at the axis height.
    std::vector<Layer> layers;
    for (int i = 22; i <= 38; ++i) {
        const double x = (i + 0.5) * 0.5;
        const double y = 10.0 + 0.5 * (1.0 - std::abs(x - 15.0) / 9.0); // the path's y there
        const int j = int(y / 0.5);
        s.layers(i, j, layers);
        uint64_t z = 0;
        Material at = Material::Air;
        for (const Layer& l : layers) {
            if (700 >= z && 700 < z + l.thickness) at = l.material;
            z += l.thickness;
        }
        EXPECT_EQ(at, Material::Air) << "x = " << x;
    }
    // A vertical ray through the ridge's top crosses the ground 4 times (floor, tunnel floor,
    // tunnel roof, top), twice before.
    SkeletonBake b;
    b.sigma = 0.25;
    b.voxelSize = 0.25;
    auto crossings = [&](const Stacks& st2) {
        auto grid = bakeSkeleton(Skeleton(st2, kGroundMask), b, task);
        auto acc = grid->getConstAccessor();
        int n = 0;
        bool prev = false;
        for (int k = -10; k < 60; ++k) {
            const bool in = acc.getValue(openvdb::Coord(60, 41, k)) < 0;
            if (in != prev && k > -10) ++n;
            prev = in;
        }
        return std::make_pair(n, eulerCharacteristic(*grid));
    };
    const auto [before, chiBefore] = crossings(s0);
    const auto [after, chiAfter] = crossings(s);
    EXPECT_EQ(before, 2);
    EXPECT_EQ(after, 4);
    EXPECT_EQ(chiBefore, 2) << "the ridge is a sphere";
    EXPECT_EQ(chiAfter, 0) << "with the tunnel through it, a torus";
}

TEST(Crack, AStraightVCrackHasItsProfilesWidthAndDepth)
{
    Task task;
    Stacks s = hill(80); // the plateau at 5 m away from the hill at (20, 20)
    // Along y = 4.25 (a row of stack axes) from x = 2 to 38: a V 3 m wide one metre above the
    // surface, 4 m deep.
    const json crack = {{"tool", "crack"}, {"nodes", {{2.0, 4.25}, {38.0, 4.25}}}, {"spline", false},
                        {"profile", {{-1.5, 1.0}, {1.5, 1.0}, {0.0, -4.0}}}};
    applyEdit(s, crack, 0, context(), task);
    // Across it at x = 6 (away from the hill): at the surface (v = 0) the V is 2 * 1.5 * 4/5 =
    // 2.4 m wide; its bottom is 4 m down.
    double deepest = 5.0, widthLo = 1e9, widthHi = -1e9;
    const int i = 12;
    for (int j = 0; j < 16; ++j) {
        const double y = (j + 0.5) * 0.5, t = topOf(s, i, j, Material::Bedrock);
        deepest = std::min(deepest, t);
        if (t < 5.0 - 0.05) {
            widthLo = std::min(widthLo, y);
            widthHi = std::max(widthHi, y);
        }
        // The V's walls: on each stack's axis the top is 5 - 4 (1 - |y - 4.25| / 1.2).
        const double d = std::abs(y - 4.25);
        const double expected = d < 1.2 ? 5.0 - 4.0 * (1.0 - d / 1.2) : 5.0;
        EXPECT_NEAR(t, expected, 0.1) << "y = " << y;
    }
    EXPECT_NEAR(deepest, 1.0, 0.1);                        // 4 m deep
    EXPECT_NEAR(widthHi - widthLo + 0.5, 2.4, 0.5 + 1e-9); // 2.4 m wide, to a stack (0.5 m)
}

TEST(Crack, BadGraphsAndProfilesNameTheEditAndKey)
{
    Task task;
    const Stacks s0 = hill(20);
    auto fails = [&](const json& e, const std::string& needle) {
        Stacks s = s0;
        try {
            applyEdit(s, e, 2, context(), task);
            ADD_FAILURE() << "accepted " << e.dump();
        } catch (const ValueError& x) {
            EXPECT_NE(std::string(x.what()).find("edits[2]"), std::string::npos) << x.what();
            EXPECT_NE(std::string(x.what()).find(needle), std::string::npos) << x.what();
        }
        EXPECT_TRUE(s == s0);
    };
    const json v = {{-1, 1}, {1, 1}, {0, -2}};
    fails({{"tool", "crack"}, {"nodes", {{1, 1}, {5, 5}, {8, 2}}}, {"arcs", {{0, 1}}}, {"profile", v}},
          "nodes[2] is on no arc");
    fails({{"tool", "crack"}, {"nodes", {{1, 1}, {5, 5}}}, {"profile", {{0, 0}, {1, 1}}}}, "at least 3 points");
    fails({{"tool", "crack"}, {"nodes", {{1, 1}, {5, 5}}}, {"arcs", {{0, 4}}}, {"profile", v}}, "does not exist");
    fails({{"tool", "tunnel"}, {"nodes", {{1, 1}, {5, 5}}}, {"profile", v}}, "nodes[0] must be a list of 3 numbers");
    fails({{"tool", "tunnel"}, {"nodes", {{1, 1, 5}, {5, 5, 5}}}}, "profile (or profiles) is required");
    fails({{"tool", "crack"}, {"nodes", {{1, 1}, {50, 5}}}, {"profile", v}}, "outside the terrain");
}

TEST(Weights, TheVisibleFacesOfEachMaterialInTheCube)
{
    // Bedrock up to 5 m everywhere, 0.5 m of sand on the half x < 10 (40 x 20 stacks of 0.5 m).
    Task task;
    const Stacks s = Stacks::build(editsGeometry(40, 20, 0.5), [&](int i, int, std::vector<Layer>& layers) {
        layers.push_back(Layer{Material::Bedrock, 500});
        if (i < 20) layers.push_back(Layer{Material::Sand, 50});
    }, task);
    const ExposedFaces faces(s);
    double a[kMaterialCount];
    faces.areas(Vec3d(3.0, 5.0, 5.4), 0.5, a); // over the sand: its top, 1 m x 1 m
    EXPECT_NEAR(a[int(Material::Sand)], 1.0, 1e-9);
    EXPECT_NEAR(a[int(Material::Bedrock)], 0.0, 1e-9);
    faces.areas(Vec3d(15.0, 5.0, 5.1), 0.5, a); // over the bare bedrock
    EXPECT_NEAR(a[int(Material::Bedrock)], 1.0, 1e-9);
    EXPECT_NEAR(a[int(Material::Sand)], 0.0, 1e-9);
    // At the sand's edge (x = 10): half a square metre of each top, and the sand's 0.5 m high
    // side over the 1 m of edge in the cube.
    faces.areas(Vec3d(10.0, 5.0, 5.25), 0.5, a);
    EXPECT_NEAR(a[int(Material::Sand)], 0.5 + 0.5, 1e-9);
    EXPECT_NEAR(a[int(Material::Bedrock)], 0.5, 1e-9);
    // The grids: 1 on each side, 2/3 : 1/3 at the edge, summing to 1 on every band voxel.
    SkeletonBake b;
    b.sigma = 0.25;
    b.voxelSize = 0.25;
    auto surface = bakeSkeleton(Skeleton(s, kGroundMask), b, task);
    const auto w = visibleWeights(s, {Material::Sand, Material::Bedrock}, 0.25, *surface, task);
    ASSERT_EQ(w.size(), 2u);
    EXPECT_EQ(w[0]->getName(), "weight_sand");
    EXPECT_EQ(w[0]->activeVoxelCount(), surface->activeVoxelCount());
    auto sand = w[0]->getConstAccessor(), bed = w[1]->getConstAccessor();
    EXPECT_NEAR(sand.getValue(openvdb::Coord(12, 20, 22)), 1.0f, 1e-6); // x = 3, z = 5.5: the sand top
    EXPECT_NEAR(bed.getValue(openvdb::Coord(60, 20, 20)), 1.0f, 1e-6);  // x = 15, z = 5: bare bedrock
    size_t checked = 0;
    for (auto it = surface->cbeginValueOn(); it; ++it) {
        const openvdb::Coord c = it.getCoord();
        const double sum = double(sand.getValue(c)) + double(bed.getValue(c));
        if (sum > 0) {
            EXPECT_NEAR(sum, 1.0, 1e-5);
            ++checked;
        }
    }
    EXPECT_GT(checked, 1000u);
}

TEST(Erode, ACollapseInsideTheRockMakesRubbleThereAndLeavesTheSandCoverAlone)
{
    Task task;
    Stacks s = hill(40, 0.3); // a plateau at 5 m under 0.3 m of sand around (10, 10)
    const EditStats e = applyEdit(s, {{"tool", "erode"}, {"mode", "collapse"}, {"center", {10.0, 10.0, 3.0}},
                                      {"radius", 1.5}, {"rho", 0.5}}, 0, context(), task);
    EXPECT_EQ(-e.bedrock, e.sand + e.rocks);
    std::vector<Layer> layers;
    s.layers(19, 19, layers); // the axis 0.25 m from the sphere's centre
    ASSERT_GE(layers.size(), 4u);
    EXPECT_EQ(layers.back().material, Material::Sand);
    EXPECT_EQ(layers.back().thickness, 30u) << "the cover is untouched";
    // Inside: a room between bedrock floor and roof, rubble on its floor, air above it.
    EXPECT_EQ(layers[0].material, Material::Bedrock);
    EXPECT_EQ(layers[1].material, Material::Sand);
    EXPECT_EQ(layers[2].material, Material::Rocks);
}

TEST(Crack, AStepFarTooSmallIsRefusedBeforeAllocating)
{
    Task task;
    Stacks s = hill(20);
    const Stacks s0 = s;
    try {
        applyEdit(s, {{"tool", "crack"}, {"nodes", {{1.0, 1.0}, {9.0, 9.0}}}, {"step", 1e-7},
                      {"profile", {{-1, 1}, {1, 1}, {0, -2}}}}, 3, context(), task);
        ADD_FAILURE() << "accepted";
    } catch (const ValueError& x) {
        EXPECT_NE(std::string(x.what()).find("edits[3] (crack)"), std::string::npos) << x.what();
        EXPECT_NE(std::string(x.what()).find("use a larger step"), std::string::npos) << x.what();
    }
    EXPECT_TRUE(s == s0);
}

TEST(Erode, AStrokeErodesAContinuousBandAlongItsSegmentsAndNothingElse)
{
    // Flat bedrock at 5 m (30 x 20 m); a stroke of three points 10 m apart at the ground's
    // height, R = 1 m: spheres at the points alone would leave 8 m gaps between them.
    Task task;
    Stacks s = Stacks::build(editsGeometry(60, 40, 0.5), [](int, int, std::vector<Layer>& layers) {
        layers.push_back(Layer{Material::Bedrock, 500});
    }, task);
    const std::vector<Vec3d> stroke = {{5, 10, 5}, {15, 10, 5}, {25, 13, 5}};
    json points = json::array();
    for (const Vec3d& p : stroke) points.push_back({p[0], p[1], p[2]});
    const double R = 1.0;
    const EditStats e = applyEdit(s, {{"tool", "erode"}, {"points", points}, {"radius", R}, {"depth", 0.3}}, 0,
                                  context(), task);
    EXPECT_EQ(-e.bedrock, e.sand);
    EXPECT_EQ(e.rocks, 0);
    auto distance = [&](double x, double y) { // to the stroke, in xy
        double best = 1e9;
        for (size_t q = 0; q + 1 < stroke.size(); ++q) {
            const Vec3d a = stroke[q], b = stroke[q + 1];
            const double dx = b[0] - a[0], dy = b[1] - a[1];
            const double t = std::clamp(((x - a[0]) * dx + (y - a[1]) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
            best = std::min(best, std::hypot(x - a[0] - t * dx, y - a[1] - t * dy));
        }
        return best;
    };
    size_t band = 0;
    for (int j = 0; j < 40; ++j)
        for (int i = 0; i < 60; ++i) {
            const double x = (i + 0.5) * 0.5, y = (j + 0.5) * 0.5, d = distance(x, y);
            const double top = topOf(s, i, j, Material::Bedrock);
            if (d < 0.8 * R) { // the sphere reaches 0.6 m below the ground there: the whole depth
                ++band;
                ASSERT_NEAR(top, 4.7, 1e-9) << x << ", " << y;
            } else if (d > R) {
                ASSERT_NEAR(top, 5.0, 1e-9) << x << ", " << y;
            }
        }
    EXPECT_GT(band, 100u); // ~ 2 x 0.8 m x 30 m / 0.25 m²: along the whole stroke
    // A stroke needs its points (or a center), not both.
    EXPECT_THROW(applyEdit(s, {{"tool", "erode"}, {"radius", R}}, 0, context(), task), ValueError);
    EXPECT_THROW(applyEdit(s, {{"tool", "erode"}, {"points", points}, {"center", {5, 5, 5}}, {"radius", R}}, 0,
                           context(), task),
                 ValueError);
    EXPECT_THROW(applyEdit(s, {{"tool", "erode"}, {"points", {{5, 5, 5}, {99, 5, 5}}}, {"radius", R}}, 0, context(),
                           task),
                 ValueError); // outside the terrain
}

namespace {

// The heights where stack (i, j) holds air between bedrock (rooms), as [bottom, top] pairs.
std::vector<std::pair<double, double>> airGaps(const Stacks& s, int i, int j)
{
    std::vector<Layer> layers;
    s.layers(i, j, layers);
    std::vector<std::pair<double, double>> out;
    double z = s.geometry().z0;
    for (size_t l = 0; l < layers.size(); ++l) {
        const double top = z + layers[l].thickness * s.geometry().quantum;
        if (layers[l].material != Material::Bedrock && l + 1 < layers.size()) out.emplace_back(z, top);
        z = top;
    }
    return out;
}

} // namespace

TEST(Crack, NodesIn3DCutAlongAVerticalWallAndUnderAnOverhang)
{
    // §4.2 projects the crack's graph on the terrain's surface, whatever its orientation. 0.5 m
    // stacks; a V profile 1 m wide at the surface, 1.5 m deep.
    Task task;
    const json profile = {{-0.5, 0.5}, {0.5, 0.5}, {0.0, -1.5}};
    // A wall facing +x at x = 10 m: bedrock to 10 m on its left, to 2 m on its right. The
    // graph runs 0.3 m in front of it at 6 m up: a horizontal groove cut into the face.
    Stacks wall = Stacks::build(editsGeometry(40, 40, 0.5), [](int i, int, std::vector<Layer>& layers) {
        layers.push_back(Layer{Material::Bedrock, i < 20 ? 1000u : 200u});
    }, task);
    const EditStats e = applyEdit(wall, {{"tool", "crack"}, {"nodes", {{10.3, 4.0, 6.0}, {10.3, 16.0, 6.0}}},
                                         {"profile", profile}, {"spline", false}}, 0, context(), task);
    EXPECT_LT(e.bedrock, 0);
    for (int j = 12; j <= 28; ++j) { // y 6.25 .. 14.25: away from the ends
        // 0.25 m into the face (x = 9.75): the V is 0.625 m wide there, round z = 6.
        const auto gaps = airGaps(wall, 19, j);
        ASSERT_EQ(gaps.size(), 1u) << j;
        EXPECT_NEAR(gaps[0].first, 6.0 - 0.3125, 0.08) << j;
        EXPECT_NEAR(gaps[0].second, 6.0 + 0.3125, 0.08) << j;
        EXPECT_NEAR(topOf(wall, 19, j, Material::Bedrock), 10.0, 1e-9); // the wall's top stays
        EXPECT_TRUE(airGaps(wall, 15, j).empty()) << "2.25 m in: beyond the V's apex";
        EXPECT_NEAR(topOf(wall, 21, j, Material::Bedrock), 2.0, 1e-9); // the ground in front stays
    }
    // An overhang: a slab 5..8 m over a floor at 2 m; the graph 0.3 m under the slab's
    // underside cuts up into it (not down into the floor, 2.7 m away).
    Stacks over = Stacks::build(editsGeometry(40, 40, 0.5), [](int i, int j, std::vector<Layer>& layers) {
        layers.push_back(Layer{Material::Bedrock, 200});
        if (i >= 6 && i < 34 && j >= 6 && j < 34) {
            layers.push_back(Layer{Material::Air, 300});
            layers.push_back(Layer{Material::Bedrock, 300});
        }
    }, task);
    applyEdit(over, {{"tool", "crack"}, {"nodes", {{6.0, 10.1, 4.7}, {14.0, 10.1, 4.7}}}, {"profile", profile},
                     {"spline", false}},
              0, context(), task);
    for (int i = 16; i <= 24; ++i) {
        const auto under = airGaps(over, i, 20); // y = 10.25: 0.15 m off the graph's line
        ASSERT_EQ(under.size(), 1u) << i;
        EXPECT_NEAR(under[0].first, 2.0, 1e-9) << "the floor stays";
        // 0.15 m off the V's axis it reaches 0.9 m up (half-width (1.5 − d) / 4 = 0.15).
        EXPECT_NEAR(under[0].second, 5.9, 0.1) << "cut up into the slab";
        EXPECT_NEAR(airGaps(over, i, 26)[0].second, 5.0, 1e-9) << "3 m aside the slab stays";
    }
    // A 3D node with no bedrock surface near it is refused.
    EXPECT_THROW(applyEdit(over, {{"tool", "crack"}, {"nodes", {{10.0, 10.0, 30.0}, {12.0, 10.0, 30.0}}},
                                  {"profile", profile}},
                           0, context(), task),
                 ValueError);
}
