// SPDX-License-Identifier: Apache-2.0
// Material stacks (arches/): encoding, the convolution of §3.3, the level set, building from
// heightfields and solids.
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/StackBake.h>
#include <rockvdb/arches/StackBuild.h>
#include <rockvdb/arches/StackFile.h>
#include <rockvdb/arches/Stabilize.h>
#include <rockvdb/arches/Stacks.h>

#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Noise.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/core/Random.h>
#include "GridCompare.h"
#include "StackFixtures.h"

#include <gtest/gtest.h>
#include <openvdb/tools/Interpolation.h>
#include <tbb/global_control.h>

#include <cmath>

using namespace rockvdb;
using namespace rockvdb::arches;
using rockvdb::random::uniform;

namespace {

StackGeometry geometry(int nx, int ny, double cell, double quantum = 0.01)
{
    return test::stackGeometry(nx, ny, cell, quantum);
}

using test::randomStacks;

// The skeleton's volume in the cube, by brute force: every layer of every stack as a box.
double bruteVolume(const Stacks& st, MaterialMask mask, const Vec3d& p, double sigma)
{
    const auto& g = st.geometry();
    double v = 0;
    std::vector<Layer> layers;
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) {
            const double cx0 = g.x0 + i * g.cell, cy0 = g.y0 + j * g.cell;
            const double wx = std::max(0.0, std::min(p[0] + sigma, cx0 + g.cell) - std::max(p[0] - sigma, cx0));
            const double wy = std::max(0.0, std::min(p[1] + sigma, cy0 + g.cell) - std::max(p[1] - sigma, cy0));
            st.layers(i, j, layers);
            double z = g.z0;
            for (const Layer& l : layers) {
                const double top = z + l.thickness * g.quantum;
                if (mask & maskOf(l.material)) {
                    v += wx * wy * std::max(0.0, std::min(p[2] + sigma, top) - std::max(p[2] - sigma, z));
                }
                z = top;
            }
        }
    return v;
}

// A 12 x 12 grid of 1 m stacks: bedrock 0..2 m everywhere; in the middle 6 x 6 an overhang:
// bedrock 0..2, air 2..4, bedrock 4..6 (a slab floating over a cave).
Stacks overhang(Task& task)
{
    return Stacks::build(geometry(12, 12, 1.0), [](int i, int j, std::vector<Layer>& layers) {
        layers.push_back(Layer{Material::Bedrock, 200});
        if (i >= 3 && i < 9 && j >= 3 && j < 9) {
            layers.push_back(Layer{Material::Air, 200});
            layers.push_back(Layer{Material::Bedrock, 200});
        }
    }, task);
}

} // namespace

TEST(Stacks, EncodingMergesRunsAndSplitsThickLayers)
{
    Task task;
    auto st = Stacks::build(geometry(2, 1, 1.0), [](int i, int, std::vector<Layer>& layers) {
        if (i == 0) {
            layers = {{Material::Bedrock, 5}, {Material::Bedrock, 7}, {Material::Sand, 0},
                      {Material::Sand, 20000}, {Material::Air, 3}};
        } else {
            layers = {{Material::Air, 10}, {Material::Rocks, 4}};
        }
    }, task);
    std::vector<Layer> l;
    st.layers(0, 0, l);
    ASSERT_EQ(l.size(), 2u); // bedrock 12, sand 20000; air on top dropped
    EXPECT_EQ(l[0], (Layer{Material::Bedrock, 12}));
    EXPECT_EQ(l[1], (Layer{Material::Sand, 20000}));
    EXPECT_EQ(st.codeCount(0, 0), 6u); // 12 | 4095 x 4 + 3620
    st.layers(1, 0, l);
    ASSERT_EQ(l.size(), 2u);
    EXPECT_EQ(l[0], (Layer{Material::Air, 10}));
    EXPECT_EQ(st.height(1, 0), 14u);
    EXPECT_EQ(st.volumeQuanta(Material::Sand), 20000u);
    // A block's first stack in full (6 x 2 bytes); stack 1's codes differ in material from
    // stack 0's at the same place (2 x 2); 2 counts; 1 block offset.
    EXPECT_EQ(st.bytes(), 12 + 4 + 2 + 4u);
    EXPECT_EQ(st.layerCount(), 8u);
    // The raw encoding round-trips; a corrupt one is refused.
    EXPECT_TRUE(Stacks::fromEncoding(st.geometry(), st.stream(), st.counts()) == st);
    auto stream = st.stream();
    stream[0] = 0xf0; // material 7
    EXPECT_THROW(Stacks::fromEncoding(st.geometry(), stream, st.counts()), ValueError);
    EXPECT_THROW(Stacks::fromEncoding(st.geometry(), st.stream(), {4, 1}), ValueError);
    EXPECT_THROW(Stacks::fromEncoding(st.geometry(), st.stream(), {6, 3}), ValueError);
    // Delta codes: random access (from each block's start) and the sequential decoding agree
    // across blocks of 64 stacks, and a smooth terrain takes about a byte per layer.
    const Stacks big = randomStacks(5, 23);
    std::vector<Layer> seq, rnd;
    big.forEachStack([&](size_t s2, const uint16_t* codes, size_t n) {
        seq.clear();
        for (size_t k = 0; k < n; ++k) {
            const Material m = Stacks::codeMaterial(codes[k]);
            if (!seq.empty() && seq.back().material == m) seq.back().thickness += Stacks::codeThickness(codes[k]);
            else seq.push_back(Layer{m, Stacks::codeThickness(codes[k])});
        }
        big.layers(int(s2 % 23), int(s2 / 23), rnd);
        ASSERT_EQ(seq, rnd) << s2;
    });
    auto smooth = Stacks::build(geometry(100, 100, 1.0), [](int i, int j, std::vector<Layer>& l) {
        l = {{Material::Bedrock, uint32_t(1000 + 3 * i + 2 * j)}, {Material::Sand, uint32_t(50 + (i % 7))},
             {Material::Air, 200}, {Material::Bedrock, 300}};
    }, task);
    EXPECT_LT(double(smooth.bytes()) / 10000.0, 1.1 + 1.2 * 4) << smooth.bytes();
    EXPECT_EQ(materialFromName("rocks", "x"), Material::Rocks);
    EXPECT_THROW(materialFromName("lava", "scene.materials[2]"), ValueError);
    EXPECT_THROW(Stacks::build(geometry(0, 1, 1.0), [](int, int, std::vector<Layer>&) {}, task), ValueError);
}

