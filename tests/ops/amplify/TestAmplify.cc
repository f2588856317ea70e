// SPDX-License-Identifier: Apache-2.0
// Terrain amplification (implicit-blocks §5): slope rule, union property, chunks,
// determinism, and a flat terrain that qualifies nowhere.
#include <rockvdb/amplify/Amplify.h>
#include <rockvdb/blocks/BlockTile.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/VdbIO.h>

#include "GridCompare.h"

#include <gtest/gtest.h>
#include <openvdb/tools/Diagnostics.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include <cmath>
#include <cstring>

using namespace rockvdb;
using rockvdb::test::bitwiseEqual;
using rockvdb::blocks::Block;

namespace {

// 32 m × 32 m: plateau 10 m high for x < 14, valley at 0 for x > 18, a 68° cliff between.
std::shared_ptr<Heightfield> cliff(bool flat = false)
{
    auto hf = std::make_shared<Heightfield>();
    hf->nx = hf->ny = 65;
    hf->cellSize = 0.5;
    for (int j = 0; j < 65; ++j)
        for (int i = 0; i < 65; ++i) {
            const double x = i * 0.5;
            const double h = flat ? 5.0 : x < 14 ? 10.0 : x > 18 ? 0.0 : 10.0 - 2.5 * (x - 14);
            hf->z.push_back(float(h));
        }
    return hf;
}

std::shared_ptr<const blocks::BlockTile> smallTile()
{
    blocks::BlockTileParams p;
    p.type = blocks::BlockType::Equidimensional;
    p.tileSize = 10;
    p.pointRadius = 0.5;
    p.seed = 3;
    return std::make_shared<const blocks::BlockTile>(blocks::generateTile(p));
}

// The cliff as a terrain field (exact within 1.5 m), its height scaled to @a height metres.
FieldPtr cliffTerrain(bool flat = false, double height = 10.0)
{
    auto hf = cliff(flat);
    for (auto& z : hf->z) z = float(z * height / 10.0);
    HeightfieldSettings hs;
    hs.baseDepth = 2.0;
    hs.exactDistance = 1.5;
    return heightfieldField(hf, hs);
}

struct Scene
{
    FieldPtr terrain, amplified;
    amplify::AmplifiedParts parts;
    amplify::AmplifyStats stats;
};

Scene scene(bool flat = false, const amplify::Strata* strata = nullptr, double height = 10.0)
{
    Scene s;
    s.terrain = cliffTerrain(flat, height);
    amplify::PlacementRules rules;
    rules.region = BBoxd(Vec3d(1, 1, -1e30), Vec3d(31, 31, 1e30));
    std::vector<std::shared_ptr<const blocks::BlockTile>> tiles{smallTile()};
    if (strata) {
        blocks::BlockTileParams p;
        p.type = blocks::BlockType::Tabular;
        p.tileSize = 10;
        p.pointRadius = 0.5;
        p.seed = 4;
        tiles.push_back(std::make_shared<const blocks::BlockTile>(blocks::generateTile(p)));
    }
    s.parts = amplify::amplifiedParts(s.terrain, tiles, rules, s.stats, strata);
    s.amplified = s.parts.united();
    return s;
}

BakeSettings amplifySettings()
{
    BakeSettings b;
    b.voxelSize = 0.1;
    b.withAttribute = true;
    b.attributeName = "block_id";
    return b;
}


} // namespace

TEST(Amplify, BlocksOnTheCliffOnlyAndTheTerrainStaysInside)
{
    initialize();
    Scene s = scene();
    EXPECT_GT(s.stats.replicated, 10u);
    // Table 2's memory: everything the tile's block fields need (planes, anchors and the
    // relief table, which is most of it), once per tile however many blocks are replicated.
    EXPECT_EQ(s.stats.blockBytes, blocks::tileFieldBytes(*smallTile()));
    EXPECT_GT(s.stats.blockBytes, 4.0 * double(relief::tableTexels(smallTile()->params.relief, 0.0f, 10.0f)));
    EXPECT_LT(s.stats.blockBytes, 4e6);
    auto r = bake(*s.amplified, amplifySettings());
    auto bare = bake(*s.terrain, amplifySettings()).surface;
    // Slope rule: no block voxels over the plateau or the valley floor (blocks on the cliff
    // may overhang its rims by their own size, < 3.5 m here).
    size_t onCliff = 0;
    for (auto it = r.attribute->cbeginValueOn(); it; ++it) {
        if (*it < 0) continue;
        const double x = r.attribute->indexToWorld(it.getCoord())[0];
        ASSERT_GT(x, 14.0 - 3.5) << "block voxel over the plateau";
        ASSERT_LT(x, 18.0 + 3.5) << "block voxel over the valley";
        ++onCliff;
    }
    EXPECT_GT(onCliff, 5000u);
    // Union property: every voxel inside the terrain is inside the amplified terrain.
    auto acc = r.surface->getConstAccessor();
    for (auto it = bare->cbeginValueOn(); it; ++it) {
        if (*it < 0) ASSERT_LT(acc.getValue(it.getCoord()), 0.0f) << it.getCoord();
    }
}

