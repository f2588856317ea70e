// vdb_arches — material-stack terrain with overhangs, arches and caves ("Arches: a Framework
// for Modeling Complex Terrains", §3, §6). Options from the stage's table (ArchesStage.h): a
// scene is that table's JSON, given as the first argument (or --params); its "terrain" is the
// initial terrain, its "edits" the §4 edits. Work in buildStacks / runArches / bakeStacks.
#include "Cli.h"

#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/StackFile.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

#include <cstdio>
#include <algorithm>
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
    app.add_option("--stacks", stacksOut, "Also save the stacks (after stabilisation and the edits) to this .stacks file");
    app.add_option("--from-stacks", stacksIn,
                   "Start from these saved stacks (their scene's parameters) instead of building the terrain: "
                   "--edits adds edits after theirs; only the bake's rows (" + bakeOnlyRowsText() + ") may change");
    app.add_option("--points", pointsOut,
                   "With --rock-tiles: also write the instanced rocks as a VDB points grid 'rocks' (P, rock, tile, "
                   "instance; as vdb_rockpile pile --points) to this .vdb");
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addDistribution(app);

    return tool.run(argc, argv, [&] {
        if (!scene.empty() && !stacksIn.empty()) fail<ValueError>("arches: give a scene or --from-stacks, not both");
        if (!stacksOut.empty()) {
            if (std::filesystem::path(stacksOut).extension() != ".stacks") {
                fail<ValueError>("arches: --stacks must end in .stacks (got '", stacksOut, "')");
            }
            requireWritable(stacksOut);
        }
        cli::distinctOutputs({{"-o", tool.output()}, {"--stacks", stacksOut}, {"--points", pointsOut}});
        if (!stacksOut.empty() && tool.givenParams(archesSchema()).value("chunk", "") != "") {
            fail<ValueError>("arches: --stacks saves the whole scene's stacks; write them from a run "
                             "without --chunk");
        }
        if (!pointsOut.empty()) requireWritable(pointsOut);
        // The scene (or the saved stacks' scene), then what the command line gives on top.
        nlohmann::json given = nlohmann::json::object();
        std::string baseDir = ".";
        std::optional<Stacks> saved;
        if (!scene.empty()) {
            given = readScene(scene, baseDir);
        } else if (!stacksIn.empty()) {
            StackFile f = readStackFile(stacksIn);
            given = parseJsonOrDiscarded(f.params);
            if (!given.is_object()) fail<IoError>("arches: ", stacksIn, " holds no scene parameters");
            saved = std::move(f.stacks);
        }
        nlohmann::json cli = tool.givenParams(archesSchema()); // (not a temporary in the loop)
        anchorGivenPaths(cli); // options name files from here, the scene's own keys from its folder
        // Saved stacks were made by their scene: only the bake's rows may differ, and edits
        // given here come after the saved ones (the record lists both, so it replays).
        nlohmann::json more = nlohmann::json::array();
        for (auto it = cli.begin(); it != cli.end(); ++it) {
            if (saved && it.key() == "edits") {
                more = jsonOrFile(it.value());
                if (!more.is_array()) fail<ValueError>("arches: --edits must be a list of edits");
                nlohmann::json all = jsonOrFile(given.value("edits", nlohmann::json::array()));
                for (const auto& e : more) all.push_back(e);
                given["edits"] = all;
                continue;
            }
            if (saved && std::find(bakeOnlyRows().begin(), bakeOnlyRows().end(), it.key()) == bakeOnlyRows().end()) {
                fail<ValueError>("arches: --", it.key(), " made the saved stacks; with --from-stacks only --edits "
                                 "(more edits) and the bake's ", bakeOnlyRowsText(), " may be given");
            }
            given[it.key()] = it.value();
        }
        ArchesParams p = archesSchema().fromJson(given);
        p.baseDir = baseDir;
        if (!pointsOut.empty() && p.rockTiles.empty()) {
            fail<ValueError>("arches: --points needs --rock-tiles (the points are the rocks instanced in rock layers)");
        }
        p.edits = jsonOrFile(p.edits); // recorded as content, not a path
        auto bar = tool.taskBar();
        Task task(bar.get());
        ArchesResult r;
        if (saved) {
            // Continue: the new edits only, then the bake.
            Stacks stacks = std::move(*saved);
            std::vector<EditStats> edits = applyEdits(p, stacks, more, p.edits.size() - more.size(), task);
            r = bakeStacks(p, stacks, ArchesOutput::All, nlohmann::json::object(), task);
            r.stats.edits = std::move(edits);
            r.stacks = std::move(stacks);
        } else {
            r = runArches(p, buildStacks(p, task), task);
        }
        bar->clear();
        char line[240];
        std::snprintf(line, sizeof line, "%zu stacks, %zu layers in %.2f MB; stabilised in %.2f s (%zu moves); "
                      "baked in %.2f s, %zu active voxels",
                      r.stats.stacks, r.stats.layers, double(r.stats.bytes) / 1e6, r.stats.stabilize.seconds,
                      r.stats.stabilize.moves, r.stats.bakeSeconds, r.stats.activeVoxels);
        tool.info(line);
        if (r.rockId) {
            std::snprintf(line, sizeof line, "%zu rocks instanced in the rock layers in %.2f s", r.rocksPlaced, r.rockSeconds);
            tool.info(line);
        }
        for (size_t k = 0; k < r.stats.edits.size(); ++k) {
            const EditStats& e = r.stats.edits[k];
            std::snprintf(line, sizeof line, "edit %zu (%s): %zu stacks changed, bedrock %+.3g m3, sand %+.3g m3, rocks %+.3g m3; "
                          "%.3f s with its stabilisation (%zu moves)", k, e.tool.c_str(), e.stacks,
                          double(e.bedrock) * r.stacks.geometry().quantum * r.stacks.geometry().cell * r.stacks.geometry().cell,
                          double(e.sand) * r.stacks.geometry().quantum * r.stacks.geometry().cell * r.stacks.geometry().cell,
                          double(e.rocks) * r.stacks.geometry().quantum * r.stacks.geometry().cell * r.stacks.geometry().cell,
                          e.seconds, e.stabilize.moves);
            tool.info(line);
        }
        // The ids first and the ground last: vdb_tool acts on the last grid read.
        openvdb::GridCPtrVec out{r.material};
        if (r.rockId) out.push_back(r.rockId);
        for (const auto& g : r.weights) out.push_back(g);
        for (const auto& g : r.materials) out.push_back(g);
        out.push_back(r.surface);
        // The stacks first: if the .vdb fails after, the run is repeatable from them; the
        // reverse would leave a terrain whose stacks were lost.
        if (!stacksOut.empty()) writeStackFile(stacksOut, r.stacks, archesSchema().toJson(p).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
        if (!pointsOut.empty()) writeGrids(pointsOut, {r.points});
        writeGrids(tool.output(), out);
    });
}