TEST(Convolution, HasThePapersThreePropertiesAndEqualsTheVolumeIntegral)
{
    Task task;
    // A bedrock slab 0..10 m over 8 x 8 stacks of 1 m.
    auto slab = Stacks::build(geometry(8, 8, 1.0), [](int, int, std::vector<Layer>& l) {
        l.push_back(Layer{Material::Bedrock, 1000});
    }, task);
    const Skeleton sk(slab, kGroundMask);
    const double sigma = 0.7;
    EXPECT_DOUBLE_EQ(sk.field(Vec3d(4.1, 3.9, 5.0), sigma), 1.0);   // only material in the cube
    EXPECT_DOUBLE_EQ(sk.field(Vec3d(4.1, 3.9, 12.0), sigma), -1.0); // none
    EXPECT_NEAR(sk.field(Vec3d(4.1, 3.9, 10.0), sigma), 0.0, 1e-12); // half full: the surface
    EXPECT_NEAR(sk.field(Vec3d(4.1, 3.9, 9.8), sigma), 0.2 / sigma, 1e-12); // linear within σ
    EXPECT_NEAR(sk.field(Vec3d(0.0, 4.0, 5.0), sigma), 0.0, 1e-12); // the side wall
    EXPECT_NEAR(sk.field(Vec3d(0.0, 0.0, 10.0), sigma), 1.0 / 8.0 * 2 - 1, 1e-12); // a corner: 1/8 full
    // Random stacks, random skeletons, random points: the per-stack cumulative tables give the
    // brute-force integral over every layer's box.
    for (uint64_t seed : {1u, 2u, 3u}) {
        const Stacks st = randomStacks(seed);
        for (MaterialMask mask : {kGroundMask, maskOf(Material::Sand), MaterialMask(maskOf(Material::Air) | maskOf(Material::Water))}) {
            const Skeleton s(st, mask);
            for (int k = 0; k < 200; ++k) {
                const Vec3d p(-0.5 + 5.5 * uniform(seed, 10, uint64_t(k)), -0.5 + 5.5 * uniform(seed, 11, uint64_t(k)),
                              -0.3 + 4.5 * uniform(seed, 12, uint64_t(k)));
                const double sig = 0.1 + 0.9 * uniform(seed, 13, uint64_t(k));
                const double ours = s.field(p, sig), brute = bruteVolume(st, mask, p, sig) / (4 * sig * sig * sig) - 1;
                ASSERT_NEAR(ours, brute, 1e-5) << "seed " << seed << " point " << k;
            }
        }
    }
}