TEST(Amplify, ChunksAndThreadsGiveTheWholeBakeBitwise)
{
    initialize();
    Scene s = scene();
    BakeSettings whole = amplifySettings();
    openvdb::FloatGrid::Ptr one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = bake(*s.amplified, whole).surface;
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = bake(*s.amplified, whole).surface;
    }
    EXPECT_TRUE(bitwiseEqual(*one, *two));
    // Two chunks split at x = 16 m (160 voxels, a leaf boundary) across the cliff.
    BakeSettings left = whole, right = whole;
    left.region = BBoxd(Vec3d(-5, -5, -5), Vec3d(16, 40, 20));
    right.region = BBoxd(Vec3d(16, -5, -5), Vec3d(40, 40, 20));
    auto a = bake(*s.amplified, left).surface;
    auto b = bake(*s.amplified, right).surface;
    EXPECT_EQ(a->activeVoxelCount() + b->activeVoxelCount(), one->activeVoxelCount());
    auto acc = one->getConstAccessor();
    for (const auto& g : {a, b}) {
        for (auto it = g->cbeginValueOn(); it; ++it) {
            float v;
            ASSERT_TRUE(acc.probeValue(it.getCoord(), v));
            ASSERT_EQ(v, *it);
        }
    }
}

TEST(Amplify, FlatTerrainQualifiesNowhere)
{
    initialize();
    Scene s = scene(/*flat=*/true);
    EXPECT_EQ(s.stats.replicated, 0u);
    EXPECT_EQ(s.amplified, s.terrain); // the bare terrain, still a valid field to bake
    amplify::PlacementRules bad;
    bad.distanceMin = 1;
    bad.distanceMax = 0;
    EXPECT_THROW(bad.validate(), ValueError);
}

TEST(Amplify, StrataChooseTheTileByElevationAlsoTilted)
{
    initialize();
    // A 20 m cliff; tile 0 (equidimensional) below the boundary, tile 1 (tabular) above.
    for (const Vec3d normal : {Vec3d(0, 0, 1), Vec3d(0, 0.4, 1)}) {
        amplify::Strata st = amplify::Strata::fromJson(
            nlohmann::json{{"normal", {normal[0], normal[1], normal[2]}},
                           {"layers", {{{"tile", "equi"}, {"top", 10.0}}, {{"tile", "tab"}}}}},
            {"equi", "tab"});
        Scene s = scene(false, &st, 20.0);
        auto r = bake(*s.amplified, amplifySettings());
        size_t counts[2] = {0, 0};
        for (auto it = r.attribute->cbeginValueOn(); it; ++it) {
            if (*it < 0) continue;
            const int tile = int(*it / amplify::kMaterialStride);
            ASSERT_TRUE(tile == 0 || tile == 1);
            ++counts[tile];
            // A copy's anchors (its centroid among them) are on its own side; its voxels
            // reach at most a block size (< 3.5 m) across the boundary.
            const double e = st.elevation(r.attribute->indexToWorld(it.getCoord()));
            if (tile == 0) ASSERT_LT(e, 10.0 + 3.5) << "tile A above the boundary";
            else ASSERT_GT(e, 10.0 - 3.5) << "tile B below the boundary";
        }
        EXPECT_GT(counts[0], 2000u);
        EXPECT_GT(counts[1], 2000u);
    }
    EXPECT_THROW(amplify::Strata::fromJson(nlohmann::json{{"layers", {{{"tile", "granite"}}}}},
                                           {"equi", "tab"}),
                 ValueError);
}

