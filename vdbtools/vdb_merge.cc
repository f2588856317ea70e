// vdb_merge — merge the chunks of one bake (--region, leaf aligned) into one file.
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Merge.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_merge",
        "Merge chunk files of one bake (each baked with --region; chunks aligned to 8-voxel "
        "leaf boundaries) into the whole: every grid (surface, block_id, material, ...) is "
        "matched by name across the chunks, their voxels are united, and level sets get their "
        "inside/outside tiles back by signed flood fill. Leaf-aligned chunks merge to exactly "
        "the whole bake. Chunks must hold the same grids with the same transform; a voxel "
        "active in two chunks must have the same value in both.");
    CLI::App& app = tool.app();
    std::vector<std::string> inputs;
    app.add_option("inputs", inputs, "Chunk .vdb files ('-' = stdin, once)")->required()
        ->expected(1, 1 << 20);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    return tool.run(argc, argv, [&] {
        if (std::count(inputs.begin(), inputs.end(), "-") > 1) {
            fail<ValueError>("merge: stdin ('-') can be given only once");
        }
        std::vector<std::string> names; // grid order of the first chunk
        std::map<std::string, std::vector<openvdb::FloatGrid::ConstPtr>> byName;
        std::map<std::string, nlohmann::json> sources;
        for (size_t i = 0; i < inputs.size(); ++i) {
            auto grids = readGrids(inputs[i]);
            std::vector<std::string> here;
            for (const auto& g : *grids) {
                auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
                if (!f) {
                    fail<ValueError>("merge: grid '", g->getName(), "' in ", inputs[i],
                                     " is not a float grid");
                }
                if (std::count(here.begin(), here.end(), f->getName())) {
                    fail<ValueError>("merge: ", inputs[i], " holds two grids named '",
                                     f->getName(), "'");
                }
                here.push_back(f->getName());
                byName[f->getName()].push_back(f);
                nlohmann::json src = {{"file", inputs[i]}};
                if (auto p = provenance(*f)) {
                    src["generator"] = p->generator;
                    src["params"] = jsonOrText(p->params);
                }
                sources[f->getName()].push_back(src);
            }
            if (i == 0) {
                names = here;
                if (names.empty()) fail<ValueError>("merge: ", inputs[i], " holds no grids");
            } else {
                std::vector<std::string> a = names, b = here;
                std::sort(a.begin(), a.end());
                std::sort(b.begin(), b.end());
                if (a != b) {
                    fail<ValueError>("merge: ", inputs[i], " holds other grids than ", inputs[0],
                                     " (chunks of one bake hold the same grids)");
                }
            }
        }
        const nlohmann::json base = nlohmann::json::parse(tool.paramsJson());
        openvdb::GridCPtrVec out;
        for (const auto& name : names) {
            auto merged = mergeChunks(byName[name]);
            nlohmann::json params = base;
            params["sources"] = sources[name];
            stampProvenance(*merged, tool.name(), params.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
            tool.info(name + ": " + std::to_string(merged->activeVoxelCount()) + " active voxels");
            out.push_back(merged);
        }
        writeGrids(tool.output(), out);
    });
}