TEST(StackBake, OverhangsAreRealAndTheBandIsADistance)
{
    Task task;
    const Stacks st = overhang(task);
    const Skeleton sk(st, kGroundMask);
    SkeletonBake b;
    b.sigma = 0.5;
    b.voxelSize = 0.25;
    auto grid = bakeSkeleton(sk, b, task);
    EXPECT_EQ(grid->getGridClass(), openvdb::GRID_LEVEL_SET);
    EXPECT_FLOAT_EQ(grid->background(), 0.75f);
    // A vertical ray through the cave crosses the surface 4 times (floor, cave floor, cave
    // roof, top); one beside the overhang twice.
    auto crossings = [&](double x, double y) {
        openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> s(*grid);
        int n = 0;
        double prev = s.wsSample(Vec3d(x, y, -2.0));
        for (double z = -2.0; z <= 9.0; z += 0.05) {
            const double v = s.wsSample(Vec3d(x, y, z));
            n += (v < 0) != (prev < 0);
            prev = v;
        }
        return n;
    };
    EXPECT_EQ(crossings(6.1, 5.9), 4);
    EXPECT_EQ(crossings(1.3, 1.4), 2);
    // Flat parts: φ is the distance to the plane (the convolution surface of a flat top is
    // the top itself).
    openvdb::tools::GridSampler<openvdb::FloatGrid, openvdb::tools::BoxSampler> s(*grid);
    // (6.7: beyond σ, where the raw convolution is flat at σ: only the redistancing gives 0.7)
    for (double z : {5.4, 5.6, 5.8, 6.0, 6.25, 6.5, 6.7}) EXPECT_NEAR(s.wsSample(Vec3d(6.0, 6.0, z)), z - 6.0, 0.03) << z;
    EXPECT_GT(s.wsSample(Vec3d(6.0, 6.0, 3.0)), 0.7); // mid-cave: air, 1 m from floor and roof
    EXPECT_NEAR(s.wsSample(Vec3d(6.0, 6.0, 3.8)), 0.2, 0.03); // under the roof
    // Every band voxel: |∇φ| near 1 (a signed distance, not the raw convolution).
    size_t good = 0, all = 0;
    auto acc = grid->getConstAccessor();
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        const openvdb::Coord c = it.getCoord();
        const double gx = (acc.getValue(c.offsetBy(1, 0, 0)) - acc.getValue(c.offsetBy(-1, 0, 0))) / (2 * b.voxelSize);
        const double gy = (acc.getValue(c.offsetBy(0, 1, 0)) - acc.getValue(c.offsetBy(0, -1, 0))) / (2 * b.voxelSize);
        const double gz = (acc.getValue(c.offsetBy(0, 0, 1)) - acc.getValue(c.offsetBy(0, 0, -1))) / (2 * b.voxelSize);
        const double len = std::sqrt(gx * gx + gy * gy + gz * gz);
        if (std::abs(*it) < 0.5 * grid->background()) {
            ++all;
            good += std::abs(len - 1.0) < 0.15;
        }
    }
    EXPECT_GT(all, 1000u);
    EXPECT_GT(double(good), 0.9 * double(all)) << good << " of " << all;
}

TEST(StackBake, SolidToStacksToLevelSetStaysWithinAVoxel)
{
    Task task;
    // A mushroom rock: a cap (sphere) on a stem (capsule) on a base slab: the cap overhangs.
    FieldPtr mushroom = unite(unite(sphere(Vec3d(3.0, 3.0, 3.2), 1.6), capsule(Vec3d(3, 3, 0.5), Vec3d(3, 3, 3), 0.55)),
                              box(Vec3d(3, 3, 0.25), Vec3d(2.9, 2.9, 0.25)));
    const double dx = 0.1;
    StackGeometry g = geometry(60, 60, dx, 0.001);
    const Stacks st = stacksFromSolid(*mushroom, g, 0.01, Material::Bedrock, task);
    // The cap's overhang is in the stacks: air between the base and the cap at the rim.
    std::vector<Layer> l;
    st.layers(44, 30, l); // x = 4.45: under the cap's rim, beside the stem
    ASSERT_GE(l.size(), 3u);
    EXPECT_EQ(l[0].material, Material::Bedrock);
    EXPECT_EQ(l[1].material, Material::Air);
    SkeletonBake b;
    b.sigma = 0.5 * dx;
    b.voxelSize = dx;
    auto grid = bakeSkeleton(Skeleton(st, kGroundMask), b, task);
    // Against the solid's exact distance on every band voxel away from the base's edges.
    double worst = 0;
    size_t n = 0;
    for (auto it = grid->cbeginValueOn(); it; ++it) {
        const Vec3d p = grid->indexToWorld(it.getCoord());
        if (p[2] < 0.7) continue; // the base's sharp rim
        worst = std::max(worst, std::abs(double(*it) - double(mushroom->eval(p))));
        ++n;
    }
    EXPECT_GT(n, 5000u);
    EXPECT_LT(worst, dx) << "worst " << worst;
}