TEST(Amplify, ABlockStraddlingACellFaceIsComplete)
{
    // A present copy whose block reaches past a face of its cell, into open air: every voxel
    // inside the lone block (translated by its cell), outside the terrain and beyond the cell
    // face, is inside the amplified terrain — no flat cut at the cell face.
    initialize();
    auto terrain = cliffTerrain();
    // Tabular blocks are long: some reach well past their cell's faces.
    blocks::BlockTileParams tp;
    tp.type = blocks::BlockType::Tabular;
    tp.tileSize = 10;
    tp.pointRadius = 0.5;
    tp.seed = 4;
    auto tile = std::make_shared<const blocks::BlockTile>(blocks::generateTile(tp));
    amplify::PlacementRules rules;
    rules.distanceMin = -2.0;
    rules.region = BBoxd(Vec3d(1, 1, -1e30), Vec3d(31, 31, 1e30));
    amplify::AmplifyStats stats;
    auto presence = amplify::computePresence(*terrain, *tile, rules, stats);
    const double s = tile->size();
    BakeSettings b = amplifySettings();
    b.withAttribute = false;
    std::vector<openvdb::Coord> probe;
    for (int ix = 0; ix <= 3 && probe.empty(); ++ix)
        for (int iy = 0; iy <= 3 && probe.empty(); ++iy)
            for (int iz = -1; iz <= 2 && probe.empty(); ++iz)
                for (size_t j = 0; j < tile->blocks.size() && probe.empty(); ++j) {
                    if (!presence->present(int(j), ix, iy, iz)) continue;
                    const Vec3d shift = Vec3d(ix, iy, iz) * s;
                    const Block& B = tile->blocks[j];
                    BakeSettings r = b;
                    r.region = BBoxd(Vec3d(B.boundsMin[0], B.boundsMin[1], B.boundsMin[2]) + shift - Vec3d(0.5),
                                     Vec3d(B.boundsMax[0], B.boundsMax[1], B.boundsMax[2]) + shift + Vec3d(0.5));
                    auto alone = transform(blocks::blockField(tile, j), makeTransform(shift, Vec3d(0), Vec3d(1)));
                    auto g = bake(*alone, r).surface;
                    std::vector<openvdb::Coord> outside;
                    for (auto it = g->cbeginValueOn(); it; ++it) {
                        if (*it > -0.1f) continue;
                        const Vec3d w = g->indexToWorld(it.getCoord());
                        bool beyond = false;
                        for (int a = 0; a < 3; ++a) {
                            beyond = beyond || w[a] < shift[a] || w[a] >= shift[a] + s;
                        }
                        if (beyond && terrain->eval(w) > 0.05f) outside.push_back(it.getCoord());
                    }
                    if (outside.size() >= 30) probe = outside;
                }
    ASSERT_FALSE(probe.empty()) << "no block reaches past its cell into open air";
    blocks::TileFieldOptions o;
    o.presence = presence;
    auto amplified = csg(CsgOp::Union, {terrain, blocks::tileField(tile, o)});
    // Baked whole: a region-clipped bake cannot flood-fill inside tiles that touch its box.
    auto h = bake(*amplified, b).surface;
    auto acc = h->getConstAccessor();
    for (const auto& ijk : probe) {
        ASSERT_LT(acc.getValue(ijk), 0.0f) << "cut at " << h->indexToWorld(ijk);
    }
}

