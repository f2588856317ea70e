// SPDX-License-Identifier: Apache-2.0
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
#include <set>
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

// An id grid holds ids (block_id, rock_id, material), not distances.
void requireIdGrid(const openvdb::FloatGrid& ids)
{
    if (ids.getGridClass() == openvdb::GRID_LEVEL_SET) {
        fail<ValueError>("asset: the id grid '", ids.getName(), "' is a level set, not an id grid");
    }
}

void requireIds(const AssetInputs& in) { requireIdGrid(*in.ids); }

// A mask's ids must fit its PNG below the "none" value (Gltf.h): checked on the grid before
// any work, not on the texels after the bake.
void requireMaskFits(const openvdb::FloatGrid& mask, int bits)
{
    requireIdGrid(mask);
    const int top = bits == 16 ? 65535 : 255;
    int most = -1;
    for (auto it = mask.cbeginValueOn(); it; ++it) {
        int id;
        if (asId(*it, id)) most = std::max(most, id);
    }
    if (most >= top) {
        fail<ValueError>("asset: the mask grid '", mask.getName(), "' holds id ", most,
                         bits == 8 ? std::string(", above 254: use --map-bits 16")
                                   : std::string(", above 65534: too large for a 16-bit mask"));
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
std::string fitBudgets(const std::vector<size_t>& budgets, size_t full)
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

// A sub-task's host for work run side by side (parallelFor counts the progress): the parent's
// cancel only.
class CancelHost : public TaskHost
{
public:
    explicit CancelHost(Task& parent) : mParent(parent) {}
    bool cancelled() override { return mParent.cancelled(); }

private:
    Task& mParent;
};

// One asset made from its level set: the meshes, atlases and maps (all a GLB needs), with its
// statistics and report lines.
struct Built
{
    AssetParams used; ///< the values it was made with (fitted LODs)
    std::vector<size_t> budgets;
    std::vector<Lod> lods;
    std::vector<UvMesh> meshes;
    std::vector<VertexFrames> frames;
    std::vector<BakedMaps> maps;
    TriMesh hull;
    bool fitted = false;
    nlohmann::json stats;
    std::vector<std::string> report;

    GltfAsset gltf() const
    {
        GltfAsset a;
        a.name = used.name;
        a.mapBits = used.mapBits;
        a.collision = used.collision ? &hull : nullptr;
        for (size_t i = 0; i < meshes.size(); ++i) a.lods.push_back({&meshes[i], &frames[i], &maps[i]});
        return a;
    }
};

// Mesh, simplify, unwrap and bake @a grid (phases cover 0.95 * @a share of the task: the
// caller writes).
Built build(const AssetParams& p, const openvdb::FloatGrid& grid, const openvdb::FloatGrid* mask,
            bool fitLods, double share, Task& task)
{
    Built b;
    b.used = p;
    b.budgets = parseLods(p.lods);
    task.phase("mesh", 0.1 * share);
    const TriMesh full = surfaceMesh(grid);
    b.fitted = fitLods && b.budgets.front() > full.triangles();
    if (b.fitted) {
        b.used.lods = fitBudgets(b.budgets, full.triangles());
        b.budgets = parseLods(b.used.lods);
    }
    task.phase("simplify", 0.2 * share);
    b.lods = makeLods(full, b.budgets, task);
    task.phase("atlas", 0.1 * share);
    // An atlas and maps per LOD: each LOD's maps are baked on its own surface.
    for (const Lod& l : b.lods) {
        task.check();
        b.meshes.push_back(atlas(l.mesh, p.textureSize, p.padding));
        b.frames.push_back(vertexFrames(b.meshes.back()));
    }
    std::optional<Occlusion> occ;
    const double aoDistance = p.aoDistance > 0 ? p.aoDistance : 0.25 * extent(full);
    if (p.occlusion) {
        task.phase("occlusion", 0.15 * share);
        occ = occlusion(b.lods.front().mesh, grid.voxelSize()[0], aoDistance, task);
    }
    task.phase("maps", (p.occlusion ? 0.35 : 0.5) * share);
    const SurfaceField field(grid, mask);
    for (size_t i = 0; i < b.meshes.size(); ++i) {
        b.maps.push_back(bakeMaps(b.meshes[i], b.frames[i], field, p.textureSize, occ ? &*occ : nullptr, task));
    }
    task.phase("hull", 0.02 * share);
    if (p.collision) b.hull = hullMesh(b.lods.back().mesh);
    task.phase("measure", 0.03 * share);

    nlohmann::json levels = nlohmann::json::array();
    for (size_t i = 0; i < b.lods.size(); ++i) {
        const SurfaceError e = surfaceError(b.lods[i].mesh, full, grid);
        const NormalMapError ne = normalMapError(b.meshes[i], b.frames[i], b.maps[i], field);
        double aoMean = 0;
        size_t covered = 0;
        for (size_t t = 0; t < b.maps[i].covered.size(); ++t) {
            if (!b.maps[i].covered[t]) continue;
            ++covered;
            if (occ) aoMean += b.maps[i].occlusion[t];
        }
        nlohmann::json level = {{"triangles", b.lods[i].mesh.triangles()}, {"target", b.budgets[i]},
                                {"vertices", b.meshes[i].points.size()}, {"charts", b.meshes[i].charts},
                                {"mean_error", e.mean}, {"max_error", e.max},
                                {"surface_to_lod_error", e.back}, {"hausdorff", e.hausdorff},
                                {"normal_map_degrees", ne.mapDegrees}, {"lod_normal_degrees", ne.meshDegrees},
                                {"texels_covered", double(covered) / double(b.maps[i].covered.size())}};
        if (occ) level["occlusion_mean"] = covered ? aoMean / double(covered) : 1.0;
        levels.push_back(level);
        char line[360];
        std::snprintf(line, sizeof line, "LOD%zu: %zu triangles (asked %zu), %zu charts, distance "
                      "to the level set mean %.3g m, Hausdorff %.3g m; normals off the level set's "
                      "by %.2f deg with the map, %.1f deg without", i, b.lods[i].mesh.triangles(),
                      b.budgets[i], b.meshes[i].charts, e.mean, e.hausdorff, ne.mapDegrees, ne.meshDegrees);
        b.report.push_back(line);
    }
    b.stats = {{"full_triangles", full.triangles()}, {"lods", levels},
               {"texels_per_metre", b.meshes.back().texelsPerMetre}};
    if (occ) b.stats["occlusion"] = {{"distance", aoDistance}, {"voxel", occ->voxel}};
    if (p.collision) {
        b.stats["collision"] = {{"vertices", b.hull.points.size()}, {"triangles", b.hull.triangles()}};
        b.report.push_back("collision hull: " + std::to_string(b.hull.points.size()) + " vertices, " +
                           std::to_string(b.hull.triangles()) + " triangles");
    }
    if (b.fitted) b.stats["lods_fitted"] = b.used.lods;
    if (mask) {
        std::set<int32_t> ids;
        size_t none = 0, texels = 0;
        for (const BakedMaps& m : b.maps) {
            for (size_t t = 0; t < m.mask.size(); ++t) {
                if (!m.covered[t]) continue;
                ++texels;
                if (m.mask[t] < 0) ++none;
                else ids.insert(m.mask[t]);
            }
        }
        b.stats["mask"] = {{"grid", mask->getName()}, {"ids", std::vector<int32_t>(ids.begin(), ids.end())},
                           {"texels_without_id", texels ? double(none) / double(texels) : 0.0}};
    }
    b.report.insert(b.report.begin(), "surface: " + std::to_string(full.triangles()) + " triangles");
    return b;
}

} // namespace

AssetResult runAsset(const AssetParams& p, const AssetInputs& in, Task& task)
{
    assetSchema().validate(p);
    if (!in.grid) fail<ValueError>("asset: no input grid");
    requireLevelSet(*in.grid, "asset input");
    AssetResult r;

    openvdb::FloatGrid::ConstPtr grid = in.grid;
    nlohmann::json cutStats = nullptr;
    if (p.id >= 0) {
        if (!in.ids) fail<ValueError>("asset: id ", p.id, " asks for an id grid, and none was given");
        requireIds(in);
        task.phase("cut", 0.1);
        const double limit = memoryLimitBytes(0);
        const openvdb::CoordBBox* box = nullptr;
        if (in.idBoxes) {
            const auto found = in.idBoxes->find(p.id);
            if (found != in.idBoxes->end()) box = &found->second;
        }
        const CutResult c = cutId(*in.grid, *in.ids, p.id, size_t(limit / 8.0), task, box);
        grid = c.grid;
        cutStats = {{"id", p.id}, {"id_grid", in.ids->getName()}, {"voxels_searched", c.voxels},
                    {"rebuilt", c.rebuilt}};
    }
    if (in.mask && !in.idBoxes) requireMaskFits(*in.mask, p.mapBits); // (runAssetEach: once)
    Built b = build(p, *grid, in.mask.get(), in.fitLods, p.id >= 0 ? 0.9 : 1.0, task);

    nlohmann::json prov = stageProvenance(assetSchema().toJson(b.used), in.names);
    // Under "sources", as vdb_csg records its inputs: a --params replay skips it.
    prov["sources"] = nlohmann::json::array({gridSource(*in.grid)});
    r.provenance = prov;
    task.phase("write", 0.05);
    GltfAsset a = b.gltf();
    if (in.mask) a.maskName = in.mask->getName();
    a.extras = {{"rockvdb", {{"version", version()}, {"generator", kAssetTool}, {"params", prov}}}};
    r.glb = writeGlb(a);
    task.done();

    r.stats = std::move(b.stats);
    r.stats["glb_bytes"] = r.glb.size();
    r.stats["phases"] = phasesJson(task);
    if (!cutStats.is_null()) r.stats["cut"] = cutStats;
    r.report = std::move(b.report);
    if (p.id >= 0) r.report.front() += " (id " + std::to_string(p.id) + " of '" + in.ids->getName() + "')";
    return r;
}

AssetResult runAssetInstances(const AssetParams& p, const PileInstances& pile, const nlohmann::json& names,
                              Task& task)
{
    assetSchema().validate(p);
    if (p.id >= 0) fail<ValueError>("asset: a pile's instances take no id (each unique rock is an asset)");
    if (pile.prototypes.empty()) fail<ValueError>("asset: the pile has no instances");
    AssetResult r;
    // The rocks side by side (each bake is parallel inside, but a small rock's leaves do not
    // fill two cores): each in its own slot, so the order of completion does not matter.
    const size_t n = pile.prototypes.size();
    std::vector<Built> built(n);
    task.phase("rocks", 0.95);
    CancelHost host(task);
    parallelFor(task, n, 1, [&](size_t i) {
        const Prototype& proto = pile.prototypes[i];
        AssetParams one = p;
        one.name = p.name + "_" + std::to_string(proto.rock);
        Task sub(&host);
        built[i] = build(one, *proto.grid, nullptr, true, 1.0, sub);
    });
    nlohmann::json each = nlohmann::json::array();
    for (size_t i = 0; i < n; ++i) {
        nlohmann::json st = built[i].stats;
        st["rock"] = pile.prototypes[i].rock;
        st["instances"] = pile.prototypes[i].seeds.size();
        each.push_back(st);
    }
    task.phase("write", 0.05);
    std::vector<GltfAsset> assets;
    for (size_t i = 0; i < n; ++i) {
        GltfAsset a = built[i].gltf();
        a.pivot = pile.prototypes[i].pivot;
        a.instances = pile.prototypes[i].seeds;
        a.extras = {{"rockvdb_rock", pile.prototypes[i].rock}, {"rockvdb_lods", built[i].used.lods}};
        assets.push_back(std::move(a));
    }
    nlohmann::json prov = stageProvenance(assetSchema().toJson(p), names);
    r.provenance = prov;
    r.glb = writeGlb(assets, p.name,
                     {{"rockvdb", {{"version", version()}, {"generator", kAssetTool}, {"params", prov}}}});
    task.done();
    r.stats = {{"rocks", each}, {"unique_rocks", n}, {"instances", pile.instances},
               {"glb_bytes", r.glb.size()}, {"phases", phasesJson(task)}};
    size_t triangles = 0;
    for (const Built& b : built) triangles += b.lods.front().mesh.triangles();
    r.report.push_back(std::to_string(pile.instances) + " instances of " + std::to_string(n) +
                       " unique rocks (EXT_mesh_gpu_instancing), LOD0 " + std::to_string(triangles) +
                       " triangles in all, " + std::to_string(r.glb.size()) + " bytes");
    return r;
}

std::vector<int> assetIds(const AssetInputs& in)
{
    if (!in.grid || !in.ids) fail<ValueError>("asset: every id needs a level set and an id grid");
    requireIds(in);
    return surfaceIdList(*in.grid, *in.ids);
}

AssetSetResult runAssetEach(const AssetParams& p, const AssetInputs& in, Task& task)
{
    assetSchema().validate(p);
    if (!in.grid || !in.ids) fail<ValueError>("asset: every id needs a level set and an id grid");
    requireIds(in);
    if (in.mask) requireMaskFits(*in.mask, p.mapBits);
    const std::map<int, openvdb::CoordBBox> boxes = surfaceIdBoxes(*in.grid, *in.ids);
    std::vector<int> ids;
    for (const auto& [id, box] : boxes) ids.push_back(id);
    if (ids.empty()) fail<ValueError>("asset: the id grid '", in.ids->getName(), "' holds no ids");
    AssetSetResult out;
    AssetInputs fit = in;
    fit.fitLods = true;
    fit.idBoxes = &boxes;
    // The ids side by side, each in its own slot (see runAssetInstances).
    std::vector<AssetResult> made(ids.size());
    std::vector<std::string> names(ids.size());
    task.phase("assets", 1.0);
    CancelHost host(task);
    parallelFor(task, ids.size(), 1, [&](size_t i) {
        AssetParams one = p;
        one.id = ids[i];
        one.name = names[i] = p.name + "_" + std::to_string(ids[i]);
        Task sub(&host);
        made[i] = runAsset(one, fit, sub);
    });
    nlohmann::json each = nlohmann::json::array();
    for (size_t i = 0; i < ids.size(); ++i) {
        AssetResult& r = made[i];
        nlohmann::json st = r.stats;
        st.erase("phases");
        each.push_back({{"id", ids[i]}, {"stats", st}});
        out.report.push_back(names[i] + ": " + std::to_string(r.glb.size()) + " bytes, " +
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
