// The asset stage's entry points (asset/AssetStage.h): every id as its own asset, a rock
// smaller than LOD 0's budget fitted (LOD 0 = its whole surface) with the budgets it used in
// its provenance, so that the same cut by --id replays it byte for byte; the same budgets
// asked of that rock alone are an error.
#include <rockvdb/asset/AssetStage.h>
#include <rockvdb/core/Error.h>

#include <gtest/gtest.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/LevelSetSphere.h>

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
