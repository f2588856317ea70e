// Editing material stacks (arches §4): local rewrites of the encoding, local stabilisation,
// sculpting, deposits and erosion.
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/Edits.h>
#include <rockvdb/arches/Stabilize.h>
#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Random.h>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace rockvdb;
using namespace rockvdb::arches;
using nlohmann::json;
using rockvdb::random::uniform;

namespace {

StackGeometry geometry(int nx, int ny, double cell, double quantum = 0.01)
{
    StackGeometry g;
    g.nx = nx;
    g.ny = ny;
    g.cell = cell;
    g.quantum = quantum;
    return g;
}

// Bedrock up to a smooth hill over a plateau at 5 m (0.5 m cells, 1 cm quanta), optionally
// under sand.
Stacks hill(int n = 80, double sand = 0.0)
{
    Task task;
    return Stacks::build(geometry(n, n, 0.5), [&](int i, int j, std::vector<Layer>& layers) {
        const double x = (i + 0.5) * 0.5 - n * 0.25, y = (j + 0.5) * 0.5 - n * 0.25;
        const double h = 5.0 + 3.0 * std::exp(-(x * x + y * y) / 30.0);
        layers.push_back(Layer{Material::Bedrock, uint32_t(std::lround(h / 0.01))});
        if (sand > 0) layers.push_back(Layer{Material::Sand, uint32_t(std::lround(sand / 0.01))});
    }, task);
}

Stacks randomStacks(uint64_t seed, int n)
{
    Task task;
    return Stacks::build(geometry(n, n, 0.5), [&](int i, int j, std::vector<Layer>& layers) {
        const uint64_t key = uint64_t(j) * 1000 + uint64_t(i);
        const int count = int(uniform(seed, uint64_t(0), key) * 6.0);
        for (int l = 0; l < count; ++l) {
            layers.push_back(Layer{Material(int(uniform(seed, uint64_t(1 + 2 * l), key) * 5.0) % 5),
                                   uint32_t(1 + uniform(seed, uint64_t(2 + 2 * l), key) * 150.0)});
        }
    }, task);
}

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
    fails({{"tool", "sculpt"}, {"radius", 1}}, "points is required");
    fails({{"tool", "sculpt"}, {"radius", 1}, {"points", {{1, 1}}}}, "points[0]");
    fails({{"tool", "sculpt"}, {"radius", 1}, {"points", {{50, 1, 5}}}}, "outside the terrain");
    fails({{"tool", "deposit"}, {"center", {1, 1}}, {"radius", 1}, {"amount", 1}, {"materiel", "sand"}},
          "did you mean 'material'");
    fails({{"tool", "deposit"}, {"center", {1, 1}}, {"radius", 1}, {"amount", 1}, {"material", "lava"}}, "lava");
    fails({{"tool", "erode"}, {"center", {1, 1, 5}}, {"radius", 1}, {"rho", 0.5}}, "rho applies to mode collapse");
    fails({{"tool", "erode"}, {"mode", "collapse"}, {"center", {1, 1, 5}}, {"radius", 1}, {"rho", 2}}, "rho must be in [0, 1]");
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
        return runArches(p, buildStacks(p, task), task);
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
