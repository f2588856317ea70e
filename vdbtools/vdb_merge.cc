// SPDX-License-Identifier: Apache-2.0
// vdb_merge — merge the chunks of one bake (--region or --chunk, leaf aligned) into one file:
// the work is mergeChunkFiles (core/MergeFiles.h).
#include "Cli.h"

#include <rockvdb/core/MergeFiles.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_merge",
        "Merge chunk files of one bake (each baked with --region or --chunk i/N; chunks aligned "
        "to 8-voxel leaf boundaries) into the whole: every grid (surface, block_id, material, "
        "...) is matched by name across the chunks, their voxels are united, and level sets get "
        "their inside/outside tiles back by signed flood fill. Leaf-aligned chunks merge to "
        "exactly the whole bake. Chunks must hold the same grids with the same transform; a "
        "voxel active in two chunks must have the same value in both. Chunks read one at a "
        "time (memory: one chunk beside the result). When the inputs are the N chunks i/N of "
        "one bake, all of them are required and the result carries that bake's own provenance "
        "(it replays to the same grids in one process); otherwise the provenance lists the "
        "sources.");
    CLI::App& app = tool.app();
    std::vector<std::string> inputs;
    std::string manifest;
    auto* in = app.add_option("inputs", inputs, "Chunk .vdb files ('-' = stdin, once)")
        ->expected(1, 1 << 20);
    app.add_option("--manifest", manifest,
                   "The manifest.json of a chunk folder (rockvdb.distributed, --keep-chunks): "
                   "its chunks, each checked against its CRC-32 first")->excludes(in);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    return tool.run(argc, argv, [&] {
        if (!manifest.empty()) inputs = manifestChunks(manifest);
        const StageResult r = mergeChunkFiles(inputs, tool.name(), nlohmann::json::parse(tool.paramsJson()));
        tool.finish(r);
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
    });
}
