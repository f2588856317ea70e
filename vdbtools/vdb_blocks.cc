// SPDX-License-Identifier: Apache-2.0
// vdb_blocks — fractured block tiles (implicit-blocks-rocky-scenery.txt §4). Options from the
// stage's table, the work in runBlocks (BlocksStage.h), which rockvdb.block_tile runs too.
#include "Cli.h"

#include <rockvdb/blocks/BlocksStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>

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
    std::string tileOut, fromTile, meshes, up;
    app.add_option("--tile", tileOut, "Also write the tile description to this .tile file")
        ->check(cli::writes({".tile", ".json"}));
    app.add_option("--from-tile", fromTile,
                   "Bake an existing tile (.tile or a vdb_blocks .vdb) instead of generating one "
                   "(the tile's own parameters replace the tile options)");
    app.add_option("--meshes", meshes, "Write one mesh per block (home frame) to .obj or .ply")
        ->check(cli::writes({".obj", ".ply"}));
    tool.addUpAxis(app, "--up", up, "the --meshes file");
    double meshAdaptivity = BlocksInputs().meshAdaptivity;
    auto* adaptivityOpt = app.add_option("--mesh-adaptivity", meshAdaptivity,
                   "The --meshes' adaptivity (OpenVDB's volumeToMesh): 0 = one quad per surface "
                   "voxel .. 1 = fewest polygons; the default merges the blocks' flat faces")
        ->capture_default_str();
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addStats(app);
    tool.addDistribution(app);

    return tool.run(argc, argv, [&] {
        const BlocksParams p = blocksSchema().fromJson(tool.givenParams(blocksSchema()));
        const UpAxis upAxis = upAxisFromString(up, "blocks: --up");
        cli::distinctOutputs({{"-o", tool.output()}, {"--tile", tileOut}, {"--meshes", meshes}});
        if (!p.bake.chunking.chunk.empty() && !tileOut.empty()) {
            fail<ValueError>("blocks: --tile describes the whole tile; write it from a run "
                             "without --chunk");
        }
        for (const auto& path : {tileOut, meshes}) {
            if (!path.empty()) requireWritable(path);
        }
        BlocksInputs in;
        if (!fromTile.empty()) {
            in.tile = std::make_shared<const BlockTile>(readTile(fromTile));
            in.source = {{"from-tile", fromTile}};
        }
        in.meshes = !meshes.empty();
        in.meshAdaptivity = meshAdaptivity;
        if (adaptivityOpt->count() > 0 && meshes.empty()) {
            fail<ValueError>("blocks: --mesh-adaptivity applies to --meshes");
        }
        const BlocksResult r = tool.stage([&](Task& task) { return runBlocks(p, in, task); });
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
        // The tile file after the grids: a failed bake leaves no file at all.
        if (!tileOut.empty()) writeTile(*r.tile, tileOut);
        if (!meshes.empty()) writeMesh(r.meshes, meshes, upAxis);
    });
}