TEST(StackBake, SameBitsAtAnyThreadCount)
{
    auto run = [](int threads, Kernel kernel) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, size_t(threads));
        Task task;
        const Stacks st = randomStacks(7, 24);
        SkeletonBake b;
        b.sigma = 0.3;
        b.voxelSize = 0.1;
        b.kernel = kernel;
        b.reach = kernel == Kernel::Interpolate ? 2.0 : 0.0;
        auto grid = bakeSkeleton(Skeleton(st, kGroundMask), b, task);
        auto ids = materialGrid(st, kGroundMask, b.sigma, *grid, task);
        return std::make_tuple(st, grid, ids);
    };
    auto [s1, g1, m1] = run(1, Kernel::Box);
    auto [s2, g2, m2] = run(2, Kernel::Box);
    EXPECT_TRUE(s1 == s2);
    EXPECT_TRUE(test::bitwiseEqual(*g1, *g2));
    EXPECT_TRUE(test::bitwiseEqual(*m1, *m2));
    auto [s3, g3, m3] = run(1, Kernel::Interpolate);
    auto [s4, g4, m4] = run(2, Kernel::Interpolate);
    EXPECT_TRUE(test::bitwiseEqual(*g3, *g4));
    EXPECT_FALSE(test::bitwiseEqual(*g1, *g3)) << "the kernels differ";
    EXPECT_GT(g1->activeVoxelCount(), 1000);
    // material ids are ground materials only, on the surface's voxels.
    EXPECT_EQ(m1->activeVoxelCount(), g1->activeVoxelCount());
    for (auto it = m1->cbeginValueOn(); it; ++it) {
        ASSERT_TRUE(*it == 2.0f || *it == 3.0f || *it == 4.0f) << *it;
    }
}

TEST(StackBuild, HeightfieldGivesBedrockUnderSand)
{
    Task task;
    Heightfield hf;
    hf.nx = 4;
    hf.ny = 3;
    hf.cellSize = 2.0;
    hf.z.assign(12, 5.0f);
    hf.z[5] = 0.3f;
    const Stacks st = stacksFromHeightfield(hf, 0.01, 0.0, 0.5, nullptr, task);
    std::vector<Layer> l;
    st.layers(0, 0, l);
    ASSERT_EQ(l.size(), 2u);
    EXPECT_EQ(l[0], (Layer{Material::Bedrock, 450}));
    EXPECT_EQ(l[1], (Layer{Material::Sand, 50}));
    st.layers(1, 1, l); // 0.3 m high: all sand
    ASSERT_EQ(l.size(), 1u);
    EXPECT_EQ(l[0], (Layer{Material::Sand, 30}));
    EXPECT_DOUBLE_EQ(st.geometry().x0, -1.0);
    EXPECT_THROW(stacksFromHeightfield(hf, 0.01, 1.0, 0.5, nullptr, task), ValueError); // below the floor
    EXPECT_THROW(stacksFromHeightfield(hf, 0.01, 0.0, -0.5, nullptr, task), ValueError);
    SkeletonBake b;
    b.sigma = 0.0;
    EXPECT_THROW(bakeSkeleton(Skeleton(st, kGroundMask), b, task), ValueError);
}

// ---- stabilisation (§3.4) -------------------------------------------------------------------

namespace {

// Bedrock intervals of every stack (what stabilisation must not touch).
std::vector<std::vector<std::pair<uint64_t, uint64_t>>> bedrockOf(const Stacks& st)
{
    const auto& g = st.geometry();
    std::vector<std::vector<std::pair<uint64_t, uint64_t>>> r(g.count());
    std::vector<Layer> l;
    for (int j = 0; j < g.ny; ++j)
        for (int i = 0; i < g.nx; ++i) {
            st.layers(i, j, l);
            uint64_t z = 0;
            for (const Layer& x : l) {
                if (x.material == Material::Bedrock) r[g.index(i, j)].emplace_back(z, z + x.thickness);
                z += x.thickness;
            }
        }
    return r;
}

// A rough terrain (fBm bedrock), 0.3 m of sand everywhere, a 6 m sand heap and a 4 m rock heap
// dropped on it, and a cave (bedrock roof over air) holding sand on its floor.
Stacks unstableTerrain(Task& task, int n = 48)
{
    noise::Fbm fbm;
    fbm.octaves = 4;
    fbm.frequency = 0.08;
    const Heightfield hf = noiseHeightfield(n, n, 0.5, 3.0, fbm, 11);
    StackGeometry g = geometry(n, n, 0.5, 0.01);
    g.z0 = -10.0;
    return Stacks::build(g, [&](int i, int j, std::vector<Layer>& l) {
        uint32_t rock = uint32_t(std::lround((hf.at(i, j) + 10.0) / 0.01));
        uint32_t sandQ = 30, rocksQ = 0;
        if (std::abs(i - n / 3) <= 1 && std::abs(j - n / 3) <= 1) sandQ += 600;
        if (std::abs(i - 2 * n / 3) <= 1 && std::abs(j - n / 2) <= 1) rocksQ += 400;
        if (i >= 7 && i < 15 && j >= 29 && j < 41) {
            // A closed cave on a flat floor at 4 m: walls all round, 2 m of room, a 1 m roof;
            // sand heaped against one wall of its floor.
            const uint32_t floorQ = 1400;
            if (i == 7 || i == 14 || j == 29 || j == 40) {
                rock = floorQ + 300;
            } else {
                l.push_back(Layer{Material::Bedrock, floorQ});
                l.push_back(Layer{Material::Sand, uint32_t(i == 8 ? 150 : 10)});
                l.push_back(Layer{Material::Air, uint32_t(i == 8 ? 50 : 190)});
                rock = 100;
            }
        }
        l.push_back(Layer{Material::Bedrock, rock});
        l.push_back(Layer{Material::Sand, sandQ});
        l.push_back(Layer{Material::Rocks, rocksQ});
    }, task);
}

} // namespace

