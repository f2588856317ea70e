// vdb_amplify — terrain amplification by block replication (implicit-blocks §5).
#include "Cli.h"

#include <amplify/Amplify.h>
#include <blocks/BlockTile.h>
#include <core/Error.h>
#include <core/Heightfield.h>
#include <core/VdbIO.h>

#include <cstdio>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_amplify",
        "Amplify a terrain with fractured blocks (Paris et al., sec. 5): the blocks of a "
        "vdb_blocks tile virtually tile space, and a copy of block i in cell c is kept when more "
        "than --fraction of its anchors lie within --distance-range of the terrain surface on "
        "ground steeper than --max-slope (|g.u_z| < max-slope). The kept copies are united with "
        "the terrain. Writes 'surface', 'block_id' (block index, -1 on bare terrain) and "
        "'material' (tile index of the block, -1 on bare terrain). The heightfield convention "
        "is vdb_heightfield's.");
    CLI::App& app = tool.app();
    std::string terrain;
    std::vector<std::string> tiles;
    double cellSize = 1.0, heightScale = 1.0, baseDepth = 1.0;
    amplify::PlacementRules rules;
    std::vector<double> range{rules.distanceMin, rules.distanceMax};
    app.add_option("--terrain", terrain, "Heightfield .exr / 16-bit .png")->required();
    app.add_option("--cell-size", cellSize, "Heightfield: distance between pixel centres (m)")
        ->capture_default_str();
    app.add_option("--height-scale", heightScale, "Heightfield: metres per image unit")
        ->capture_default_str();
    app.add_option("--base-depth", baseDepth, "Heightfield: floor depth below the lowest sample (m)")
        ->capture_default_str();
    app.add_option("--tiles", tiles, "Block tile (.tile or vdb_blocks .vdb)")
        ->delimiter(',')->required();
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
        if (tiles.size() != 1) {
            fail<ValueError>("amplify: give exactly one tile (", tiles.size(), " given); several "
                             "tiles need a strata definition, not supported yet");
        }
        auto tile = std::make_shared<const blocks::BlockTile>(blocks::readTile(tiles[0]));
        auto hf = std::make_shared<Heightfield>(loadHeightfield(terrain, cellSize, heightScale));
        HeightfieldSettings hs;
        hs.baseDepth = baseDepth;
        hs.exactDistance = std::max(1.0, std::max(std::abs(rules.distanceMin), std::abs(rules.distanceMax)) + 0.5);
        auto ground = heightfieldField(hf, hs);
        // Anchors must stand over the footprint (1 m in from its edge): the closed solid's
        // vertical side walls are not terrain.
        rules.region = BBoxd(Vec3d(1.0, 1.0, -1e30), Vec3d(hf->width() - 1.0, hf->depth() - 1.0, 1e30));
        amplify::AmplifyStats stats;
        auto field = amplify::amplifiedTerrain(ground, tile, rules, stats);
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
        // material: the tile index wherever a block claims the voxel.
        auto material = r.attribute->deepCopy();
        material->setName("material");
        for (auto it = material->beginValueOn(); it; ++it) {
            if (it.getValue() >= 0) it.setValue(0.0f);
        }
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
