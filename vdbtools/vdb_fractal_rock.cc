// SPDX-License-Identifier: Apache-2.0
// vdb_fractal_rock — fractal rocks from an icosahedron (fractal-rocks-midpoint-displacement.txt):
// options from the stage's table, the work in runFractal (FractalStage.h), which
// rockvdb.fractal_rock / fractal_scatter / fractal_carve run too.
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/fractal/FractalStage.h>


using namespace rockvdb;
using namespace rockvdb::fractal;

namespace {

// Each path's extension is checked as the options are parsed (cli::writes); a normal map
// needs the OBJ's UVs, refused before any work too.
void checkExtensions(const std::string& meshPath, const std::string& mapPath)
{
if (!mapPath.empty() && cli::hasExtension(meshPath, {".ply"})) {
    fail<ValueError>("fractal: a normal map needs the OBJ's UVs; write --mesh as .obj");
}
}

} // namespace

int main(int argc, char** argv)
{
    cli::Tool tool(kToolName, std::string(
        "Fractal rocks (midpoint displacement on an icosahedron, "
        "fractal-rocks-midpoint-displacement.txt): the 20 faces of an icosahedron scaled to "
        "--size are refined --levels times by deterministic midpoint displacement (each "
        "edge's displacement a hash of its endpoints and the seed: no cracks at any level or "
        "thread count), rougher where the surface faces up (--h-up) than down (--h-down), with "
        "subdivision damping (interpolating or approximating spline, 16 sub-triangles per "
        "face per level) or plain midpoint displacement (4). Writes the level set 'surface' "
        "(baked directly from the closed mesh: exact distances, signs from pseudo-normals), and with --mesh the mesh (OBJ with normals "
        "and UVs, or PLY with normals), with --normal-map its normal map. With --count N, N "
        "rocks of jittered sizes are scattered on --ground (a heightfield image, a level set "
        ".vdb, or the plane z = 0) where an fBm density map allows, partly sunk (--embed), no "
        "two interpenetrating: 'surface' (their union) and 'rock_id', with --points the "
        "instances (P, orient, pscale, scale, variant, id, rock) as a VDB points grid 'rocks' in its own file. ") +
        normalMapHelp() +
        " With --carve SOLID.vdb --count N, a chain of N rocks is subtracted from the solid (§9: "
        "caves). The output's rockvdb:params replays it: vdb_fractal_rock --params FILE -o OUT.");
    CLI::App& app = tool.app();
    tool.addParams(app, rockSchema());
    std::string meshPath, mapPath, up;
    app.add_option("--mesh", meshPath, "Also write the mesh: .obj (normals, UVs) or .ply (normals)")
        ->check(cli::writes({".obj", ".ply"}));
    tool.addUpAxis(app, "--mesh-up", up, "the mesh file");
    app.add_option("--normal-map", mapPath, "Also write the normal map (.exr; layout above; one rock)")
        ->check(cli::writes({".exr"}));
    std::string groundPath, pointsPath;
    app.add_option("--ground", groundPath, "Scatter ground: a heightfield image (.exr, .png; "
                                           "--ground-cell-size, --ground-height-scale) or a level "
                                           "set .vdb (--ground-grid); default the plane z = 0");
    std::string carvePath;
    app.add_option("--carve", carvePath, "Cave (§9): subtract a chain of --count rocks from this "
                                         "solid (a level set .vdb: 'surface' or its only one), "
                                         "on its voxels; writes the carved solid and 'cave'");
    app.add_option("--points", pointsPath, "Scatter: also write the instances as a VDB points "
                                           "grid 'rocks' (P, orient, pscale, scale: a radius-1 piece copied by Houdini's "
                                           "Copy to Points lands on each rock's ellipsoid; variant 0, id, rock) to this .vdb")
        ->check(cli::writes({".vdb"}));
    tool.addOutput(app, "Output .vdb: level set 'surface' ('-' = stdout)");
    tool.addStats(app);

    return tool.run(argc, argv, [&] {
        const FractalRockParams p = rockSchema().fromJson(tool.givenParams(rockSchema()));
        const UpAxis upAxis = upAxisFromString(up, "--mesh-up");
        cli::distinctOutputs({{"-o", tool.output()}, {"--mesh", meshPath}, {"--normal-map", mapPath},
                              {"--points", pointsPath}});
        for (const auto& path : {meshPath, mapPath, pointsPath}) {
            if (!path.empty()) requireWritable(path);
        }
        checkExtensions(meshPath, mapPath);
        FractalInputs in;
        in.groundPath = groundPath;
        in.carvePath = carvePath;
        in.normalMap = !mapPath.empty();
        in.mesh = !meshPath.empty();
        in.points = !pointsPath.empty();
        const FractalResult r = tool.stage([&](Task& task) { return runFractal(p, in, task); });
        if (!meshPath.empty()) writeMesh(r.mesh(), meshPath, upAxis);
        if (!mapPath.empty()) {
            writeNormalMap(mapPath, r.rock.normalMapWidth, r.rock.normalMapHeight, r.rock.normalMap,
                           p.normalSpace, upAxis);
        }
        if (r.scatter.points) writeGrids(pointsPath, {r.scatter.points});
        writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
    });
}
