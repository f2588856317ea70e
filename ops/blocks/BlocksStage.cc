// SPDX-License-Identifier: Apache-2.0
#include "BlocksStage.h"

#include <rockvdb/blocks/Aperiodic.h>
#include <rockvdb/blocks/TileBuild.h>

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/VdbIO.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace rockvdb {
namespace blocks {

using nlohmann::json;

namespace {

json vec(const Vec3d& v) { return {v[0], v[1], v[2]}; }

/// The tile's rows on any Params that holds a BlockTileParams: @a at(p) gives it (const or not).
template<typename P, typename Access>
void addTileRows(Schema<P>& s, Access at)
{
    using T = BlockTileParams;
    auto bind = [&](ParamInfo info, auto get, auto set) {
        s.add(std::move(info), [at, get](const P& p) { return json(get(at(p))); },
              [at, set](P& p, const json& j) { set(at(p), j); });
    };
    auto member = [&](ParamInfo info, auto T::*m) {
        using V = std::remove_reference_t<decltype(std::declval<T&>().*m)>;
        bind(std::move(info), [m](const T& t) { return schema_detail::Conv<V>::get(t.*m); },
             [m](T& t, const json& j) { schema_detail::Conv<V>::set(t.*m, j); });
    };
    ParamInfo type = param("type", ParamType::Text, "", "equidimensional", Range::any(),
                         "Block type (§4.1, Fig. 2)");
    type.choices = {"equidimensional", "prismatic", "polyhedral", "rhombohedral", "tabular",
                    "columnar"};
    bind(type, [](const T& t) { return json(blockTypeName(t.type)); },
         [](T& t, const json& j) { t.type = blockTypeFromString(j.get<std::string>()); });
    member(param("tile-size", ParamType::Real, "m", 20.0, Range::openClosed(0, 1e4), "Tile side s"),
           &T::tileSize);
    member(param("point-radius", ParamType::Real, "m", 0.0, Range::open(0, 5e3),
               "Poisson radius of the sample points"), &T::pointRadius);
    member(param("neighbour-radius", ParamType::Real, "m", 0.0, Range::open(0, 5e3),
               "Longest graph edge"), &T::neighbourRadius);
    member(param("disc-count", ParamType::Int, "", -1, Range::closed(0, 10000),
               "Generated fracture discs (0 = none)"), &T::discCount);
    member(param("disc-spacing", ParamType::Real, "m", 0.0, Range::open(0, 5e3),
               "Poisson radius of the disc centres"), &T::discSpacing);
    bind(param("disc-radius", ParamType::Reals, "m", nullptr, Range::closed(0, 4e4),
             "Disc radius range min,max", 2),
         [](const T& t) {
             return t.discRadiusMin > 0 ? json::array({t.discRadiusMin, t.discRadiusMax}) : json();
         },
         [](T& t, const json& j) {
             t.discRadiusMin = j.is_null() ? 0.0 : j.at(0).get<double>();
             t.discRadiusMax = j.is_null() ? 0.0 : j.at(1).get<double>();
         });
    member(param("jitter", ParamType::Real, "degrees", -1.0, Range::closed(0, 90),
               "Random tilt of the set normals"), &T::jitterDeg);
    member(param("irregular-fraction", ParamType::Real, "", -1.0, Range::closed(0, 1),
               "Share of discs with a random normal"),
           &T::irregularFraction);
    member(param("axis", ParamType::Reals, "", json::array({0.0, 0.0, 1.0}), Range::closed(-1e6, 1e6),
               "Dominant axis: bedding normal / column axis", 3), &T::axis);
    member(param("oblique-angle", ParamType::Real, "degrees", 60.0, Range::closed(30, 90),
               "Rhombohedral: angle between the three set normals"), &T::obliqueDeg);
    bind(param("fractures", ParamType::Json, "", nullptr, Range::any(),
             "Extra fracture discs, a JSON file (or list): [{\"center\":[x,y,z],"
             "\"normal\":[x,y,z],\"radius\":r}, ...] (tile coordinates, m)"),
         [](const T& t) {
             if (t.extraDiscs.empty()) return json();
             json a = json::array();
             for (const auto& d : t.extraDiscs) {
                 a.push_back({{"center", vec(d.center)}, {"normal", vec(d.normal)}, {"radius", d.radius}});
             }
             return a;
         },
         [](T& t, const json& j) {
             t.extraDiscs = j.is_null() ? std::vector<Disc>() : fracturesFromJson(jsonOrFile(j));
         });
    bind(param("authored", ParamType::Json, "", nullptr, Range::any(),
             "Authored blocks, a JSON file (or list): [{\"type\":\"box\",\"center\":[..],"
             "\"size\":[..],\"rotate\":[..]} or {\"type\":\"polytope\",\"planes\":"
             "[[nx,ny,nz,d],...]} (convex), or any bounded expression node as vdb_primitive "
             "expr takes ({\"type\":\"sphere\",...}, a smooth union, ...; it keeps later "
             "blocks fracture-width away), ...]; ids in list order"),
         [](const T& t) {
             if (t.authored.empty()) return json();
             json a = json::array();
             for (const auto& b : t.authored) {
                 if (b.isExpression()) a.push_back(json::parse(b.expression));
                 else a.push_back({{"type", "polytope"}, {"planes", b.planes}});
             }
             return a;
         },
         [](T& t, const json& j) {
             t.authored = j.is_null() ? std::vector<AuthoredBlock>() : authoredListFromJson(jsonOrFile(j));
         });
    member(param("min-points", ParamType::Int, "", 8, Range::closed(1, 100000),
               "Clusters with fewer points join a neighbour whose joint hull holds no third "
               "cluster's point, else stay blocks (without fill: are dropped)"), &T::minPoints);
    member(param("fill", ParamType::Bool, "", true, Range::any(),
               "Grow each block to its fractures: neighbours share a separating plane (the "
               "disc's own where it separates them) and stand fracture-width apart; --no-fill: "
               "the paper's hull-only reading (neighbours about a point spacing apart, small "
               "clusters dropped)"), &T::fill);
    member(param("fracture-width", ParamType::Real, "m", -1.0, Range::closed(0, 1e3),
               "Gap between neighbouring blocks across a fracture (unused without fill)"),
           &T::fractureWidth);
    member(param("smooth-radius", ParamType::Real, "m", -1.0, Range::closed(0, 2.5e3),
               "R of the smooth intersection of the hull planes"), &T::smoothRadius);
    const auto warp = warpRows(-1.0, 1.0,
        "Warp: exponent p of the triplanar weights |g.u_i|^p (1 = the paper's)");
    bind(warp[0], [](const T& t) { return t.relief.amplitude; },
         [](T& t, const json& j) { t.relief.amplitude = j.get<double>(); });
    bind(warp[1], [](const T& t) { return t.relief.image.empty() ? std::string("turbulence") : t.relief.image; },
         [](T& t, const json& j) {
             const std::string v = j.get<std::string>();
             t.relief.image = v == "turbulence" ? std::string() : v;
         });
    bind(warp[2], [](const T& t) { return t.relief.scale; },
         [](T& t, const json& j) { t.relief.scale = j.get<double>(); });
    bind(warp[3], [](const T& t) { return t.relief.octaves; },
         [](T& t, const json& j) { t.relief.octaves = j.get<int>(); });
    bind(warp[4], [](const T& t) { return t.relief.sharpness; },
         [](T& t, const json& j) { t.relief.sharpness = j.get<double>(); });
    member(seedRow(), &T::seed);

    // Derived defaults (numbers and reasons: BlockTileParams.cc), in the order they read each
    // other, and the rules between rows.
    using namespace tilegen;
    auto derived = [&](const char* name, const std::string& text, auto fill) {
        s.derived(name, text, [at, fill](P& p) { fill(at(p)); });
    };
    // The texts are made from the factors, so help and rule cannot disagree.
    auto perSize = [](double factor) {
        std::ostringstream os;
        os << factor << " x tile-size";
        return os.str();
    };
    derived("point-radius", perSize(kPointRadiusPerSize),
            [](T& t) { t.pointRadius = kPointRadiusPerSize * t.tileSize; });
    derived("neighbour-radius", "2 x point-radius",
            [](T& t) { t.neighbourRadius = 2.0 * t.pointRadius; });
    derived("disc-count", "the type's",
            [](T& t) { t.discCount = typeDefaults(t.type).count; });
    derived("disc-spacing", "the type's share of tile-size",
            [](T& t) { t.discSpacing = typeDefaults(t.type).spacing * t.tileSize; });
    derived("disc-radius", "the type's shares of tile-size", [](T& t) {
        const TypeDefaults& d = typeDefaults(t.type);
        if (t.discRadiusMin <= 0) t.discRadiusMin = d.rmin * t.tileSize;
        if (t.discRadiusMax <= 0) t.discRadiusMax = std::max(t.discRadiusMin, d.rmax * t.tileSize);
    });
    derived("jitter", "the type's", [](T& t) { t.jitterDeg = typeDefaults(t.type).jitter; });
    derived("irregular-fraction", "the type's",
            [](T& t) { t.irregularFraction = typeDefaults(t.type).irregular; });
    derived("fracture-width", perSize(kFractureWidthPerSize),
            [](T& t) { t.fractureWidth = kFractureWidthPerSize * t.tileSize; });
    // R and the warp scale with the tile, so a 5 m tile is as full as a 20 m one (issue 38:
    // at 0.25 m and 0.05 m absolute, 5 m tiles were 63-76 % rock); given, they stay absolute.
    derived("smooth-radius", perSize(kSmoothRadiusPerSize),
            [](T& t) { t.smoothRadius = kSmoothRadiusPerSize * t.tileSize; });
    derived("warp-amplitude", perSize(kWarpAmplitudePerSize),
            [](T& t) { t.relief.amplitude = kWarpAmplitudePerSize * t.tileSize; });
    s.rule([at](const P& p) { checkTileRules(at(p)); });
    // Front-ends' groups (the Blender add-on's sub-panels); the rest is Shape.
    s.group("Fractures", {"point-radius", "neighbour-radius", "disc-count", "disc-spacing",
                          "disc-radius", "jitter", "irregular-fraction", "oblique-angle",
                          "fractures", "min-points"});
    s.group("Surface", {"fill", "fracture-width", "smooth-radius", "warp-amplitude", "warp-relief",
                        "warp-scale", "warp-octaves", "warp-sharpness"});
}

Schema<BlockTileParams> makeTileSchema()
{
    Schema<BlockTileParams> s("blocks", "A periodic tile of fractured rock blocks (implicit blocks §4).");
    addTileRows(s, [](auto& p) -> auto& { return p; });
    return s;
}

Schema<BlocksParams> makeBlocksSchema()
{
    Schema<BlocksParams> s("blocks",
        "Generate a periodic tile of fractured rock blocks (Paris et al., 'Modeling rocky "
        "scenery using implicit blocks', §4): Poisson-sphere points in a periodic cube, a "
        "neighbour graph, fracture discs per block type cutting its edges, clusters split "
        "until no disc separates two of their points, one block per cluster = smooth "
        "intersection of its convex hull's planes, warped by a triplanar relief; baked with "
        "its block ids over periods.");
    addTileRows(s, [](auto& p) -> auto& { return p.tile; });
    s.member(param("periods", ParamType::Ints, "", json::array({1, 1, 1}), Range::closed(1, 1024),
                 "Tile periods baked along x,y,z", 3), &BlocksParams::periods);
    addAperiodicRows(s, &BlocksParams::aperiodic, &BlocksParams::colours,
                     " (periods: the cubes baked from the lattice's origin)");
    addBakeRows(s, &BlocksParams::bake, defaultVoxelSize(), defaultHalfWidth());
    return s;
}

// Tile files written before the table spelt keys with '_' and nested the warp as "relief".
json fromLegacy(const json& j)
{
    if (!j.is_object() || !j.contains("relief")) return j;
    json out = json::object();
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (it.key() == "relief") {
            const json& r = it.value();
            static const std::pair<const char*, const char*> names[] = {
                {"amplitude", "warp-amplitude"}, {"scale", "warp-scale"},
                {"octaves", "warp-octaves"}, {"sharpness", "warp-sharpness"}};
            for (const auto& [from, to] : names) {
                if (r.contains(from)) out[to] = r.at(from);
            }
            const std::string image = r.value("image", std::string());
            out["warp-relief"] = image.empty() ? std::string("turbulence") : image;
            continue;
        }
        std::string key = it.key();
        std::replace(key.begin(), key.end(), '_', '-');
        const bool emptyList = it.value().is_array() && it.value().empty();
        out[key] = emptyList && (key == "fractures" || key == "authored") ? json() : it.value();
    }
    return out;
}

// The tile field is exact up to s/4 from the blocks; a renormalised bake reads values up to
// about 2·band + a voxel + 2·amplitude.
void checkVoxel(double tileSize, double amplitude, const BakeSettings& s)
{
    const double need = (2.0 * s.halfWidth * s.voxelSize + s.voxelSize + 2.0 * amplitude) * 1.01;
    if (need > tileSize / 4) {
        fail<ValueError>("blocks: voxel size ", s.voxelSize, " m is too coarse for a ", tileSize,
                         " m tile (the band needs ", need, " m, the tile field is exact to tile "
                         "size / 4)");
    }
}

} // namespace

const Schema<BlockTileParams>& tileSchema()
{
    static const Schema<BlockTileParams> s = makeTileSchema();
    return s;
}

const Schema<BlocksParams>& blocksSchema()
{
    static const Schema<BlocksParams> s = makeBlocksSchema();
    return s;
}

BlockTileParams::BlockTileParams() { tileSchema().reset(*this); }
json BlockTileParams::toJson() const { return tileSchema().toJson(*this); }
BlockTileParams BlockTileParams::fromJson(const json& j) { return tileSchema().fromJson(fromLegacy(j)); }

BlocksParams::BlocksParams() { blocksSchema().reset(*this); }

namespace {

std::shared_ptr<const BlockTile> makeTile(const BlockTileParams& given, Task& task)
{
    BlockTileParams params = given;
    params.resolveDefaults();
    if (!params.relief.image.empty() && params.relief.amplitude > 0) {
        // Fail before generating: unreadable or multi-channel reliefs are errors.
        readGrayImage(params.relief.image, "relief");
    }
    return std::make_shared<const BlockTile>(generateTile(params, task));
}

BakeResult bakeTile(const std::shared_ptr<const BlockTile>& tile, const BlocksParams& params,
                    Task& task)
{
    BakeSettings s = params.bake.settings();
    s.withAttribute = true;
    s.attributeName = "block_id";
    FieldPtr field;
    if (params.aperiodic) {
        // The cubes [0, periods) of the aperiodic tiling of the tile's parameters.
        auto tiles = std::make_shared<const AperiodicTiles>(tile->params, params.colours);
        const auto& P = params.periods;
        field = aperiodicField(tiles, {0, 0, 0}, {P[0] - 1, P[1] - 1, P[2] - 1}, task);
    } else {
        TileFieldOptions opt;
        opt.periods = params.periods;
        field = tileField(tile, opt);
    }
    BakeResult r = bake(*field, s, task.interrupter());
    task.check();
    r.surface->insertMeta("rockvdb:tile", openvdb::StringMetadata(jsonText(tileToJson(*tile))));
    return r;
}

// Every block's own level set, meshed in its home frame: one triangle group per block, its
// points carrying block_id. The blocks are baked and meshed in parallel (each bake is
// parallel too) and appended in block order, so the file is the same whatever the threads.
Mesh blockMeshes(const std::shared_ptr<const BlockTile>& tile, const BakeSettings& one,
                 double adaptivity, Task& task)
{
    const size_t n = tile->blocks.size();
    std::vector<Mesh> parts(n);
    std::atomic<size_t> done{0};
    tbb::parallel_for(size_t(0), n, [&](size_t j) {
        task.check();
        parts[j] = meshLevelSet(*bake(*blockField(tile, j), one).surface, 0.0, adaptivity);
        parts[j].pointIds.emplace_back("block_id", std::vector<int>(parts[j].points.size(), int(j)));
        task.advance(double(++done) / double(std::max<size_t>(n, 1)));
    });
    Mesh all;
    all.groupName = "block";
    for (size_t j = 0; j < n; ++j) appendMesh(all, parts[j], int(j));
    return all;
}

// Table 1 of the paper, as vdb_blocks prints it.
std::vector<std::string> tileReport(const BlockTile& tile)
{
    const BlockTileStats& s = tile.stats;
    char line[512];
    std::vector<std::string> out;
    std::snprintf(line, sizeof line,
                  "%s tile %g m: #P %zu points, #D %zu discs, #B %zu blocks, mean #Pi %.1f "
                  "(%zu edges, %zu cut; %zu visibility splits, %zu wrap cuts; dropped %zu "
                  "clusters, %zu points; merged %zu, %zu small blocks)",
                  blockTypeName(tile.params.type), tile.size(), s.points, s.discs, s.blocks,
                  s.meanPoints, s.edges, s.cutEdges, s.visibilitySplits, s.wrapCuts,
                  s.droppedClusters, s.droppedPoints, s.mergedClusters, s.smallBlocks);
    out.push_back(line);
    std::snprintf(line, sizeof line,
                  "sampling %.3f s, graph %.3f s, fracturing %.3f s, clustering %.3f s, "
                  "hulls %.3f s", s.sampling, s.graph, s.fracturing, s.clustering, s.hulls);
    out.push_back(line);
    std::snprintf(line, sizeof line, "generation: %.3f s", s.generation);
    out.push_back(line);
    return out;
}

json tileTimes(const BlockTileStats& s)
{
    return {{"sampling", s.sampling}, {"graph", s.graph}, {"fracturing", s.fracturing},
            {"clustering", s.clustering}, {"hulls", s.hulls}, {"generation", s.generation}};
}

} // namespace

BlocksResult runBlocks(const BlocksParams& params, const BlocksInputs& inputs, Task& task)
{
    blocksSchema().validate(params);
    if (inputs.meshes && params.aperiodic) {
        fail<ValueError>("blocks: block meshes are the periodic tile's; mesh them from a run "
                         "without aperiodic");
    }
    require(std::isfinite(inputs.meshAdaptivity) && inputs.meshAdaptivity >= 0 &&
                inputs.meshAdaptivity <= 1, "blocks", "mesh-adaptivity", "in [0, 1]",
            inputs.meshAdaptivity);
    if (inputs.meshes && !params.bake.chunking.chunk.empty()) {
        fail<ValueError>("blocks: block meshes describe the whole tile; mesh them from a run "
                         "without chunk");
    }
    const double tileSize = inputs.tile ? inputs.tile->size() : params.tile.tileSize;
    BlockTileParams resolved = params.tile; // derived defaults filled (the warp amplitude)
    resolved.resolveDefaults();
    const double amplitude =
        inputs.tile ? inputs.tile->params.relief.amplitude : resolved.relief.amplitude;
    // The bake settings are checked before generating: a bad voxel size fails at once.
    if (inputs.bake) checkVoxel(tileSize, amplitude, params.bake.settings());

    BlocksResult r;
    if (inputs.tile) {
        r.tile = inputs.tile;
    } else {
        task.phase("generation", inputs.bake ? 0.3 : 1.0);
        r.tile = makeTile(params.tile, task);
        r.report = tileReport(*r.tile);
        r.stats["tile_seconds"] = tileTimes(r.tile->stats);
    }
    r.stats["tile"] = r.tile->stats.toJson();
    if (inputs.bake) {
        task.phase("bake", inputs.meshes ? 0.5 : 0.7);
        r.bake = bakeTile(r.tile, params, task);
        r.stats["bake"] = bakeStatsJson(r.bake.stats);
        r.report.push_back(bakeReport(r.bake.stats));
        // Provenance: the table with the tile's own (resolved) parameters, and the inputs.
        BlocksParams used = params;
        used.tile = r.tile->params;
        stampResult(r, kBlocksTool, {r.bake.surface, r.bake.attribute},
                    stageProvenance(blocksSchema().toJson(used), inputs.source));
    }
    if (inputs.meshes) {
        task.phase("meshes", 0.2);
        r.meshes = blockMeshes(r.tile, params.bake.settings(), inputs.meshAdaptivity, task);
        r.report.push_back("meshed " + std::to_string(r.tile->blocks.size()) + " blocks");
    }
    task.done();
    r.stats["phases"] = phasesJson(task);
    return r;
}

} // namespace blocks
} // namespace rockvdb
