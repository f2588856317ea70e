// vdb_amplify — terrain amplification by block replication (implicit-blocks §5).
#include "Cli.h"

#include <amplify/Amplify.h>
#include <blocks/BlockTile.h>
#include <core/Error.h>
#include <core/Expression.h>
#include <core/Image.h>
#include <core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_amplify",
        "Amplify a terrain with fractured blocks (Paris et al., sec. 5): the blocks of a "
        "vdb_blocks tile virtually tile space, and a copy of block i in cell c is kept when more "
        "than --fraction of its anchors lie within --distance-range of the terrain surface on "
        "ground steeper than --max-slope (|g.u_z| < max-slope). The kept copies are united with "
        "the terrain. Writes 'surface', 'block_id' (block index, -1 on bare terrain) and "
        "'material' (0 on bare terrain, 1 + the tile's index on its blocks). With several tiles a strata "
        "file chooses the tile by elevation (the material of sec. 5). The heightfield "
        "convention is vdb_heightfield's.");
    CLI::App& app = tool.app();
    std::string terrain, strataFile;
    std::vector<std::string> tiles;
    bool mixedSizes = false;
    double cellSize = 1.0, heightScale = 1.0, baseDepth = 1.0;
    amplify::PlacementRules rules;
    std::vector<double> range{rules.distanceMin, rules.distanceMax};
    app.add_option("--terrain", terrain,
                   "Heightfield .exr / 16-bit .png, a procedural heightfield .json (a sea_cliff, "
                   "noise_terrain or heightfield node, as vdb_primitive expr reads), or a "
                   "terrain level set .vdb ('-' = a .vdb on stdin)")->required();
    std::string terrainGrid = "surface";
    app.add_option("--terrain-grid", terrainGrid, "Level-set grid name in a .vdb terrain")
        ->capture_default_str();
    app.add_option("--cell-size", cellSize, "Heightfield: distance between pixel centres (m)")
        ->capture_default_str();
    app.add_option("--height-scale", heightScale, "Heightfield: metres per image unit")
        ->capture_default_str();
    app.add_option("--base-depth", baseDepth, "Heightfield: floor depth below the lowest sample (m)")
        ->capture_default_str();
    app.add_option("--tiles", tiles,
                   "Block tiles (.tile or vdb_blocks .vdb), comma-separated; strata name them by "
                   "file stem")->delimiter(',')->required();
    app.add_option("--strata", strataFile,
                   "Strata JSON: {\"normal\": [0,0,1], \"noise\": {\"amplitude\": 1, "
                   "\"frequency\": 0.05}, \"layers\": [{\"tile\": \"equi\", \"top\": 12}, "
                   "{\"tile\": \"tabular\"}]} (needed for several tiles)");
    app.add_flag("--mixed-tile-sizes", mixedSizes, "Allow tiles of different sizes");
    std::vector<double> roi;
    app.add_option("--roi", roi,
                   "Region of interest xmin,ymin,zmin,xmax,ymax,zmax (m): only anchors inside "
                   "count (heightfields: also within the footprint)")->delimiter(',')->expected(6);
    std::string mask;
    double maskCell = 0.0;
    app.add_option("--mask", mask,
                   "Mask image (EXR / 16-bit PNG) over the terrain's xy: blocks only where it "
                   "reads >= 0.5 (PNG: >= 32768)");
    app.add_option("--mask-cell-size", maskCell,
                   "Mask pixel spacing (m; 0 = the heightfield's --cell-size)")->capture_default_str();
    double carve = 0.0;
    app.add_option("--carve", carve,
                   "Carving variant: blocks replace the terrain's skin where present, the terrain "
                   "cut back to the blocks dilated by this gap (m; 0 = plain union)")
        ->capture_default_str();
    app.add_option("--max-slope", rules.maxSlope, "epsilon: replicate where |g.u_z| < this")
        ->capture_default_str();
    app.add_option("--distance-range", range, "[va, vb]: anchor distance to the surface (m)")
        ->delimiter(',')->expected(2)->capture_default_str();
    app.add_option("--anchors", rules.anchors, "Anchors tested per block (<= 16)")->capture_default_str();
    app.add_option("--fraction", rules.fraction, "Share of anchors that must pass (more than)")
        ->capture_default_str();
    tool.addBakeOptions(app);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        using Clock = std::chrono::steady_clock;
        const auto t0 = Clock::now();
        BakeSettings settings = tool.bake().settings();
        rules.distanceMin = range[0];
        rules.distanceMax = range[1];
        rules.validate();
        if (tiles.size() > 1 && strataFile.empty()) {
            fail<ValueError>("amplify: ", tiles.size(), " tiles need --strata to say where each "
                             "one goes");
        }
        std::vector<std::shared_ptr<const blocks::BlockTile>> loaded;
        std::vector<std::string> names;
        for (const auto& t : tiles) {
            loaded.push_back(std::make_shared<const blocks::BlockTile>(blocks::readTile(t)));
            std::string stem = t.substr(t.find_last_of('/') + 1);
            names.push_back(stem.substr(0, stem.find_last_of('.')));
        }
        amplify::checkTileSizes(loaded, mixedSizes);
        std::unique_ptr<amplify::Strata> strata;
        if (!strataFile.empty()) {
            strata = std::make_unique<amplify::Strata>(
                amplify::Strata::fromJson(readJsonFile(strataFile), names));
        }
        FieldPtr ground;
        auto endsWith = [&](const char* ext) {
            const std::string e(ext);
            return terrain.size() > e.size() && terrain.substr(terrain.size() - e.size()) == e;
        };
        if (endsWith(".vdb") || terrain == "-") {
            ground = amplify::levelSetTerrain(readLevelSet(terrain, terrainGrid), rules);
        } else if (endsWith(".json")) {
            // A procedural heightfield (sea_cliff, noise_terrain, heightfield): its exact
            // distance and footprint, as for an image.
            ExpressionContext ctx;
            const auto slash = terrain.find_last_of('/');
            ctx.baseDir = slash == std::string::npos ? "." : terrain.substr(0, slash);
            auto node = heightfieldFromJson(readJsonFile(terrain), ctx);
            if (!node) {
                fail<ValueError>("amplify: a JSON terrain must be a heightfield node (sea_cliff, "
                                 "noise_terrain or heightfield); bake other expressions with "
                                 "vdb_primitive expr and pass the .vdb (", terrain, ")");
            }
            cellSize = node->heightfield->cellSize;
            ground = amplify::heightfieldTerrain(node->heightfield, node->baseDepth, rules);
        } else {
            ground = amplify::heightfieldTerrain(
                std::make_shared<Heightfield>(loadHeightfield(terrain, cellSize, heightScale)),
                baseDepth, rules);
        }
        if (!roi.empty()) {
            rules.restrictTo(BBoxd(Vec3d(roi[0], roi[1], roi[2]), Vec3d(roi[3], roi[4], roi[5])));
        }
        if (!mask.empty()) {
            rules.mask = std::make_shared<const GrayImage>(readGrayImage(mask, "mask"));
            rules.maskCellSize = maskCell > 0 ? maskCell : cellSize;
            rules.validate();
        }
        require(std::isfinite(carve) && carve >= 0 && carve < 10, "amplify", "carve gap",
                "in [0, 10) m", carve);
        const double loadSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

        amplify::AmplifyStats stats;
        auto field = amplify::amplifiedTerrain(ground, loaded, rules, stats, strata.get(), carve);
        if (stats.replicated == 0) {
            tool.info("no block qualifies (flat terrain or rules too strict): writing the bare "
                      "terrain");
        }
        auto bar = tool.progress("baking");
        amplify::AmplifyResult r = amplify::bakeAmplified(*field, settings, stats, bar.get());
        bar->end();
        const std::string params = tool.paramsJson();
        for (const auto& g : {r.surface, r.blockId, r.material}) {
            stampProvenance(*g, tool.name(), params);
        }
        const auto tw = Clock::now();
        writeGrids(tool.output(), {r.surface, r.blockId, r.material});
        for (const auto& line : amplify::describe(stats)) tool.info(line);
        char line[160];
        std::snprintf(line, sizeof line, "io: load %.3f s, write %.3f s; total %.3f s", loadSeconds,
                      std::chrono::duration<double>(Clock::now() - tw).count(),
                      std::chrono::duration<double>(Clock::now() - t0).count());
        tool.info(line);
    });
}
