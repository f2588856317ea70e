// vdb_csg — union / intersection / difference of level-set files.
#include "Cli.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/GridCsg.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <map>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_csg",
        "Combine level sets: union, intersection or difference (the first minus the others), "
        "folded left to right; optional smooth radius (implicit-blocks §4.2 operator). Inputs "
        "on other voxel sizes are resampled onto the first. The inputs' id grids come along.");
    CLI::App& app = tool.app();
    std::string op;
    std::vector<std::string> inputs;
    std::string gridName = "surface";
    double smooth = 0.0;
    app.add_option("operation", op, "union | intersection | difference")->required()
        ->check(CLI::IsMember({"union", "intersection", "difference"}));
    app.add_option("inputs", inputs, "Input .vdb files ('-' = stdin, once)")->required()
        ->expected(1, 1 << 20);
    app.add_option("--grid", gridName, "Level-set grid to read from each input")->capture_default_str();
    app.add_option("--smooth", smooth, "Smooth blend radius R (m); 0 = hard CSG")->capture_default_str();
    bool noIds = false;
    app.add_flag("--no-ids", noIds,
                 "Do not carry the inputs' id grids (block_id, rock_id, material, ...). By "
                 "default each is carried: a voxel takes the id of the input whose surface the "
                 "result follows there (in a difference, the first input's)");
    double maxMemoryGB = 0;
    app.add_option("--max-memory", maxMemoryGB,
                   "Refuse a CSG whose resampled inputs or widened bands are estimated above "
                   "this (GB; 0 = 75% of RAM)")->capture_default_str();
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        require(std::isfinite(smooth) && smooth >= 0, "csg", "--smooth", ">= 0", smooth);
        require(std::isfinite(maxMemoryGB) && maxMemoryGB >= 0, "csg", "--max-memory", ">= 0 GB",
                maxMemoryGB);
        if (std::count(inputs.begin(), inputs.end(), "-") > 1) {
            fail<ValueError>("csg: stdin ('-') can be given only once");
        }
        std::vector<openvdb::FloatGrid::ConstPtr> grids;
        // Each input's id grids (float grids that are not level sets: block_id, rock_id,
        // material), by name in order of first appearance.
        std::vector<std::string> idNames;
        std::vector<std::map<std::string, openvdb::FloatGrid::ConstPtr>> idGrids;
        nlohmann::json sources = nlohmann::json::array();
        for (const auto& path : inputs) {
            auto all = readGrids(path);
            auto g = findLevelSet(*all, gridName, path == "-" ? "<stdin>" : path);
            idGrids.emplace_back();
            if (!noIds) {
                for (const auto& gb : *all) {
                    auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(gb);
                    if (!f || f == g || f->getGridClass() == openvdb::GRID_LEVEL_SET) continue;
                    if (!idGrids.back().emplace(f->getName(), f).second) continue;
                    if (std::find(idNames.begin(), idNames.end(), f->getName()) == idNames.end()) {
                        idNames.push_back(f->getName());
                    }
                }
            }
            nlohmann::json src = {{"file", path}};
            if (auto p = provenance(*g)) {
                src["generator"] = p->generator;
                src["params"] = jsonOrText(p->params);
            }
            sources.push_back(src);
            grids.push_back(g);
        }
        auto result = csgGrids(csgOpFromString(op), grids, smooth, maxMemoryGB * 1e9);
        nlohmann::json params = nlohmann::json::parse(tool.paramsJson());
        params["sources"] = sources;
        stampProvenance(*result, tool.name(), jsonText(params));
        openvdb::GridCPtrVec out{result};
        for (const auto& name : idNames) {
            std::vector<openvdb::FloatGrid::ConstPtr> ids;
            for (const auto& m : idGrids) {
                auto it = m.find(name);
                ids.push_back(it == m.end() ? nullptr : it->second);
            }
            auto carried = csgAttribute(csgOpFromString(op), grids, ids, *result, name);
            stampProvenance(*carried, tool.name(), jsonText(params));
            out.push_back(carried);
        }
        tool.info(std::to_string(result->activeVoxelCount()) + " active voxels" +
                  (idNames.empty() ? std::string() : ", id grids carried: " + [&] {
                      std::string s;
                      for (const auto& n : idNames) s += (s.empty() ? "" : ", ") + n;
                      return s;
                  }()));
        cli::refuseEmpty(*result, "the inputs do not meet, or the difference or smooth radius removed everything");
        writeGrids(tool.output(), out);
    });
}
