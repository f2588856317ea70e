// SPDX-License-Identifier: Apache-2.0
// vdb_info — what is in a .vdb: grids, voxel size, active voxels, bounds, memory, provenance.
#include "Cli.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <iostream>

#include <sys/stat.h>

using namespace rockvdb;

namespace {

// One file: its size and every grid's type, class, voxel size, counts, bounds and provenance.
nlohmann::json describeFile(const std::string& path)
{
    auto grids = readGrids(path);
    nlohmann::json jf = {{"file", path}, {"grids", nlohmann::json::array()}};
    struct stat st;
    if (path != "-" && ::stat(path.c_str(), &st) == 0) jf["file_bytes"] = uint64_t(st.st_size);
    for (const auto& g : *grids) {
        if (!g) continue;
        const auto ibox = g->evalActiveVoxelBoundingBox();
        const auto wbox = g->transform().indexToWorld(ibox);
        nlohmann::json jg = {
            {"name", g->getName()}, {"type", g->type()},
            {"class", openvdb::GridBase::gridClassToString(g->getGridClass())},
            {"voxel_size", g->voxelSize()[0]},
            {"active_voxels", g->activeVoxelCount()},
            {"memory_bytes", g->memUsage()}};
        if (g->activeVoxelCount() > 0) {
            jg["bbox_index"] = {{ibox.min()[0], ibox.min()[1], ibox.min()[2]},
                                {ibox.max()[0], ibox.max()[1], ibox.max()[2]}};
            jg["bbox_world"] = {{wbox.min()[0], wbox.min()[1], wbox.min()[2]},
                                {wbox.max()[0], wbox.max()[1], wbox.max()[2]}};
        }
        if (auto p = provenance(*g)) {
            jg["rockvdb"] = {{"version", p->version}, {"generator", p->generator},
                             {"params", jsonOrText(p->params)}};
        }
        jf["grids"].push_back(jg);
    }
    return jf;
}

// --brief: one line per file.
void printBrief(const nlohmann::json& files)
{
    for (const auto& jf : files) {
        std::cout << jf["file"].get<std::string>();
        if (jf.contains("file_bytes")) {
            std::cout << "  " << formatBytes(jf["file_bytes"].get<double>());
        }
        // Level sets first, then the others, each in file order.
        for (const bool levelSets : {true, false}) {
            for (const auto& jg : jf["grids"]) {
                if ((jg["class"].get<std::string>() == "level set") != levelSets) continue;
                std::cout << "  " << jg["name"].get<std::string>() << " "
                          << jg["active_voxels"].get<uint64_t>();
            }
        }
        std::cout << "\n";
    }
}

// The default: a block per file, a line or three per grid.
void printText(const nlohmann::json& files)
{
    for (const auto& jf : files) {
        std::cout << jf["file"].get<std::string>() << "\n";
        for (const auto& jg : jf["grids"]) {
            std::cout << "  " << jg["name"].get<std::string>() << "  " << jg["type"].get<std::string>()
                      << "  class=" << jg["class"].get<std::string>()
                      << "  voxel=" << jg["voxel_size"].get<double>() << " m"
                      << "  active=" << jg["active_voxels"].get<uint64_t>()
                      << "  memory=" << formatBytes(jg["memory_bytes"].get<double>()) << "\n";
            if (jg.contains("bbox_world")) {
                const auto& b = jg["bbox_world"];
                std::cout << "    bounds (m): [" << b[0][0] << ", " << b[0][1] << ", " << b[0][2]
                          << "] .. [" << b[1][0] << ", " << b[1][1] << ", " << b[1][2] << "]\n";
            }
            if (jg.contains("rockvdb")) {
                const auto& r = jg["rockvdb"];
                std::string params = jsonText(r["params"]);
                if (params.size() > 160) params = params.substr(0, 157) + "...";
                std::cout << "    rockvdb " << r["version"].get<std::string>() << " "
                          << r["generator"].get<std::string>() << " " << params << "\n";
            }
        }
    }
}

} // namespace

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_info", "Describe the grids of .vdb files: type, class, voxel size, "
                               "active voxels, world bounds, memory and rockvdb provenance.");
    CLI::App& app = tool.app();
    std::vector<std::string> inputs;
    bool asJson = false;
    app.add_option("inputs", inputs, "Input .vdb files ('-' = stdin)")->required()->expected(1, 1 << 20);
    app.add_flag("--json", asJson, "Print one JSON document (provenance parameters in full)");
    bool brief = false;
    app.add_flag("--brief", brief, "One line per file: its size and each grid's active voxels");

    return tool.run(argc, argv, [&] {
        nlohmann::json files = nlohmann::json::array();
        for (const auto& path : inputs) files.push_back(describeFile(path));
        if (asJson) {
            // (names from a file may be any bytes: invalid UTF-8 is replaced, not thrown on)
            std::cout << files.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
        } else if (brief) {
            printBrief(files);
        } else {
            printText(files);
        }
    });
}
