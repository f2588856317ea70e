// SPDX-License-Identifier: Apache-2.0
// vdb_heightfield — a heightfield image to a narrow-band level set of the terrain solid.
// Options from the table, the work in runHeightfield (HeightfieldStage.h), which
// rockvdb.heightfield runs too.
#include "Cli.h"

#include <rockvdb/core/HeightfieldStage.h>
#include <rockvdb/core/VdbIO.h>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool(kHeightfieldTool, heightfieldSchema().summary());
    CLI::App& app = tool.app();
    std::string image;
    app.add_option("image", image, "Heightfield .exr or .png")->required();
    tool.addParams(app, heightfieldSchema());
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addStats(app);

    return tool.run(argc, argv, [&] {
        const HeightfieldParams p = heightfieldSchema().fromJson(tool.givenParams(heightfieldSchema()));
        const StageResult r = tool.stage([&](Task& task) {
            return runHeightfield(p, image, task);
        });
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
    });
}
