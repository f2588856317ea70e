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
    tool.addParams(app, meshSchema());
    tool.addOutput(app, "Output .obj or .ply ('-' = OBJ on stdout)", {".obj", ".ply"});

    return tool.run(argc, argv, [&] {
        const MeshParams p = meshSchema().fromJson(tool.givenParams(meshSchema()));
        const Mesh mesh = meshGrid(*readLevelSet(input, gridName), p);
        tool.info(std::to_string(mesh.points.size()) + " points, " +
                  std::to_string(mesh.triangles.size()) + " triangles, " +
                  std::to_string(mesh.quads.size()) + " quads");
        writeMesh(mesh, tool.output(), upAxisFromString(p.up, "mesh: up"));
    });
}
