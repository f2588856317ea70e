// SPDX-License-Identifier: Apache-2.0
// The asset stage's entry points (asset/AssetStage.h): every id as its own asset, a rock
// smaller than LOD 0's budget fitted (LOD 0 = its whole surface) with the budgets it used in
// its provenance, so that the same cut by --id replays it byte for byte; the same budgets
// asked of that rock alone are an error. A pile's copies share their rock's asset.
#include <rockvdb/asset/AssetStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/rockpile/RockPile.h>
#include <rockvdb/rockpile/RockTiles.h>

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetSphere.h>

#include <algorithm>
#include <cmath>
#include <tuple>

using namespace rockvdb;
using namespace rockvdb::asset;
using openvdb::FloatGrid;

TEST(AssetStage, EveryIdIsAnAssetAndSmallRocksHaveTheirLodsFitted)
{
    const float h = 0.02f;
    auto s = openvdb::tools::createLevelSetSphere<FloatGrid>(0.5f, openvdb::Vec3f(0), h, 3.0f);
    openvdb::tools::csgUnion(*s, *openvdb::tools::createLevelSetSphere<FloatGrid>(0.1f, openvdb::Vec3f(1, 0, 0), h, 3.0f));
    s->setName("surface");
    auto ids = FloatGrid::create(-1.0f);
    ids->setTransform(s->transform().copy());
    ids->setName("rock_id");
    {
        auto acc = ids->getAccessor();
        for (auto it = s->cbeginValueOn(); it; ++it) {
            acc.setValueOn(it.getCoord(), s->transform().indexToWorld(it.getCoord()).x() < 0.7 ? 4.0f : 6.0f);
        }
    }
    AssetParams p;
    p.lods = "3000,1000,300";
    p.textureSize = 64;
    p.padding = 2;
    p.name = "stone";
    AssetInputs in;
    in.grid = s;
    in.ids = ids;
    Task task;
    EXPECT_EQ(assetIds(in), (std::vector<int>{4, 6}));
    const AssetSetResult all = runAssetEach(p, in, task);
    ASSERT_EQ(all.glbs.size(), 2u);
    EXPECT_EQ(all.glbs[0].first, 4);
    EXPECT_EQ(all.glbs[1].first, 6);
    const auto& big = all.stats["assets"][0]["stats"];
    const auto& small = all.stats["assets"][1]["stats"];
    EXPECT_FALSE(big.contains("lods_fitted"));
    EXPECT_EQ(big["lods"][0]["triangles"].get<size_t>(), 3000u);
    // the small sphere (r = 5 voxels) has fewer than 3000 triangles: LOD 0 is all of them, the
    // others keep their ratios to it
    const size_t full = small["full_triangles"].get<size_t>();
    ASSERT_LT(full, 3000u);
    EXPECT_EQ(small["lods"][0]["triangles"].get<size_t>(), full);
    const std::vector<size_t> fitted = parseLods(small["lods_fitted"].get<std::string>());
    ASSERT_EQ(fitted.size(), 3u);
    EXPECT_EQ(fitted[0], full);
    EXPECT_EQ(fitted[1], full * 1000 / 3000);
    EXPECT_EQ(fitted[2], full * 300 / 3000);
    // alone, the same budgets are an error; with the fitted ones (its provenance), the same bytes
    AssetParams one = p;
    one.id = 6;
    one.name = "stone_6";
    EXPECT_THROW(runAsset(one, in, task), ValueError);
    one.lods = small["lods_fitted"].get<std::string>();
    EXPECT_EQ(runAsset(one, in, task).glb, all.glbs[1].second);
}

