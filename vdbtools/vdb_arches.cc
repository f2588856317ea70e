// SPDX-License-Identifier: Apache-2.0
// vdb_arches — material-stack terrain with overhangs, arches and caves ("Arches: a Framework
// for Modeling Complex Terrains", §3, §6). Options from the stage's table (ArchesStage.h): a
// scene is that table's JSON, given as the first argument (or --params); its "terrain" is the
// initial terrain, its "edits" the §4 edits. The work in runArches (openScene, bakeScene),
// which rockvdb.Stacks runs too.
#include "Cli.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/StackFile.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

#include <filesystem>

using namespace rockvdb;
using namespace rockvdb::arches;

int main(int argc, char** argv)
{
    cli::Tool tool(kToolName, archesSchema().summary() +
        " Writes 'surface' (the ground: sand, bedrock and rocks), one level set per ground material "
        "present ('sand', 'bedrock', 'rocks'), 'material' (ids: sand 2, bedrock 3, rocks 4, or "
        "--material-ids) and weight_<material> fog grids (visible share of each material, §6; --no-weights: "
        "none); with --rock-tiles also 'rock_id', and --points writes the rock instances. --stacks saves the stacks to continue later with --from-stacks. The output's "
        "rockvdb:params replays it: vdb_arches --params FILE -o OUT.");
    CLI::App& app = tool.app();
    std::string scene, stacksOut, stacksIn, pointsOut;
    app.add_option("scene", scene, "Scene .json: the table's keys (command-line options win)");
    tool.addParams(app, archesSchema());
    app.add_option("--stacks", stacksOut, "Also save the stacks (after stabilisation and the edits) to this .stacks file")
        ->check(cli::writes({".stacks"}));
    app.add_option("--from-stacks", stacksIn,
                   "Start from these saved stacks (their scene's parameters) instead of building the terrain: "
                   "--edits adds edits after theirs; only the bake's rows (" + bakeOnlyRowsText() + ") may change");
    app.add_option("--points", pointsOut,
                   "With --rock-tiles: also write the instanced rocks as a VDB points grid 'rocks' (P, orient, "
                   "pscale, variant, pivot, id, rock, tile; as vdb_rockpile pile --points) to this .vdb")
        ->check(cli::writes({".vdb"}));
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addDistribution(app);

    tool.addStats(app);

    return tool.run(argc, argv, [&] {
        if (!stacksOut.empty()) {
            requireWritable(stacksOut);
        }
        cli::distinctOutputs({{"-o", tool.output()}, {"--stacks", stacksOut}, {"--points", pointsOut}});
        SceneInputs in;
        in.scenePath = scene;
        in.stacksPath = stacksIn;
        in.given = tool.givenParams(archesSchema());
        if (!stacksOut.empty() && in.given.value("chunk", "") != "") {
            fail<ValueError>("arches: --stacks saves the whole scene's stacks; write them from a run "
                             "without --chunk");
        }
        if (!pointsOut.empty()) requireWritable(pointsOut);
        in.points = !pointsOut.empty();
        const ArchesResult r = tool.stage([&](Task& task) { return runArches(in, task); });
        // The stacks first: if the .vdb fails after, the run is repeatable from them; the
        // reverse would leave a terrain whose stacks were lost.
        if (!stacksOut.empty()) writeStackFile(stacksOut, r.stacks, jsonText(r.provenance));
        if (!pointsOut.empty()) writeGrids(pointsOut, {r.points});
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
    });
}
