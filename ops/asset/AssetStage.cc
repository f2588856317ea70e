#include "AssetStage.h"

#include <rockvdb/asset/Gltf.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <cstdio>
#include <sstream>

namespace rockvdb {
namespace asset {

const Schema<AssetParams>& assetSchema()
{
    static const Schema<AssetParams> s = [] {
        Schema<AssetParams> t("asset", "A level set as a game asset: one GLB (glTF 2.0) with "
                                       "levels of detail, a UV atlas and a normal map baked "
                                       "from the level set, y up, metres.");
        t.member(param("lods", ParamType::Text, "", "5000,1500,400", Range::any(),
                       "Triangles of each level of detail, finest first, decreasing (each is "
                       "simplified from the full surface)"),
                 &AssetParams::lods);
        t.member(param("texture-size", ParamType::Int, "texels", 1024, Range::closed(8, 16384),
                       "Normal map size (square; every LOD shares the atlas)"),
                 &AssetParams::textureSize);
        t.member(param("padding", ParamType::Int, "texels", 4, Range::closed(0, 512),
                       "Texels between UV charts (and at the border)"),
                 &AssetParams::padding);
        t.member(param("name", ParamType::Text, "", "rock", Range::any(),
                       "Asset name: nodes <name>_LOD0, <name>_LOD1, ..."),
                 &AssetParams::name);
        t.rule([](const AssetParams& p) {
            parseLods(p.lods);
            require(p.padding <= p.textureSize / 8, "asset", "padding", "at most texture-size / 8",
                    p.padding);
            require(!p.name.empty(), "asset", "name", "not empty", p.name);
        });
        return t;
    }();
    return s;
}

AssetParams::AssetParams() { assetSchema().reset(*this); }

std::vector<size_t> parseLods(const std::string& text)
{
    std::vector<size_t> out;
    std::stringstream ss(text);
    std::string item;
    while (std::getline(ss, item, ',')) {
        size_t used = 0;
        long long v = -1;
        try {
            v = std::stoll(item, &used);
        } catch (const std::exception&) {
            used = 0;
        }
        if (used == 0 || used != item.size() || v < 1) {
            fail<ValueError>("asset: lods must be triangle counts >= 1 separated by commas, e.g. "
                             "5000,1500,400 (got '", text, "')");
        }
        out.push_back(size_t(v));
    }
    if (out.empty() || out.size() > 8) {
        fail<ValueError>("asset: lods must list 1 to 8 levels (got '", text, "')");
    }
    return out;
}

AssetResult runAsset(const AssetParams& p, const AssetInputs& in, Task& task)
{
    assetSchema().validate(p);
    if (!in.grid) fail<ValueError>("asset: no input grid");
    requireLevelSet(*in.grid, "asset input");
    const std::vector<size_t> budgets = parseLods(p.lods);
    AssetResult r;

    task.phase("mesh", 0.15);
    const TriMesh full = surfaceMesh(*in.grid);
    task.phase("simplify", 0.25);
    const std::vector<Lod> lods = makeLods(full, budgets, task);
    task.phase("atlas", 0.1);
    // An atlas and a normal map per LOD: each map is baked on its own LOD's surface.
    std::vector<UvMesh> meshes;
    std::vector<VertexFrames> frames;
    for (const Lod& l : lods) {
        task.check();
        meshes.push_back(atlas(l.mesh, p.textureSize, p.padding));
        frames.push_back(vertexFrames(meshes.back()));
    }
    task.phase("normal maps", 0.45);
    std::vector<NormalMap> maps;
    for (size_t i = 0; i < meshes.size(); ++i) {
        maps.push_back(bakeNormalMap(meshes[i], frames[i], *in.grid, p.textureSize, task));
    }
    task.phase("write", 0.05);

    nlohmann::json prov = stageProvenance(assetSchema().toJson(p), in.names);
    prov["source"] = gridSource(*in.grid);
    r.provenance = prov;
    GltfAsset a;
    a.name = p.name;
    for (size_t i = 0; i < meshes.size(); ++i) a.lods.push_back({&meshes[i], &frames[i], &maps[i]});
    a.extras = {{"rockvdb", {{"version", version()}, {"generator", kAssetTool}, {"params", prov}}}};
    r.glb = writeGlb(a);
    task.done();

    nlohmann::json levels = nlohmann::json::array();
    for (size_t i = 0; i < lods.size(); ++i) {
        const SurfaceError e = surfaceError(lods[i].mesh, *in.grid);
        levels.push_back({{"triangles", lods[i].mesh.triangles()}, {"target", budgets[i]},
                          {"vertices", meshes[i].points.size()}, {"charts", meshes[i].charts},
                          {"mean_error", e.mean}, {"max_error", e.max}});
        char line[200];
        std::snprintf(line, sizeof line, "LOD%zu: %zu triangles (asked %zu), %zu charts, distance "
                      "to the level set mean %.3g m, max %.3g m", i, lods[i].mesh.triangles(),
                      budgets[i], meshes[i].charts, e.mean, e.max);
        r.report.push_back(line);
    }
    r.stats = {{"full_triangles", full.triangles()}, {"lods", levels},
               {"texels_per_metre", meshes.back().texelsPerMetre}, {"glb_bytes", r.glb.size()},
               {"phases", phasesJson(task)}};
    r.report.insert(r.report.begin(), "surface: " + std::to_string(full.triangles()) + " triangles");
    return r;
}

} // namespace asset
} // namespace rockvdb
