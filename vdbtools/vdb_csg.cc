// SPDX-License-Identifier: Apache-2.0
// vdb_csg — union / intersection / difference of level-set files: options from the stage's
// table, work in runCsg (core/CsgStage.h), which rockvdb.csg runs too.
#include "Cli.h"

#include <rockvdb/core/CsgStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <algorithm>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool(kCsgTool, csgSchema().summary() + " The output's rockvdb:params replays it: "
                             "vdb_csg --params FILE -o OUT.");
    CLI::App& app = tool.app();
    std::string op, gridName = "surface";
    std::vector<std::string> inputs;
    app.add_option("operation", op, "union | intersection | difference")->required()
        ->check(CLI::IsMember({"union", "intersection", "difference"}));
    app.add_option("inputs", inputs, "Input .vdb files ('-' = stdin, once)")->required()
        ->expected(1, 1 << 20);
    app.add_option("--grid", gridName, "Level-set grid to read from each input")->capture_default_str();
    tool.addParams(app, csgSchema());
    tool.addOutput(app, "Output .vdb ('-' = stdout)");
    tool.addStats(app);

    return tool.run(argc, argv, [&] {
        const CsgParams p = csgSchema().fromJson(tool.givenParams(csgSchema()));
        if (std::count(inputs.begin(), inputs.end(), "-") > 1) {
            fail<ValueError>("csg: stdin ('-') can be given only once");
        }
        std::vector<CsgInput> in;
        nlohmann::json names = {{"inputs", inputs}, {"grid", gridName}, {"sources", nlohmann::json::array()}};
        for (const auto& path : inputs) {
            in.push_back(readCsgInput(path, gridName, p.ids));
            nlohmann::json src = {{"file", path}};
            if (auto prov = provenance(*in.back().surface)) {
                src["generator"] = prov->generator;
                src["params"] = jsonOrText(prov->params);
            }
            names["sources"].push_back(src);
        }
        const StageResult r = tool.stage([&](Task& task) {
            return runCsg(csgOpFromString(op), p, in, names, task);
        });
        cli::refuseEmpty(*r.grids[0], "the inputs do not meet, or the difference or smooth radius "
                                      "removed everything");
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
    });
}
