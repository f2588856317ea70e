// SPDX-License-Identifier: Apache-2.0
#include "AmplifyStage.h"

#include <rockvdb/blocks/BlocksStage.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

namespace rockvdb {
namespace amplify {

using nlohmann::json;

namespace {

Schema<AmplifyParams> makeSchema()
{
    using P = AmplifyParams;
    const PlacementRules rules; // the presence rules' defaults live there (Amplify.h)
    Schema<P> s("amplify",
        "Amplify a terrain with fractured blocks (Paris et al., §5): the blocks of a tile "
        "virtually tile space, and a copy of block i in cell c is kept when more than fraction "
        "of its anchors lie within distance-range of the terrain surface on ground steeper "
        "than max-slope (|g.u_z| < max-slope). The kept copies are united with the terrain.");
    s.member(param("terrain-grid", ParamType::Text, "", "surface", Range::any(),
                 "Level-set grid name in a .vdb terrain"), &P::terrainGrid);
    s.member(param("cell-size", ParamType::Real, "m", 1.0, Range::openClosed(0, 1e6),
                 "Heightfield: distance between pixel centres"), &P::cellSize);
    s.member(param("height-scale", ParamType::Real, "", 1.0, Range::closed(-1e6, 1e6),
                 "Heightfield: metres per image unit"), &P::heightScale);
    s.member(param("base-depth", ParamType::Real, "m", 1.0, Range::openClosed(0, 1e6),
                 "Heightfield: floor depth below the lowest sample"), &P::baseDepth);
    s.add(param("strata", ParamType::Json, "", nullptr, Range::any(),
              "Strata, a JSON file (or object): {\"normal\": [0,0,1], \"noise\": {\"amplitude\": "
              "1, \"frequency\": 0.05}, \"layers\": [{\"tile\": \"equi\", \"top\": 12}, "
              "{\"tile\": \"tabular\"}]}, layers naming tiles by file stem (or index); needed "
              "for several tiles"),
          [](const P& p) { return p.strata; },
          [](P& p, const json& j) { p.strata = jsonOrFile(j); });
    s.member(param("mixed-tile-sizes", ParamType::Bool, "", false, Range::any(),
                 "Allow tiles of different sizes"), &P::mixedTileSizes);
    s.member(param("roi", ParamType::Reals, "m", nullptr, Range::closed(-1e9, 1e9),
                 "Region of interest xmin,ymin,zmin,xmax,ymax,zmax: only anchors inside count "
                 "(heightfields: also within the footprint)", 6), &P::roi);
    s.member(param("mask-cell-size", ParamType::Real, "m", 0.0, Range::closed(0, 1e6),
                 "Mask pixel spacing (0 = the heightfield's cell size)"), &P::maskCellSize);
    s.member(param("carve", ParamType::Real, "m", 0.0, Range::halfOpen(0, 10),
                 "Carving variant: blocks replace the terrain's skin where present, the terrain "
                 "cut back to the blocks dilated by this gap (0 = plain union)"), &P::carve);
    blocks::addAperiodicRows(s, &P::aperiodic, &P::colours, " (one tile, no strata)");
    s.add(param("max-slope", ParamType::Real, "", rules.maxSlope, Range::closed(0, 1),
              "epsilon: replicate where |g.u_z| < this"),
          [](const P& p) { return json(p.rules.maxSlope); },
          [](P& p, const json& j) { p.rules.maxSlope = j.get<double>(); });
    s.add(param("distance-range", ParamType::Reals, "m",
              json::array({rules.distanceMin, rules.distanceMax}), Range::closed(-1e4, 1e4),
              "[va, vb]: anchor distance to the surface", 2),
          [](const P& p) { return json::array({p.rules.distanceMin, p.rules.distanceMax}); },
          [](P& p, const json& j) {
              p.rules.distanceMin = j.at(0).get<double>();
              p.rules.distanceMax = j.at(1).get<double>();
          });
    s.add(param("anchors", ParamType::Int, "", rules.anchors, Range::closed(1, 16),
              "Anchors tested per block"),
          [](const P& p) { return json(p.rules.anchors); },
          [](P& p, const json& j) { p.rules.anchors = j.get<int>(); });
    s.add(param("fraction", ParamType::Real, "", rules.fraction, Range::halfOpen(0, 1),
              "Share of anchors that must pass (more than)"),
          [](const P& p) { return json(p.rules.fraction); },
          [](P& p, const json& j) { p.rules.fraction = j.get<double>(); });
    addBakeRows(s, &P::bake, defaultVoxelSize(), defaultHalfWidth());
    s.rule([](const P& p) {
        if (p.rules.distanceMin > p.rules.distanceMax) {
            fail<ValueError>("amplify: distance-range needs va <= vb (got ", p.rules.distanceMin,
                             ", ", p.rules.distanceMax, ")");
        }
    });
    // Front-ends' groups (the Blender add-on's sub-panels); the rest is Shape.
    s.group("Input", {"terrain-grid", "cell-size", "height-scale", "base-depth"});
    s.group("Placement", {"roi", "mask-cell-size", "carve", "max-slope", "distance-range",
                          "anchors", "fraction"});
    return s;
}

bool endsWith(const std::string& s, const char* ext)
{
    const std::string e(ext);
    return s.size() > e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

} // namespace

const Schema<AmplifyParams>& amplifySchema()
{
    static const Schema<AmplifyParams> s = makeSchema();
    return s;
}

AmplifyParams::AmplifyParams() { amplifySchema().reset(*this); }

AmplifyRun runAmplify(const AmplifyParams& params, const AmplifyInputs& in, Task& task)
{
    amplifySchema().validate(params);
    const BakeSettings settings = params.bake.settings();
    PlacementRules rules = params.rules;
    rules.validate();
    if (in.tiles.empty()) fail<ValueError>("amplify: at least one tile is required");
    if (in.tiles.size() > 1 && params.strata.is_null()) {
        fail<ValueError>("amplify: ", in.tiles.size(), " tiles need strata (--strata, strata=) "
                         "to say where each one goes");
    }
    checkTileSizes(in.tiles, params.mixedTileSizes);
    std::shared_ptr<const blocks::AperiodicTiles> aperiodic;
    if (params.aperiodic) {
        if (in.tiles.size() > 1 || !params.strata.is_null()) {
            fail<ValueError>("amplify: --aperiodic takes one tile and no strata");
        }
        aperiodic = std::make_shared<blocks::AperiodicTiles>(in.tiles[0]->params, params.colours);
    }
    std::unique_ptr<Strata> strata;
    if (!params.strata.is_null()) {
        std::vector<std::string> names = in.tileNames;
        for (size_t i = names.size(); i < in.tiles.size(); ++i) names.push_back(std::to_string(i));
        strata = std::make_unique<Strata>(Strata::fromJson(params.strata, names));
    }

    // The terrain: a level set, a procedural heightfield (.json), or a heightfield image.
    FieldPtr ground;
    double cellSize = params.cellSize;
    const std::string& path = in.terrainPath;
    if (in.terrainGrid) {
        ground = levelSetTerrain(in.terrainGrid, rules, settings.maxMemoryBytes);
    } else if (endsWith(path, ".vdb") || path == "-") {
        ground = levelSetTerrain(readLevelSet(path, params.terrainGrid), rules, settings.maxMemoryBytes);
    } else if (endsWith(path, ".json")) {
        ExpressionContext ctx;
        const auto slash = path.find_last_of('/');
        ctx.baseDir = slash == std::string::npos ? "." : path.substr(0, slash);
        auto node = heightfieldFromJson(readJsonFile(path), ctx);
        if (!node) {
            fail<ValueError>("amplify: a JSON terrain must be a heightfield node (sea_cliff, "
                             "noise_terrain or heightfield); bake other expressions with "
                             "vdb_primitive expr and pass the .vdb (", path, ")");
        }
        cellSize = node->heightfield->cellSize;
        ground = heightfieldTerrain(node->heightfield, node->baseDepth, rules);
    } else if (!path.empty()) {
        ground = heightfieldTerrain(
            std::make_shared<Heightfield>(loadHeightfield(path, cellSize, params.heightScale,
                                                          settings.maxMemoryBytes)),
            params.baseDepth, rules);
    } else {
        fail<ValueError>("amplify: the terrain is required");
    }
    if (params.roi) {
        const auto& r = *params.roi;
        rules.restrictTo(BBoxd(Vec3d(r[0], r[1], r[2]), Vec3d(r[3], r[4], r[5])));
    }
    if (in.mask) {
        rules.mask = in.mask;
        rules.maskCellSize = params.maskCellSize > 0 ? params.maskCellSize : cellSize;
        rules.validate();
    }

    AmplifyRun r;
    task.phase("presence", 0.3);
    const AmplifiedParts parts = amplifiedParts(ground, in.tiles, rules, r.counts, strata.get(),
                                                params.carve, &task, aperiodic);
    task.phase("bake", 0.7);
    r.amplified = bakeAmplified(parts, settings, r.counts, task.interrupter());
    task.check();
    stampResult(r, kAmplifyTool, {r.amplified.surface, r.amplified.blockId, r.amplified.material},
                stageProvenance(amplifySchema().toJson(params), in.names));
    task.done();
    const AmplifyStats& s = r.counts;
    if (s.replicated == 0) {
        r.report.push_back("no block qualifies (flat terrain or rules too strict): wrote the "
                           "bare terrain");
    }
    for (const auto& line : describe(s)) r.report.push_back(line);
    r.stats = {{"replicated", s.replicated}, {"cells", s.cells}, {"block_field_bytes", s.blockBytes},
               {"active_voxels", s.bake.activeVoxels}, {"presence_seconds", s.presenceSeconds},
               {"bake_seconds", s.bakeSeconds}, {"split_seconds", s.splitSeconds},
               {"bake", bakeStatsJson(s.bake)}, {"phases", phasesJson(task)}};
    return r;
}

} // namespace amplify
} // namespace rockvdb
