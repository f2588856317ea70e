// SPDX-License-Identifier: Apache-2.0
// vdb_detail — surface detail on any level set: gradient warp (implicit-blocks §4.2) and
// Gabor details (gabor-details-implicit-surfaces §3–§4). Options from the stage's table,
// work in runDetail (DetailStage.h).
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/detail/DetailStage.h>

#include <cstdio>

using namespace rockvdb;
using namespace rockvdb::detail;

int main(int argc, char** argv)
{
    cli::Tool tool(kDetailTool, detailSchema().summary() +
        " The file's id grids (block_id, material, ...) are carried onto the result. W comes "
        "from --direction-axis, --direction-skeleton or --direction-curvature. The output's "
        "rockvdb:params replays it: vdb_detail --params FILE -o OUT.");
    CLI::App& app = tool.app();
    std::string input, gridName = "surface", blendMask, blendGrid;
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid to detail")->capture_default_str();
    tool.addParams(app, detailSchema());
    app.add_option("--blend-mask", blendMask,
                   "Scalar .vdb grid of blend weights in [0, 1] (world space)");
    app.add_option("--blend-mask-grid", blendGrid,
                   "Grid name in --blend-mask (default: its only or first float grid)");
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addStats(app);
    tool.addDistribution(app);

    return tool.run(argc, argv, [&] {
        const DetailStageParams p = detailSchema().fromJson(tool.givenParams(detailSchema()));
        DetailInputs in;
        in.names = {{"input", input}, {"grid", gridName}};
        // The level set, and the file's other float grids (ids) to carry onto the result.
        auto all = readGrids(input);
        in.grid = findLevelSet(*all, gridName, input);
        for (const auto& gb : *all) {
            auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(gb);
            if (f && f != in.grid && f->getGridClass() != openvdb::GRID_LEVEL_SET) in.ids.push_back(f);
        }
        if (!blendMask.empty()) {
            in.names["blend-mask"] = blendMask;
            if (!blendGrid.empty()) in.names["blend-mask-grid"] = blendGrid;
            const auto maskFile = readGrids(blendMask);
            for (const auto& gb : *maskFile) {
                auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(gb);
                if (f && (blendGrid.empty() || f->getName() == blendGrid)) {
                    in.blendMask = f;
                    break;
                }
            }
            if (!in.blendMask) {
                fail<ValueError>("detail: no float grid", blendGrid.empty() ? "" : " '" + blendGrid + "'",
                                 " in ", blendMask);
            }
        }
        const DetailResult r = tool.stage([&](Task& task) { return runDetail(p, in, task); });
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
    });
}
