#include "AssetStage.h"

#include <rockvdb/asset/Cut.h>
#include <rockvdb/asset/Gltf.h>
#include <rockvdb/blocks/Hull.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

namespace rockvdb {
namespace asset {

const Schema<AssetParams>& assetSchema()
{
    static const Schema<AssetParams> s = [] {
        Schema<AssetParams> t("asset", "A level set as a game asset: one GLB (glTF 2.0) with "
                                       "levels of detail, each with a UV atlas and normal "
                                       "and ambient-occlusion maps baked from the level set, "
                                       "y up, metres.");
        t.member(param("lods", ParamType::Text, "", "5000,1500,400", Range::any(),
                       "Triangles of each level of detail, finest first, decreasing (each is "
                       "simplified from the full surface)"),
                 &AssetParams::lods);
        t.member(param("texture-size", ParamType::Int, "texels", 1024, Range::closed(8, 16384),
                       "Size of each LOD's maps (square; each LOD has its own atlas)"),
                 &AssetParams::textureSize);
        t.member(param("padding", ParamType::Int, "texels", 4, Range::closed(0, 512),
                       "Texels between UV charts (and at the border)"),
                 &AssetParams::padding);
        t.member(param("name", ParamType::Text, "", "rock", Range::any(),
                       "Asset name: nodes <name>_LOD0, <name>_LOD1, ..."),
                 &AssetParams::name);
        t.member(param("occlusion", ParamType::Bool, "", true, Range::any(),
                       "Bake ambient occlusion (cones traced in the asset's distance field) into "
                       "each LOD's occlusion texture"),
                 &AssetParams::occlusion);
        t.member(param("ao-distance", ParamType::Real, "m", 0.0, Range::atLeast(0),
                       "Occluders count within this distance (0 = a quarter of the asset's "
                       "largest extent)"),
                 &AssetParams::aoDistance);
        t.member(param("map-bits", ParamType::Int, "", 8, Range::closed(8, 16),
                       "Bits per channel of the PNG maps: 8 or 16"),
                 &AssetParams::mapBits);
        t.member(param("id", ParamType::Int, "", -1, Range::closed(-1, 16777215),
                       "Cut this block / rock out of the id grid (block_id, else rock_id) as the "
                       "asset (-1 = the whole level set)"),
                 &AssetParams::id);
        t.member(param("collision", ParamType::Bool, "", false, Range::any(),
                       "Add a convex collision hull, node UCX_<name>_00 (the hull of the coarsest "
                       "LOD's vertices, points of the surface)"),
                 &AssetParams::collision);
        t.rule([](const AssetParams& p) {
            parseLods(p.lods);
            require(p.padding <= p.textureSize / 8, "asset", "padding", "at most texture-size / 8",
                    p.padding);
            require(!p.name.empty(), "asset", "name", "not empty", p.name);
            require(p.mapBits == 8 || p.mapBits == 16, "asset", "map-bits", "8 or 16", p.mapBits);
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

openvdb::FloatGrid::Ptr findIdGrid(const openvdb::GridPtrVec& grids, const std::string& name,
                                   const std::string& source)
{
    const std::vector<std::string> wanted =
        name.empty() ? std::vector<std::string>{"block_id", "rock_id"} : std::vector<std::string>{name};
    for (const std::string& w : wanted) {
        for (const auto& g : grids) {
            if (!g || g->getName() != w) continue;
            auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
            if (!f) fail<ValueError>("asset: grid '", w, "' of '", source, "' is not a float grid");
            return f;
        }
    }
    std::string names;
    for (const auto& g : grids) {
        if (g && openvdb::gridPtrCast<openvdb::FloatGrid>(g) &&
            g->getGridClass() != openvdb::GRID_LEVEL_SET) {
            names += (names.empty() ? "" : ", ") + ("'" + g->getName() + "'");
        }
    }
    fail<ValueError>("asset: '", source, "' has no id grid ",
                     name.empty() ? std::string("'block_id' or 'rock_id'") : "'" + name + "'",
                     " (its other float grids: ", names.empty() ? std::string("none") : names, ")");
}

namespace {

// An id grid holds ids (block_id, rock_id), not distances: the one check both entries share.
void requireIds(const AssetInputs& in)
{
    if (in.ids->getGridClass() == openvdb::GRID_LEVEL_SET) {
        fail<ValueError>("asset: the id grid '", in.ids->getName(), "' is a level set, not an id grid");
    }
}

// The largest extent of a mesh's bounding box (m).
double extent(const TriMesh& m)
{
    openvdb::BBoxd box;
    for (const auto& p : m.points) box.expand(openvdb::Vec3d(p));
    return box.extents()[box.maxExtent()];
}

// Budgets scaled by full / budgets[0] (LOD 0 = the whole surface), each at least one below
// the one before, as the lods text.
std::string fitLods(const std::vector<size_t>& budgets, size_t full)
{
    std::string text;
    size_t prev = full + 1;
    for (size_t b : budgets) {
        size_t v = size_t(double(b) * double(full) / double(budgets.front()));
        v = std::min(v, prev - 1);
        if (v < 1) {
            fail<ValueError>("asset: the surface has ", full, " triangles, too few for ", budgets.size(),
                             " levels of detail");
        }
        text += (text.empty() ? "" : ",") + std::to_string(v);
        prev = v;
    }
    return text;
}

TriMesh hullMesh(const TriMesh& lod)
{
    std::vector<Vec3d> pts(lod.points.begin(), lod.points.end());
    const blocks::Hull h = blocks::convexHull(pts, 1e-9 * std::max(extent(lod), 1e-9));
    if (h.dimension < 3) fail<ValueError>("asset: the coarsest LOD is flat: no collision hull");
    TriMesh m;
    for (const auto& v : h.vertices) m.points.emplace_back(float(v.x()), float(v.y()), float(v.z()));
    for (const auto& t : h.triangles) m.indices.insert(m.indices.end(), t.begin(), t.end());
    return m;
}

} // namespace

AssetResult runAsset(const AssetParams& p, const AssetInputs& in, Task& task)
{
    assetSchema().validate(p);
    if (!in.grid) fail<ValueError>("asset: no input grid");
    requireLevelSet(*in.grid, "asset input");
    std::vector<size_t> budgets = parseLods(p.lods);
    AssetParams used = p; // the values this asset was made with (fitted LODs)
    AssetResult r;

    openvdb::FloatGrid::ConstPtr grid = in.grid;
    nlohmann::json cutStats = nullptr;
    if (p.id >= 0) {
        if (!in.ids) fail<ValueError>("asset: id ", p.id, " asks for an id grid, and none was given");
        requireIds(in);
        task.phase("cut", 0.1);
        const double limit = memoryLimitBytes(0);
        const CutResult c = cutId(*in.grid, *in.ids, p.id, size_t(limit / 8.0), task);
        grid = c.grid;
        cutStats = {{"id", p.id}, {"id_grid", in.ids->getName()}, {"voxels_searched", c.voxels},
                    {"rebuilt", c.rebuilt}};
    }
    const double share = p.id >= 0 ? 0.9 : 1.0;

    task.phase("mesh", 0.1 * share);
    const TriMesh full = surfaceMesh(*grid);
    const bool fitted = in.fitLods && budgets.front() > full.triangles();
    if (fitted) {
        used.lods = fitLods(budgets, full.triangles());
        budgets = parseLods(used.lods);
    }
    task.phase("simplify", 0.2 * share);
    const std::vector<Lod> lods = makeLods(full, budgets, task);
    task.phase("atlas", 0.1 * share);
    // An atlas and maps per LOD: each LOD's maps are baked on its own surface.
    std::vector<UvMesh> meshes;
    std::vector<VertexFrames> frames;
    for (const Lod& l : lods) {
        task.check();
        meshes.push_back(atlas(l.mesh, p.textureSize, p.padding));
        frames.push_back(vertexFrames(meshes.back()));
    }
    std::optional<Occlusion> occ;
    const double aoDistance = p.aoDistance > 0 ? p.aoDistance : 0.25 * extent(full);
    if (p.occlusion) {
        task.phase("occlusion", 0.15 * share);
        occ = occlusion(lods.front().mesh, grid->voxelSize()[0], aoDistance, task);
    }
    task.phase("maps", (p.occlusion ? 0.4 : 0.55) * share);
    std::vector<BakedMaps> maps;
    for (size_t i = 0; i < meshes.size(); ++i) {
        maps.push_back(bakeMaps(meshes[i], frames[i], *grid, p.textureSize, occ ? &*occ : nullptr, task));
    }
    task.phase("write", 0.05 * share);
    TriMesh hull;
    if (p.collision) hull = hullMesh(lods.back().mesh);

    nlohmann::json prov = stageProvenance(assetSchema().toJson(used), in.names);
    // Under "sources", as vdb_csg records its inputs: a --params replay skips it.
    prov["sources"] = nlohmann::json::array({gridSource(*in.grid)});
    r.provenance = prov;
    GltfAsset a;
    a.name = p.name;
    a.mapBits = p.mapBits;
    a.collision = p.collision ? &hull : nullptr;
    for (size_t i = 0; i < meshes.size(); ++i) a.lods.push_back({&meshes[i], &frames[i], &maps[i]});
    a.extras = {{"rockvdb", {{"version", version()}, {"generator", kAssetTool}, {"params", prov}}}};
    r.glb = writeGlb(a);
    task.done();

    nlohmann::json levels = nlohmann::json::array();
    for (size_t i = 0; i < lods.size(); ++i) {
        const SurfaceError e = surfaceError(lods[i].mesh, *grid);
        const NormalMapError ne = normalMapError(meshes[i], frames[i], maps[i], *grid);
        double aoMean = 0;
        size_t covered = 0;
        for (size_t t = 0; t < maps[i].covered.size(); ++t) {
            if (!maps[i].covered[t]) continue;
            ++covered;
            if (occ) aoMean += maps[i].occlusion[t];
        }
        nlohmann::json level = {{"triangles", lods[i].mesh.triangles()}, {"target", budgets[i]},
                                {"vertices", meshes[i].points.size()}, {"charts", meshes[i].charts},
                                {"mean_error", e.mean}, {"max_error", e.max},
                                {"normal_map_degrees", ne.mapDegrees}, {"lod_normal_degrees", ne.meshDegrees},
                                {"texels_covered", double(covered) / double(maps[i].covered.size())}};
        if (occ) level["occlusion_mean"] = covered ? aoMean / double(covered) : 1.0;
        levels.push_back(level);
        char line[320];
        std::snprintf(line, sizeof line, "LOD%zu: %zu triangles (asked %zu), %zu charts, distance "
                      "to the level set mean %.3g m, max %.3g m; normals off the level set's by "
                      "%.2f deg with the map, %.1f deg without", i, lods[i].mesh.triangles(),
                      budgets[i], meshes[i].charts, e.mean, e.max, ne.mapDegrees, ne.meshDegrees);
        r.report.push_back(line);
    }
    r.stats = {{"full_triangles", full.triangles()}, {"lods", levels},
               {"texels_per_metre", meshes.back().texelsPerMetre}, {"glb_bytes", r.glb.size()},
               {"phases", phasesJson(task)}};
    if (occ) {
        r.stats["occlusion"] = {{"distance", aoDistance}, {"voxel", occ->voxel}};
    }
    if (p.collision) {
        r.stats["collision"] = {{"vertices", hull.points.size()}, {"triangles", hull.triangles()}};
        r.report.push_back("collision hull: " + std::to_string(hull.points.size()) + " vertices, " +
                           std::to_string(hull.triangles()) + " triangles");
    }
    if (!cutStats.is_null()) r.stats["cut"] = cutStats;
    if (fitted) r.stats["lods_fitted"] = used.lods;
    r.report.insert(r.report.begin(), "surface: " + std::to_string(full.triangles()) + " triangles" +
                    (p.id >= 0 ? " (id " + std::to_string(p.id) + " of '" + in.ids->getName() + "')" : ""));
    return r;
}

std::vector<int> assetIds(const AssetInputs& in)
{
    if (!in.grid || !in.ids) fail<ValueError>("asset: every id needs a level set and an id grid");
    requireIds(in);
    return surfaceIdList(*in.grid, *in.ids);
}

namespace {

// A sub-task's host: the parent's cancel; its progress maps into [lo, hi] of the parent's phase.
class SubHost : public TaskHost
{
public:
    SubHost(Task& parent, double lo, double hi) : mParent(parent), mLo(lo), mHi(hi) {}
    bool cancelled() override { return mParent.cancelled(); }
    void progress(const char*, double f) override { mParent.advance(mLo + (mHi - mLo) * f); }

private:
    Task& mParent;
    double mLo, mHi;
};

} // namespace

AssetSetResult runAssetEach(const AssetParams& p, const AssetInputs& in, Task& task)
{
    assetSchema().validate(p);
    const std::vector<int> ids = assetIds(in);
    if (ids.empty()) fail<ValueError>("asset: the id grid '", in.ids->getName(), "' holds no ids");
    AssetSetResult out;
    AssetInputs fit = in;
    fit.fitLods = true;
    nlohmann::json each = nlohmann::json::array();
    task.phase("assets", 1.0);
    for (size_t i = 0; i < ids.size(); ++i) {
        task.check();
        AssetParams one = p;
        one.id = ids[i];
        one.name = p.name + "_" + std::to_string(ids[i]);
        SubHost host(task, double(i) / double(ids.size()), double(i + 1) / double(ids.size()));
        Task sub(&host);
        AssetResult r = runAsset(one, fit, sub);
        nlohmann::json st = r.stats;
        st.erase("phases");
        each.push_back({{"id", ids[i]}, {"stats", st}});
        out.report.push_back(one.name + ": " + std::to_string(r.glb.size()) + " bytes, " +
                             (r.report.size() > 1 ? r.report[1] : r.report.front()));
        out.glbs.emplace_back(ids[i], std::move(r.glb));
    }
    task.done();
    out.stats = {{"assets", each}, {"count", ids.size()}, {"phases", phasesJson(task)}};
    out.report.insert(out.report.begin(), std::to_string(ids.size()) + " assets, one per id of '" +
                      in.ids->getName() + "'");
    return out;
}

} // namespace asset
} // namespace rockvdb