TEST(Stabilize, MergesAndSortsBetweenBedrockLayers)
{
    Task task;
    auto st = Stacks::build(geometry(1, 1, 1.0), [](int, int, std::vector<Layer>& l) {
        l = {{Material::Bedrock, 100}, {Material::Rocks, 5}, {Material::Air, 20}, {Material::Sand, 7},
             {Material::Water, 3}, {Material::Sand, 4}, {Material::Bedrock, 50}, {Material::Air, 9},
             {Material::Rocks, 2}, {Material::Sand, 1}};
    }, task);
    const Stacks n = normalizeStacks(st, task);
    std::vector<Layer> l;
    n.layers(0, 0, l);
    const std::vector<Layer> want = {{Material::Bedrock, 100}, {Material::Sand, 11}, {Material::Rocks, 5},
                                     {Material::Water, 3}, {Material::Air, 20}, {Material::Bedrock, 50},
                                     {Material::Sand, 1}, {Material::Rocks, 2}};
    EXPECT_EQ(l, want);
}

TEST(Stabilize, SlopesEndAtTheReposeAngleMassConservedBedrockUntouched)
{
    Task task;
    const Stacks before = unstableTerrain(task);
    const ReposeAngles angles;
    // Not stable to begin with (the test is not vacuous).
    EXPECT_GT(largestExcess(before, Material::Sand, angles.sand), 100.0);
    EXPECT_GT(largestExcess(before, Material::Rocks, angles.rocks), 100.0);
    StabilizeStats stats;
    const Stacks after = stabilizeStacks(before, angles, task, &stats);
    EXPECT_GT(stats.moves, 100u);
    // Stable within a quantum, for each material at its own angle.
    EXPECT_LE(largestExcess(after, Material::Sand, angles.sand), 1.0);
    EXPECT_LE(largestExcess(after, Material::Rocks, angles.rocks), 1.0);
    // Mass: exactly; bedrock: untouched.
    for (Material m : {Material::Sand, Material::Rocks, Material::Water, Material::Bedrock}) {
        EXPECT_EQ(before.volumeQuanta(m), after.volumeQuanta(m)) << materialName(m);
    }
    EXPECT_EQ(bedrockOf(before), bedrockOf(after));
    // The cave's sand stayed in the cave (bedrock walls and roof), levelled on its floor.
    uint64_t caveSand = 0;
    std::vector<Layer> l;
    for (int j = 30; j < 40; ++j)
        for (int i = 8; i < 14; ++i) {
            after.layers(i, j, l);
            ASSERT_GE(l.size(), 3u);
            ASSERT_EQ(l[1].material, Material::Sand) << i << " " << j;
            caveSand += l[1].thickness;
        }
    EXPECT_EQ(caveSand, 10u * (150 + 5 * 10));
    after.layers(8, 35, l);
    const uint32_t wallSide = l[1].thickness;
    after.layers(13, 35, l);
    EXPECT_LE(wallSide - l[1].thickness, 5 * uint32_t(0.5 * std::tan(33.0 * M_PI / 180.0) / 0.01) + 5); // spread out
    // Same bits at any thread count.
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    EXPECT_TRUE(stabilizeStacks(before, angles, task) == after);
}

TEST(Stabilize, AHeapBecomesAConeAtTheReposeAngle)
{
    Task task;
    // 20 m of sand on one stack of a flat 61 x 61 bedrock floor (0.5 m cells).
    const int n = 61;
    auto heap = Stacks::build(geometry(n, n, 0.5, 0.01), [&](int i, int j, std::vector<Layer>& l) {
        l.push_back(Layer{Material::Bedrock, 100});
        if (i == n / 2 && j == n / 2) l.push_back(Layer{Material::Sand, 2000});
    }, task);
    ReposeAngles angles;
    angles.sand = 30.0;
    const Stacks cone = stabilizeStacks(heap, angles, task);
    EXPECT_EQ(cone.volumeQuanta(Material::Sand), 2000u);
    // Along the x axis through the centre the flank stands at the angle: each step down is
    // s·tan α within a quantum or two, wherever sand lies on both sides.
    const double step = 0.5 * std::tan(30.0 * M_PI / 180.0) / 0.01;
    int flank = 0;
    for (int i = n / 2; i + 1 < n; ++i) {
        const double h0 = double(cone.height(i, n / 2)), h1 = double(cone.height(i + 1, n / 2));
        if (h1 <= 100) break; // bare bedrock beyond
        EXPECT_LE(h0 - h1, step + 1.0) << i;
        EXPECT_GE(h0 - h1, step - 2.0) << i;
        ++flank;
    }
    EXPECT_GE(flank, 2);
    EXPECT_GT(cone.height(n / 2, n / 2), 100u + uint64_t(2 * step));
    // And it is round, not square: the diagonal flank is as steep per metre as the axis.
    EXPECT_NEAR(double(cone.height(n / 2 + 2, n / 2 + 2)), double(cone.height(n / 2 + 3, n / 2)), 2 * step);
}

