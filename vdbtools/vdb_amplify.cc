// vdb_amplify — terrain amplification by block replication (implicit-blocks §5).
#include "Cli.h"

#include <amplify/Amplify.h>
#include <blocks/BlockTile.h>
#include <core/Error.h>
#include <core/Expression.h>
#include <core/GridField.h>
#include <core/Image.h>
#include <core/Heightfield.h>
#include <core/VdbIO.h>

#include <nlohmann/json.hpp>

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
        "'material' (tile index of the block, -1 on bare terrain). With several tiles a strata "
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
                   "Heightfield .exr / 16-bit .png, or a terrain level set .vdb")->required();
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
            if (!mixedSizes && loaded.back()->size() != loaded.front()->size()) {
                fail<ValueError>("amplify: tile sizes differ (", loaded.front()->size(), " m and ",
                                 loaded.back()->size(), " m); pass --mixed-tile-sizes to allow it");
            }
        }
        std::unique_ptr<amplify::Strata> strata;
        if (!strataFile.empty()) {
            strata = std::make_unique<amplify::Strata>(
                amplify::Strata::fromJson(readJsonFile(strataFile), names));
        }
        const double exact =
            std::max(1.0, std::max(std::abs(rules.distanceMin), std::abs(rules.distanceMax)) + 0.5);
        FieldPtr ground;
        const bool isVdb = terrain.size() > 4 && terrain.substr(terrain.size() - 4) == ".vdb";
        if (isVdb) {
            // A 3D terrain level set (overhangs, arches): its band widened to the rules' reach.
            ground = levelSetField(readLevelSet(terrain, terrainGrid), exact);
        } else {
            auto hf = std::make_shared<Heightfield>(loadHeightfield(terrain, cellSize, heightScale));
            HeightfieldSettings hs;
            hs.baseDepth = baseDepth;
            hs.exactDistance = exact;
            ground = heightfieldField(hf, hs);
            // Anchors must stand over the footprint (1 m in from its edge): the closed
            // solid's vertical side walls are not terrain.
            rules.region = BBoxd(Vec3d(1.0, 1.0, -1e30),
                                 Vec3d(hf->width() - 1.0, hf->depth() - 1.0, 1e30));
        }
        if (!roi.empty()) {
            for (int a = 0; a < 3; ++a) {
                require(std::isfinite(roi[size_t(a)]) && std::isfinite(roi[size_t(a) + 3]) &&
                            roi[size_t(a)] < roi[size_t(a) + 3],
                        "amplify", "roi", "finite with min < max on every axis",
                        std::to_string(roi[size_t(a)]) + ".." + std::to_string(roi[size_t(a) + 3]));
            }
            const BBoxd user(Vec3d(roi[0], roi[1], roi[2]), Vec3d(roi[3], roi[4], roi[5]));
            rules.region = BBoxd(maxComponent(rules.region.min(), user.min()),
                                 minComponent(rules.region.max(), user.max()));
        }
        if (!mask.empty()) {
            rules.mask = std::make_shared<const GrayImage>(readGrayImage(mask, "mask"));
            rules.maskCellSize = maskCell > 0 ? maskCell : cellSize;
            rules.validate();
        }
        amplify::AmplifyStats stats;
        require(std::isfinite(carve) && carve >= 0 && carve < 10, "amplify", "carve gap",
                "in [0, 10) m", carve);
        auto field = amplify::amplifiedTerrain(ground, loaded, rules, stats, strata.get(), carve);
        char line[256];
        std::snprintf(line, sizeof line, "#R %zu replicated blocks (%zu cells examined, presence "
                      "%.3f s); block fields %.2f MB", stats.replicated, stats.cells,
                      stats.presenceSeconds, stats.blockBytes / 1e6);
        tool.info(line);
        if (stats.replicated == 0) {
            tool.info("no block qualifies (flat terrain or rules too strict): writing the bare "
                      "terrain");
        }
        settings.withAttribute = true;
        settings.attributeName = "block_id";
        auto bar = tool.progress("baking");
        BakeResult r = bake(*field, settings, bar.get());
        bar->end();
        auto material = amplify::splitMaterial(*r.attribute);
        std::snprintf(line, sizeof line, "bake: %zu active voxels, cull %.3f s, fill %.3f s",
                      r.stats.activeVoxels, r.stats.cullSeconds, r.stats.fillSeconds);
        tool.info(line);
        const std::string params = tool.paramsJson();
        for (const auto& g : {r.surface, r.attribute, material}) {
            stampProvenance(*g, tool.name(), params);
        }
        writeGrids(tool.output(), {r.surface, r.attribute, material});
    });
}
