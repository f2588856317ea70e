// vdb_blocks — fractured block tiles (implicit-blocks-rocky-scenery.txt §4). Options from the
// stage's table, work in runBlocks / bakeTile (BlocksStage.h).
#include "Cli.h"

#include <rockvdb/blocks/BlocksStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>

#include <cstdio>

using namespace rockvdb;
using namespace rockvdb::blocks;

int main(int argc, char** argv)
{
    cli::Tool tool(kBlocksTool, blocksSchema().summary() +
        " Writes grid 'surface' and grid 'block_id' (float ids), the tile description as "
        "metadata 'rockvdb:tile' (and with --tile as a standalone .tile file, what vdb_amplify "
        "reads), and statistics like the paper's Table 1 on stderr, ending with the line "
        "'vdb_blocks: generation: N.NNN s' (sampling through hulls). The output's "
        "rockvdb:params replays it: vdb_blocks --params FILE -o OUT.");
    CLI::App& app = tool.app();
    tool.addParams(app, blocksSchema());
    std::string tileOut, fromTile, meshes, up = "z";
    app.add_option("--tile", tileOut, "Also write the tile description to this .tile file");
    app.add_option("--from-tile", fromTile,
                   "Bake an existing tile (.tile or a vdb_blocks .vdb) instead of generating one "
                   "(the tile's own parameters replace the tile options)");
    app.add_option("--meshes", meshes, "Write one mesh per block (home frame) to .obj or .ply");
    app.add_option("--up", up, "Up axis of the --meshes file: z (rockvdb) or y (Blender's OBJ "
                               "import default, Houdini)")->capture_default_str();
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addDistribution(app);

    return tool.run(argc, argv, [&] {
        const BlocksParams p = blocksSchema().fromJson(tool.givenParams(blocksSchema()));
        const UpAxis upAxis = upAxisFromString(up, "blocks: --up");
        cli::distinctOutputs({{"-o", tool.output()}, {"--tile", tileOut}, {"--meshes", meshes}});
        if (!p.bake.chunking.chunk.empty() && (!tileOut.empty() || !meshes.empty())) {
            fail<ValueError>("blocks: --tile and --meshes describe the whole tile; write them from "
                             "a run without --chunk");
        }
        for (const auto& path : {tileOut, meshes}) {
            if (!path.empty()) requireWritable(path);
        }
        auto bar = tool.taskBar();
        Task task(bar.get());
        BlocksResult r;
        if (!fromTile.empty()) {
            task.phase("bake", 1.0);
            r = bakeTile(std::make_shared<const BlockTile>(readTile(fromTile)), p,
                         {{"from-tile", fromTile}}, task);
            task.done();
        } else {
            r = runBlocks(p, task);
        }
        bar->clear();
        if (fromTile.empty()) {
            const BlockTileStats& s = r.tile->stats;
            char line[512];
            std::snprintf(line, sizeof line,
                          "%s tile %g m: #P %zu points, #D %zu discs, #B %zu blocks, mean #Pi %.1f "
                          "(%zu edges, %zu cut; %zu visibility splits, %zu wrap cuts; dropped %zu "
                          "clusters, %zu points; merged %zu, %zu small blocks)",
                          blockTypeName(r.tile->params.type), r.tile->size(), s.points, s.discs,
                          s.blocks, s.meanPoints, s.edges, s.cutEdges, s.visibilitySplits,
                          s.wrapCuts, s.droppedClusters, s.droppedPoints, s.mergedClusters,
                          s.smallBlocks);
            tool.info(line);
            std::snprintf(line, sizeof line,
                          "sampling %.3f s, graph %.3f s, fracturing %.3f s, clustering %.3f s, "
                          "hulls %.3f s", s.sampling, s.graph, s.fracturing, s.clustering, s.hulls);
            tool.info(line);
            std::snprintf(line, sizeof line, "generation: %.3f s", s.generation);
            tool.info(line);
        }
        const BakeStats& b = r.bake.stats;
        char line[256];
        std::snprintf(line, sizeof line, "bake: %zu active voxels, cull %.3f s, fill %.3f s, "
                      "finish %.3f s", b.activeVoxels, b.cullSeconds, b.fillSeconds, b.finishSeconds);
        tool.info(line);
        writeGrids(tool.output(), {r.bake.surface, r.bake.attribute});
        // The tile file after the grids: a failed bake leaves no file at all.
        if (!tileOut.empty()) writeTile(*r.tile, tileOut);
        if (!meshes.empty()) {
            Mesh all;
            all.groupName = "block";
            const BakeSettings one = p.bake.settings();
            for (size_t j = 0; j < r.tile->blocks.size(); ++j) {
                task.check();
                auto g = bake(*blockField(r.tile, j), one).surface;
                appendMesh(all, meshLevelSet(*g), int(j));
            }
            writeMesh(all, meshes, upAxis);
            tool.info("wrote " + std::to_string(r.tile->blocks.size()) + " block meshes to " + meshes);
        }
    });
}