TEST(StackBuild, StrataFollowTheirOrderAndTheAirBandMakesOverhangs)
{
    Task task;
    StrataSpec spec;
    spec.geometry = geometry(40, 30, 1.0, 0.01);
    spec.base = 20.0;
    spec.amplitude = 8.0;
    spec.frequency = 0.05;
    spec.warp = 1.5;
    spec.warpFrequency = 0.1;
    spec.seed = 9;
    spec.strata = {{Material::Bedrock, 6}, {Material::Sand, 2}, {Material::Bedrock, 3}, {Material::Air, 2},
                   {Material::Bedrock, 100}};
    const Stacks st = stacksFromStrata(spec, task);
    noise::Fbm top;
    top.frequency = spec.frequency;
    top.octaves = spec.octaves;
    std::vector<Layer> l;
    size_t overhangs = 0;
    for (int j = 0; j < 30; ++j)
        for (int i = 0; i < 40; ++i) {
            st.layers(i, j, l);
            // The top: base + amplitude · fbm at the stack's centre, to a quantum.
            const double h = spec.base + spec.amplitude / top.amplitudeSum() * noise::fbm2(spec.seed, top, float(i + 0.5), float(j + 0.5));
            // (a top inside the air band ends the stack at the band's floor: air on top is implied)
            EXPECT_LE(double(st.height(i, j)) * 0.01, h + 0.0051);
            if (h > 15.0) EXPECT_NEAR(double(st.height(i, j)) * 0.01, h, 0.0051);
            // Materials appear in the strata's order (each at most once: boundaries never cross).
            size_t next = 0;
            for (const Layer& x : l) {
                while (next < spec.strata.size() && spec.strata[next].material != x.material) ++next;
                ASSERT_LT(next, spec.strata.size()) << i << " " << j;
                ++next;
            }
            // Where the top stands above the air band: bedrock, air, bedrock — an overhang.
            for (size_t k = 1; k + 1 < l.size(); ++k) {
                if (l[k].material == Material::Air && l[k - 1].material == Material::Bedrock && l[k + 1].material == Material::Bedrock) {
                    ++overhangs;
                }
            }
        }
    EXPECT_GT(overhangs, 200u);
    EXPECT_TRUE(stacksFromStrata(spec, task) == st);
    spec.strata[1].thickness = -1;
    EXPECT_THROW(stacksFromStrata(spec, task), ValueError);
    spec.strata.clear();
    EXPECT_THROW(stacksFromStrata(spec, task), ValueError);
}

TEST(StackFile, RoundTripsAndRefusesAnyDamage)
{
    Task task;
    const Stacks st = randomStacks(4, 13);
    const std::string params = R"({"sigma": 0.5, "materials": ["sand"]})";
    const std::string bytes = encodeStackFile(st, params);
    const StackFile back = decodeStackFile(bytes, "t");
    EXPECT_TRUE(back.stacks == st);
    EXPECT_EQ(back.params, params);
    // Every truncation and every single flipped byte is refused with an IoError.
    for (size_t n = 0; n < bytes.size(); n += 7) {
        EXPECT_THROW(decodeStackFile(bytes.substr(0, n), "t"), IoError) << n;
    }
    for (size_t i = 0; i < bytes.size(); i += 5) {
        std::string bad = bytes;
        bad[i] = char(bad[i] ^ 0x20);
        EXPECT_THROW(decodeStackFile(bad, "t"), IoError) << i;
    }
    // Through a real file; a missing file and a folder are refused.
    const std::string path = ::testing::TempDir() + "/t.stacks";
    writeStackFile(path, st, params);
    EXPECT_TRUE(readStackFile(path).stacks == st);
    EXPECT_THROW(readStackFile(path + ".missing"), IoError);
    EXPECT_THROW(readStackFile(::testing::TempDir()), IoError);
}

