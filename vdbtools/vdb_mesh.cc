// SPDX-License-Identifier: Apache-2.0
// vdb_mesh — level set to an OBJ or PLY mesh (tools::volumeToMesh).
#include "Cli.h"

#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_mesh", meshSchema().summary());
    CLI::App& app = tool.app();
    std::string input, gridName = "surface";
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid to mesh")->capture_default_str();
    std::string idsOption = "auto";
    app.add_option("--ids", idsOption,
                   "Id grids written per vertex (PLY properties; OBJ faces under usemtl NAME_ID "
                   "of the first): comma-separated names, 'auto' = whichever of block_id, "
                   "rock_id, material the input holds, 'none'")
        ->capture_default_str();
    tool.addParams(app, meshSchema());
    tool.addOutput(app, "Output .obj or .ply ('-' = OBJ on stdout)", {".obj", ".ply"});

    return tool.run(argc, argv, [&] {
        const MeshParams p = meshSchema().fromJson(tool.givenParams(meshSchema()));
        std::vector<std::string> names;
        std::string item;
        for (char c : idsOption + ",") {
            if (c != ',') { item += c; continue; }
            if (!item.empty() && item != "none") names.push_back(item);
            item.clear();
        }
        const bool automatic = names.size() == 1 && names[0] == "auto";
        if (automatic) names = {"block_id", "rock_id", "material"};
        // One read of the file (stdin can be read once): the level set and its id grids.
        const auto grids = readGrids(input);
        const openvdb::FloatGrid::Ptr surface = findLevelSet(*grids, gridName, input);
        Mesh mesh = meshGrid(*surface, p);
        for (const auto& name : names) {
            openvdb::FloatGrid::Ptr ids;
            for (const auto& g : *grids) {
                if (g->getName() == name) ids = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
            }
            if (!ids) {
                if (automatic) continue;
                fail<ValueError>("mesh: --ids: '", input, "' holds no float grid '", name, "'");
            }
            attachIds(mesh, *surface, *ids, name);
        }
        tool.info(std::to_string(mesh.points.size()) + " points, " +
                  std::to_string(mesh.triangles.size()) + " triangles, " +
                  std::to_string(mesh.quads.size()) + " quads");
        writeMesh(mesh, tool.output(), upAxisFromString(p.up, "mesh: up"));
    });
}