TEST(AssetStage, APilesCopiesShareTheirRocksAsset)
{
    // a periodic set: every cube holds the same rocks, so a pile repeats them
    rockpile::RockTileParams tp;
    tp.tiling = rockpile::Tiling::Periodic;
    tp.n = 3;
    tp.cubeSize = 0.5;
    const rockpile::TileSet set = rockpile::generateTiles(tp);
    const auto placed = rockpile::selectRocks(set, *sphere(Vec3d(0.0), 0.5), rockpile::PileParams());
    ASSERT_GT(placed.size(), 20u);
    std::vector<PilePoint> points;
    for (const auto& in : placed) points.push_back({int64_t(in.rock), in.position});
    Task task;
    const PileInstances pile = pileInstances(set, points, 3.0, "test points", task);
    EXPECT_EQ(pile.instances, placed.size());
    size_t copies = 0;
    for (size_t i = 0; i < pile.prototypes.size(); ++i) {
        const Prototype& p = pile.prototypes[i];
        if (i > 0) EXPECT_LT(pile.prototypes[i - 1].rock, p.rock);
        EXPECT_TRUE(std::is_sorted(p.seeds.begin(), p.seeds.end(), [](const Vec3d& a, const Vec3d& b) {
            return std::make_tuple(a[0], a[1], a[2]) < std::make_tuple(b[0], b[1], b[2]);
        }));
        // every copy is its rock shifted by whole voxels
        for (const Vec3d& s : p.seeds) {
            const Vec3d k = (s - p.pivot) / pile.voxelSize;
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(k[c], std::round(k[c]), 1e-6);
        }
        // the pivot (the seed) is inside the rock
        EXPECT_LT(openvdb::tools::BoxSampler::sample(p.grid->tree(), p.grid->transform().worldToIndex(p.pivot)), 0.0f);
        copies += p.seeds.size();
    }
    EXPECT_EQ(copies, placed.size());
    EXPECT_LT(3 * pile.prototypes.size(), placed.size()) << "a periodic pile repeats its rocks";

    AssetParams ap;
    ap.lods = "200,60";
    ap.textureSize = 32;
    ap.padding = 1;
    const AssetResult r = runAssetInstances(ap, pile, {{"input", "p.vdb"}}, task);
    EXPECT_EQ(r.stats["unique_rocks"].get<size_t>(), pile.prototypes.size());
    EXPECT_EQ(r.stats["instances"].get<size_t>(), placed.size());
    EXPECT_EQ(r.provenance["input"], "p.vdb");

    // a point off its rock's lattice, and a rock the set does not have
    std::vector<PilePoint> off = points;
    off[3].position[0] += 0.3 * pile.voxelSize;
    EXPECT_THROW(pileInstances(set, off, 3.0, "test points", task), ValueError);
    off = points;
    off[0].rock = int64_t(set.rocks.size());
    EXPECT_THROW(pileInstances(set, off, 3.0, "test points", task), ValueError);
    EXPECT_THROW(pileInstances(set, {}, 3.0, "test points", task), ValueError);
    ap.id = 3;
    EXPECT_THROW(runAssetInstances(ap, pile, {}, task), ValueError);
}

TEST(AssetStage, AMaskWhoseIdsDoNotFitItsBitsIsRefusedBeforeAnyWork)
{
    auto s = openvdb::tools::createLevelSetSphere<FloatGrid>(0.3f, openvdb::Vec3f(0), 0.03f, 3.0f);
    auto mask = FloatGrid::create(-1.0f);
    mask->setTransform(s->transform().copy());
    mask->setName("material");
    for (auto it = s->cbeginValueOn(); it; ++it) mask->tree().setValueOn(it.getCoord(), 300.0f);
    AssetParams p;
    p.lods = "200";
    p.textureSize = 32;
    p.padding = 1;
    AssetInputs in;
    in.grid = s;
    in.mask = mask;
    Task task;
    try {
        runAsset(p, in, task);
        FAIL() << "id 300 in an 8-bit mask";
    } catch (const ValueError& e) {
        EXPECT_NE(std::string(e.what()).find("holds id 300, above 254"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(task.phases().empty()) << "refused before any phase";
    p.mapBits = 16;
    const AssetResult r = runAsset(p, in, task);
    EXPECT_EQ(r.stats["mask"]["ids"], nlohmann::json::array({300}));
}
