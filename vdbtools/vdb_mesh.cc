// vdb_mesh — level set to an OBJ or PLY mesh (tools::volumeToMesh).
#include "Cli.h"

#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_mesh", "Mesh a level set (tools::volumeToMesh) and write OBJ or PLY "
                               "with outward, counter-clockwise faces.");
    CLI::App& app = tool.app();
    std::string input, gridName = "surface";
    double isovalue = 0.0, adaptivity = 0.0;
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid to mesh")->capture_default_str();
    app.add_option("--isovalue", isovalue, "Iso-surface value (m)")->capture_default_str();
    app.add_option("--adaptivity", adaptivity, "0 = uniform .. 1 = most adaptive")->capture_default_str();
    std::string up = "z";
    app.add_option("--up", up, "Up axis of the written mesh: z (rockvdb) or y (what Blender's "
                               "OBJ import expects by default, Houdini)")->capture_default_str();
    tool.addOutput(app, "Output .obj or .ply ('-' = OBJ on stdout)");

    return tool.run(argc, argv, [&] {
        const UpAxis upAxis = upAxisFromString(up, "mesh: --up");
        auto grid = readLevelSet(input, gridName);
        const Mesh mesh = meshLevelSet(*grid, isovalue, adaptivity);
        tool.info(std::to_string(mesh.points.size()) + " points, " +
                  std::to_string(mesh.triangles.size()) + " triangles, " +
                  std::to_string(mesh.quads.size()) + " quads");
        if (mesh.points.empty()) {
            const double bg = double(grid->background());
            fail<ValueError>("the result is empty: no surface at isovalue ", isovalue, " (the level set's band holds "
                             "values within +-", bg, "; an isovalue must lie inside it)");
        }
        writeMesh(mesh, tool.output(), upAxis);
    });
}