TEST(Amplify, CarvingReplacesTheSkinNearBlocksOnly)
{
    initialize();
    auto terrain = cliffTerrain();
    amplify::PlacementRules rules;
    rules.region = BBoxd(Vec3d(1, 1, -1e30), Vec3d(31, 31, 1e30));
    // A tight range keeps the blocks near the face, far from the bands checked below.
    rules.distanceMin = -1.0;
    rules.distanceMax = 0.5;
    amplify::AmplifyStats a, b;
    auto plain = amplify::amplifiedTerrain(terrain, {smallTile()}, rules, a);
    auto carved = amplify::amplifiedTerrain(terrain, {smallTile()}, rules, b, nullptr, 0.15);
    auto P = bake(*plain, amplifySettings());
    auto C = bake(*carved, amplifySettings());
    auto bare = bake(*terrain, amplifySettings()).surface;
    auto pacc = P.surface->getConstAccessor();
    auto cacc = C.surface->getConstAccessor();
    // Carved: voxels inside the bare terrain that are now open (the fractures between
    // blocks, cut back into the rock), and only near the cliff.
    size_t opened = 0;
    for (auto it = bare->cbeginValueOn(); it; ++it) {
        if (*it > -0.05f) continue;
        if (cacc.getValue(it.getCoord()) > 0.0f) {
            ++opened;
            const double x = bare->indexToWorld(it.getCoord())[0];
            ASSERT_GT(x, 14.0 - 3.5);
            ASSERT_LT(x, 18.0 + 3.5);
        }
    }
    EXPECT_GT(opened, 200u);
    // Far from every block (the plateau's middle and the valley floor) nothing changes.
    for (auto it = C.surface->cbeginValueOn(); it; ++it) {
        const double x = C.surface->indexToWorld(it.getCoord())[0];
        if (x > 6 && x < 8) ASSERT_EQ(*it, pacc.getValue(it.getCoord()));
        if (x > 26 && x < 28) ASSERT_EQ(*it, pacc.getValue(it.getCoord()));
    }
    // Blocks still make the face.
    size_t blockVoxels = 0;
    for (auto it = C.attribute->cbeginValueOn(); it; ++it) blockVoxels += *it >= 0;
    EXPECT_GT(blockVoxels, 5000u);
}

namespace {

// A zero crossing of @a acc's grid within one voxel of @a ijk: a sign change among the
// 27 voxels around it.
template <typename AccT>
bool crossingNear(AccT& acc, const openvdb::Coord& ijk)
{
    bool neg = false, pos = false;
    for (int i = -1; i <= 1; ++i)
        for (int j = -1; j <= 1; ++j)
            for (int k = -1; k <= 1; ++k) {
                const float v = acc.getValue(ijk.offsetBy(i, j, k));
                neg = neg || v < 0;
                pos = pos || v >= 0;
            }
    return neg && pos;
}

size_t normGradFailures(const openvdb::FloatGrid& g)
{
    openvdb::tools::Diagnose<openvdb::FloatGrid> d(g);
    openvdb::tools::CheckNormGrad<openvdb::FloatGrid> c(g, 0.5, 1.5);
    d.check(c, false, true, false, false);
    return size_t(d.failureCount());
}

// The parts baked apart and united (what vdb_amplify does) against the single bake of the
// united field (what it did before, renormalising terrain and blocks together): each
// surface within a voxel of the other (every voxel next to one's zero crossing has a zero
// crossing of the other within a voxel), the same block id on >= 99 % of the surface
// voxels, a level set by OpenVDB's checks, no more voxels of bad gradient.
void expectSameAsSingleBake(const amplify::AmplifiedParts& parts, const char* what,
                            double voxelSize = 0.1)
{
    BakeSettings s = amplifySettings();
    s.voxelSize = voxelSize;
    amplify::AmplifyStats st;
    const amplify::AmplifyResult split = amplify::bakeAmplified(parts, s, st);
    const BakeResult single = bake(*parts.united(), s);
    auto sacc = single.surface->getConstAccessor();
    auto nacc = split.surface->getConstAccessor();
    auto iacc = single.attribute->getConstAccessor();
    auto bacc = split.blockId->getConstAccessor();
    auto macc = split.material->getConstAccessor();
    size_t surface = 0, sameId = 0, blockVoxels = 0, far = 0;
    for (auto it = split.surface->cbeginValueOn(); it; ++it) {
        const openvdb::Coord ijk = it.getCoord();
        if (!crossingNear(nacc, ijk)) continue;
        ++surface;
        far += !crossingNear(sacc, ijk);
        // The single bake's ids hold tile·stride + block; the split ones block and material.
        const float oldId = iacc.getValue(ijk);
        const float tile = macc.getValue(ijk) - 1.0f;
        const float newId = tile < 0 ? -1.0f : tile * amplify::kMaterialStride + bacc.getValue(ijk);
        sameId += oldId == newId;
        blockVoxels += newId >= 0;
    }
    size_t oldFar = 0;
    for (auto it = single.surface->cbeginValueOn(); it; ++it) {
        if (crossingNear(sacc, it.getCoord()) && !crossingNear(nacc, it.getCoord())) ++oldFar;
    }
    EXPECT_GT(surface, 10000u) << what;
    EXPECT_GT(blockVoxels, 1000u) << what;
    EXPECT_EQ(far, 0u) << what << ": surface voxels without the single bake's surface near";
    EXPECT_EQ(oldFar, 0u) << what << ": the single bake's surface voxels without ours near";
    EXPECT_GE(double(sameId), 0.99 * double(surface)) << what << ": " << sameId << " of " << surface;
    // OpenVDB's level-set checks but the gradient's (blocks have edges: both bakes have
    // voxels outside its range, ours no more), and ids on the surface's voxels only.
    EXPECT_EQ(openvdb::tools::checkLevelSet(*split.surface, 8), "") << what;
    EXPECT_LE(normGradFailures(*split.surface), normGradFailures(*single.surface)) << what;
    EXPECT_EQ(split.blockId->activeVoxelCount(), split.surface->activeVoxelCount());
    EXPECT_EQ(split.material->activeVoxelCount(), split.surface->activeVoxelCount());
}

} // namespace

