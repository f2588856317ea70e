// vdb_arches — material-stack terrain with overhangs, arches and caves ("Arches: a Framework
// for Modeling Complex Terrains", §3, §6). Options from the stage's table (ArchesStage.h): a
// scene is that table's JSON, given as the first argument (or --params); its "terrain" is the
// initial terrain. Work in buildStacks / runArches.
#include "Cli.h"

#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/StackFile.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <cstdio>
#include <filesystem>

using namespace rockvdb;
using namespace rockvdb::arches;

int main(int argc, char** argv)
{
    cli::Tool tool(kToolName, archesSchema().summary() +
        " Writes 'surface' (the ground: sand, bedrock and rocks), one level set per ground material "
        "present ('sand', 'bedrock', 'rocks') and 'material' (ids: sand 2, bedrock 3, rocks 4). "
        "--stacks saves the stacks to continue later with --from-stacks. The output's "
        "rockvdb:params replays it: vdb_arches --params FILE -o OUT.");
    CLI::App& app = tool.app();
    std::string scene, stacksOut, stacksIn;
    app.add_option("scene", scene, "Scene .json: the table's keys (command-line options win)");
    tool.addParams(app, archesSchema());
    app.add_option("--stacks", stacksOut, "Also save the stacks (after stabilisation) to this .stacks file");
    app.add_option("--from-stacks", stacksIn,
                   "Start from these saved stacks (their scene's parameters, command-line options win) "
                   "instead of building the terrain");
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        if (!scene.empty() && !stacksIn.empty()) fail<ValueError>("arches: give a scene or --from-stacks, not both");
        if (!stacksOut.empty()) {
            if (std::filesystem::path(stacksOut).extension() != ".stacks") {
                fail<ValueError>("arches: --stacks must end in .stacks (got '", stacksOut, "')");
            }
            if (stacksOut == tool.output()) fail<ValueError>("arches: --stacks and -o name the same file");
            requireWritable(stacksOut);
        }
        // The scene (or the saved stacks' scene), then what the command line gives on top.
        nlohmann::json given = nlohmann::json::object();
        std::string baseDir = ".";
        std::optional<Stacks> saved;
        if (!scene.empty()) {
            given = readScene(scene, baseDir);
        } else if (!stacksIn.empty()) {
            StackFile f = readStackFile(stacksIn);
            given = nlohmann::json::parse(f.params, nullptr, false);
            if (!given.is_object()) fail<IoError>("arches: ", stacksIn, " holds no scene parameters");
            saved = std::move(f.stacks);
        }
        const nlohmann::json cli = tool.givenParams(archesSchema()); // (not a temporary in the loop)
        for (auto it = cli.begin(); it != cli.end(); ++it) given[it.key()] = it.value();
        ArchesParams p = archesSchema().fromJson(given);
        p.baseDir = baseDir;
        auto bar = tool.taskBar();
        Task task(bar.get());
        Stacks stacks = saved ? std::move(*saved) : buildStacks(p, task);
        const ArchesResult r = runArches(p, std::move(stacks), task);
        bar->clear();
        char line[240];
        std::snprintf(line, sizeof line, "%zu stacks, %zu layers in %.2f MB; stabilised in %.2f s (%zu moves); "
                      "baked in %.2f s, %zu active voxels",
                      r.stats.stacks, r.stats.layers, double(r.stats.bytes) / 1e6, r.stats.stabilize.seconds,
                      r.stats.stabilize.moves, r.stats.bakeSeconds, r.stats.activeVoxels);
        tool.info(line);
        // The ids first and the ground last: vdb_tool acts on the last grid read.
        openvdb::GridCPtrVec out{r.material};
        for (const auto& g : r.materials) out.push_back(g);
        out.push_back(r.surface);
        // The stacks first: if the .vdb fails after, the run is repeatable from them; the
        // reverse would leave a terrain whose stacks were lost.
        if (!stacksOut.empty()) writeStackFile(stacksOut, r.stacks, archesSchema().toJson(p).dump());
        writeGrids(tool.output(), out);
    });
}
