// SPDX-License-Identifier: Apache-2.0
// vdb_amplify — terrain amplification by block replication (implicit-blocks §5). Options from
// the stage's table, work in runAmplify (AmplifyStage.h).
#include "Cli.h"

#include <rockvdb/amplify/AmplifyStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/VdbIO.h>

#include <chrono>
#include <cstdio>

using namespace rockvdb;
using namespace rockvdb::amplify;

int main(int argc, char** argv)
{
    cli::Tool tool(kAmplifyTool, amplifySchema().summary() +
        " Writes 'surface', 'block_id' (block index, -1 on bare terrain) and 'material' (0 on "
        "bare terrain, 1 + the tile's index on its blocks). With several tiles a strata file "
        "chooses the tile by elevation (the material of §5). The heightfield convention is "
        "vdb_heightfield's. The output's rockvdb:params replays it: vdb_amplify --params FILE "
        "-o OUT.");
    CLI::App& app = tool.app();
    std::string terrain, mask;
    std::vector<std::string> tiles;
    app.add_option("--terrain", terrain,
                   "Heightfield .exr / 16-bit .png, a procedural heightfield .json (a sea_cliff, "
                   "noise_terrain or heightfield node, as vdb_primitive expr reads), or a "
                   "terrain level set .vdb ('-' = a .vdb on stdin)")->required();
    app.add_option("--tiles", tiles,
                   "Block tiles (.tile or vdb_blocks .vdb), comma-separated; strata name them by "
                   "file stem")->delimiter(',')->required();
    app.add_option("--mask", mask,
                   "Mask image (EXR / 16-bit PNG) over the terrain's xy: blocks only where it "
                   "reads >= 0.5 (PNG: >= 32768)");
    tool.addParams(app, amplifySchema());
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addStats(app);
    tool.addDistribution(app);

    return tool.run(argc, argv, [&] {
        using Clock = std::chrono::steady_clock;
        const auto t0 = Clock::now();
        const AmplifyParams p = amplifySchema().fromJson(tool.givenParams(amplifySchema()));
        AmplifyInputs in;
        in.terrainPath = terrain;
        in.names = {{"terrain", terrain}, {"tiles", tiles}};
        for (const auto& t : tiles) {
            in.tiles.push_back(std::make_shared<const blocks::BlockTile>(blocks::readTile(t)));
            const std::string stem = t.substr(t.find_last_of('/') + 1);
            in.tileNames.push_back(stem.substr(0, stem.find_last_of('.')));
        }
        if (!mask.empty()) {
            in.mask = std::make_shared<const GrayImage>(readGrayImage(mask, "mask"));
            in.names["mask"] = mask;
        }
        const double loadSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
        const AmplifyRun r = tool.stage([&](Task& task) { return runAmplify(p, in, task); });
        const auto tw = Clock::now();
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
        char line[160];
        std::snprintf(line, sizeof line, "io: load %.3f s (tiles, mask), write %.3f s; total %.3f s",
                      loadSeconds, std::chrono::duration<double>(Clock::now() - tw).count(),
                      std::chrono::duration<double>(Clock::now() - t0).count());
        tool.info(line);
    });
}