TEST(Amplify, PartsBakedApartMatchTheSingleBakeOnTheCliff)
{
    initialize();
    expectSameAsSingleBake(scene().parts, "cliff");
}

TEST(Amplify, PartsBakedApartMatchTheSingleBakeWithStrataOnALevelSetTerrain)
{
    initialize();
    // A second terrain, given as a level set (a 3D terrain's route: trilinear samples), with
    // two tiles chosen by strata; at 0.2 m voxels (the sanitizer build runs it too).
    amplify::Strata st = amplify::Strata::fromJson(
        nlohmann::json{{"layers", {{{"tile", "equi"}, {"top", 10.0}}, {{"tile", "tab"}}}}},
        {"equi", "tab"});
    BakeSettings bs;
    bs.voxelSize = 0.2;
    bs.halfWidth = 3;
    auto hf = cliff();
    for (auto& z : hf->z) z *= 2.0f;
    HeightfieldSettings hs;
    hs.baseDepth = 2.0;
    auto grid = bake(*heightfieldField(hf, hs), bs).surface;
    amplify::PlacementRules rules;
    rules.region = BBoxd(Vec3d(1, 1, -1e30), Vec3d(31, 31, 1e30));
    auto terrain = amplify::levelSetTerrain(grid, rules);
    blocks::BlockTileParams p;
    p.type = blocks::BlockType::Tabular;
    p.tileSize = 10;
    p.pointRadius = 0.5;
    p.seed = 4;
    auto tab = std::make_shared<const blocks::BlockTile>(blocks::generateTile(p));
    amplify::AmplifyStats stats;
    expectSameAsSingleBake(amplify::amplifiedParts(terrain, {smallTile(), tab}, rules, stats, &st),
                           "level-set terrain with strata", 0.2);
}

TEST(Amplify, PartsBakedApartAreTheSameAtOneAndTwoThreadsAndInChunks)
{
    initialize();
    Scene s = scene();
    const BakeSettings whole = amplifySettings();
    amplify::AmplifyResult one, two;
    amplify::AmplifyStats st;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = amplify::bakeAmplified(s.parts, whole, st);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = amplify::bakeAmplified(s.parts, whole, st);
    }
    EXPECT_TRUE(bitwiseEqual(*one.surface, *two.surface));
    EXPECT_TRUE(bitwiseEqual(*one.blockId, *two.blockId));
    EXPECT_TRUE(bitwiseEqual(*one.material, *two.material));
    // --chunks 3x2x1: every chunk's voxels are the whole bake's, and together all of them.
    size_t active = 0;
    for (int i = 0; i < 6; ++i) {
        BakeSettings c = whole;
        c.chunk = ChunkSpec::parse("3x2x1", std::to_string(i) + "/6", "amplify");
        const amplify::AmplifyResult part = amplify::bakeAmplified(s.parts, c, st);
        active += size_t(part.surface->activeVoxelCount());
        auto acc = one.surface->getConstAccessor();
        auto ids = one.blockId->getConstAccessor();
        auto pid = part.blockId->getConstAccessor();
        for (auto it = part.surface->cbeginValueOn(); it; ++it) {
            float v;
            ASSERT_TRUE(acc.probeValue(it.getCoord(), v)) << "chunk " << i << " " << it.getCoord() << " part " << *it << " whole " << v << " box " << part.surface->evalActiveVoxelBoundingBox();
            ASSERT_EQ(v, *it);
            ASSERT_EQ(ids.getValue(it.getCoord()), pid.getValue(it.getCoord()));
        }
    }
    EXPECT_EQ(active, size_t(one.surface->activeVoxelCount()));
}