TEST(Stacks, AbsurdSizesAreRefusedWithAnEstimateBeforeAllocating)
{
    Task task;
    try {
        Stacks::build(geometry(2000000, 2000000, 1.0), [](int, int, std::vector<Layer>&) {}, task);
        FAIL() << "no error";
    } catch (const ValueError& e) {
        EXPECT_NE(std::string(e.what()).find("TB"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("--max-memory"), std::string::npos) << e.what();
    }
    // A small terrain baked at an absurdly fine voxel size.
    const Stacks st = randomStacks(1, 4);
    SkeletonBake b;
    b.sigma = 0.1;
    b.voxelSize = 1e-6;
    EXPECT_THROW(bakeSkeleton(Skeleton(st, kGroundMask), b, task), ValueError);
}

// ---- the stage (ArchesStage.h) --------------------------------------------------------------

TEST(ArchesStage, TheTableDrivesDefaultsChecksAndReplay)
{
    Task task;
    const ArchesParams defaults;
    EXPECT_DOUBLE_EQ(defaults.quantum, 0.01);
    EXPECT_DOUBLE_EQ(defaults.reposeSand, 33.0);
    EXPECT_FALSE(defaults.sigma.has_value());
    // No terrain, unknown keys, bad materials, bad ranges: one message naming the key.
    auto message = [&](const nlohmann::json& j) {
        try {
            const ArchesParams p = archesSchema().fromJson(j);
            buildStacks(p, task);
        } catch (const ValueError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message(nlohmann::json::object()).find("terrain is required"), std::string::npos);
    const nlohmann::json strata = {{"type", "strata"}, {"samples", {24, 20}}, {"base", 8.0}, {"amplitude", 3.0},
                                   {"frequency", 0.1}, {"warp", 0.5}, {"warp_frequency", 0.2},
                                   {"layers", {{{"material", "bedrock"}, {"thickness", 4}}, {{"material", "sand"}, {"thickness", 1}},
                                               {{"material", "bedrock"}, {"thickness", 1}}, {{"material", "air"}, {"thickness", 1}},
                                               {{"material", "bedrock"}, {"thickness", 50}}}}};
    nlohmann::json bad = strata;
    bad["layers"][1]["material"] = "lava";
    EXPECT_NE(message({{"terrain", bad}}).find("terrain.layers[1].material: unknown material 'lava'"), std::string::npos)
        << message({{"terrain", bad}});
    bad = strata;
    bad["colour"] = 3;
    EXPECT_NE(message({{"terrain", bad}}).find("terrain.colour"), std::string::npos);
    EXPECT_NE(message({{"terrain", strata}, {"sigma", 0.0}}).find("sigma"), std::string::npos);
    EXPECT_NE(message({{"terrain", strata}, {"repose-sand", 95}}).find("repose-sand"), std::string::npos);
    EXPECT_NE(message({{"terrain", strata}, {"cell-sise", 1}}).find("cell-size"), std::string::npos); // suggests

    // A run: the ground, a level set per material present, material ids, provenance that
    // replays bit for bit.
    const ArchesParams p = archesSchema().fromJson({{"terrain", strata}, {"cell-size", 0.5}});
    ArchesResult r = runStacks(p, buildStacks(p, task), task);
    ASSERT_TRUE(r.surface);
    EXPECT_EQ(r.surface->getName(), "surface");
    std::vector<std::string> names;
    for (const auto& g : r.materials) names.push_back(g->getName());
    EXPECT_EQ(names, (std::vector<std::string>{"sand", "bedrock"}));
    EXPECT_EQ(r.material->activeVoxelCount(), r.surface->activeVoxelCount());
    EXPECT_GT(r.stats.activeVoxels, 1000u);
    const auto prov = provenance(*r.surface);
    ASSERT_TRUE(prov);
    EXPECT_EQ(prov->generator, "vdb_arches");
    const ArchesParams replayed = archesSchema().fromJson(nlohmann::json::parse(prov->params));
    ArchesResult again = runStacks(replayed, buildStacks(replayed, task), task);
    EXPECT_TRUE(test::bitwiseEqual(*r.surface, *again.surface));
    EXPECT_TRUE(test::bitwiseEqual(*r.material, *again.material));
    EXPECT_TRUE(r.stacks == again.stacks);
}

TEST(ArchesStage, HeightfieldAndSolidTerrains)
{
    Task task;
    // A noise heightfield under 0.4 m of sand: one stack per sample, sand conserved by the
    // stabilisation.
    const ArchesParams hp = archesSchema().fromJson(
        {{"terrain", {{"type", "noise_terrain"}, {"samples", {30, 25}}, {"cell_size", 0.5}, {"amplitude", 4.0},
                      {"frequency", 0.1}, {"seed", 2}}},
         {"sand-depth", 0.4}});
    const Stacks hs = buildStacks(hp, task);
    EXPECT_EQ(hs.geometry().nx, 30);
    EXPECT_EQ(hs.geometry().ny, 25);
    EXPECT_DOUBLE_EQ(hs.geometry().cell, 0.5);
    EXPECT_EQ(hs.volumeQuanta(Material::Sand), 30u * 25u * 40u);
    const ArchesResult hr = runStacks(hp, hs, task);
    EXPECT_EQ(hr.stacks.volumeQuanta(Material::Sand), 30u * 25u * 40u);
    EXPECT_LE(largestExcess(hr.stacks, Material::Sand, 33.0), 1.0);
    // A solid: an arch (a box minus a cylinder-like capsule) keeps its opening as air.
    const ArchesParams sp = archesSchema().fromJson(
        {{"terrain", {{"type", "difference"},
                      {"children", {{{"type", "box"}, {"center", {0, 0, 2}}, {"size", {6, 2, 4}}},
                                    {{"type", "capsule"}, {"a", {0, -3, 0.5}}, {"b", {0, 3, 0.5}}, {"radius", 1.5}}}}}},
         {"cell-size", 0.25}, {"stabilize", false}});
    const Stacks ss = buildStacks(sp, task);
    std::vector<Layer> l;
    ss.layers(ss.geometry().nx / 2, ss.geometry().ny / 2, l); // under the arch's crown
    ASSERT_EQ(l.size(), 2u);
    EXPECT_EQ(l[0].material, Material::Air);
    EXPECT_EQ(l[1].material, Material::Bedrock);
    EXPECT_NEAR(l[0].thickness * 0.01, 2.0, 0.05); // the opening: floor 0 to the capsule's top at 2 m
}

TEST(StackBake, TheMaterialIsTheLayerAtTheSurfaceEvenOneVoxelThickOnSlopesAndOverhangs)
{
    // A 0.3 m layer of each ground material over another (σ = 0.6 m, 0.25 m voxels: the layer
    // is thinner than σ, one voxel and a bit thick), on a 27° slope and under an overhang
    // (issue 39: a volume vote in a cube of half size σ + |φ| gave the material beneath).
    Task task;
    const double cell = 0.5, t = 0.3, voxel = 0.25;
    const int n = 40; // 20 m
    const std::vector<std::pair<Material, Material>> cases = {
        {Material::Sand, Material::Bedrock}, {Material::Rocks, Material::Bedrock}, {Material::Bedrock, Material::Sand}};
    for (const auto& [top, base] : cases) {
        const char* name = materialName(top);
        // x < 10 m: the slope z = 2 + x / 2 topped by the layer; x >= 10 m: ground at 2 m and,
        // over 12 <= x < 18, 4 <= y < 16, an overhang whose underside (4 m up) is the layer.
        const Stacks st = Stacks::build(geometry(n, n, cell), [&, top = top, base = base](int i, int j, std::vector<Layer>& layers) {
            const double x = (i + 0.5) * cell, y = (j + 0.5) * cell;
            auto q = [](double m) { return uint32_t(std::lround(m / 0.01)); };
            if (x < 10) {
                const double h = 2 + 0.5 * x;
                layers.push_back(Layer{base, q(h - t)});
                layers.push_back(Layer{top, q(t)});
                return;
            }
            layers.push_back(Layer{base, q(2)});
            if (x >= 12 && x < 18 && y >= 4 && y < 16) {
                layers.push_back(Layer{Material::Air, q(2)});
                layers.push_back(Layer{top, q(t)});
                layers.push_back(Layer{base, q(2 - t)});
            }
        }, task);
        SkeletonBake b;
        b.sigma = 0.6;
        b.voxelSize = voxel;
        b.kernel = Kernel::Interpolate;
        b.reach = kDefaultReachCells * cell;
        auto surface = bakeSkeleton(Skeleton(st, kGroundMask), b, task);
        auto ids = materialGrid(st, kGroundMask, b.sigma, *surface, task);
        auto acc = ids->getConstAccessor();
        size_t slope = 0, slopeRight = 0, under = 0, underRight = 0;
        for (auto it = surface->cbeginValueOn(); it; ++it) {
            if (std::abs(*it) > 0.5 * voxel) continue; // the voxels at the surface
            const Vec3d p = surface->indexToWorld(it.getCoord());
            const bool right = acc.getValue(it.getCoord()) == float(unsigned(top));
            if (p[0] > 1.5 && p[0] < 8.5 && p[1] > 1.5 && p[1] < 18.5 && p[2] > 2.5) {
                ++slope;
                slopeRight += right;
            }
            if (p[0] > 13 && p[0] < 17 && p[1] > 5 && p[1] < 15 && std::abs(p[2] - 4) < 0.2) {
                ++under;
                underRight += right;
            }
        }
        ASSERT_GT(slope, 500u) << name;
        ASSERT_GT(under, 200u) << name;
        EXPECT_GE(double(slopeRight) / slope, 0.95) << name << " on the slope";
        EXPECT_GE(double(underRight) / under, 0.95) << name << " under the overhang";
    }
}
