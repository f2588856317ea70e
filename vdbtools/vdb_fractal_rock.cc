// vdb_fractal_rock — fractal rocks from an icosahedron (fractal-rocks-midpoint-displacement.txt):
// options from the stage's table, work in runRock (FractalStage.h).
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/fractal/FractalStage.h>

#include <cstdio>

using namespace rockvdb;
using namespace rockvdb::fractal;

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
        "instances (P, orient, pscale, rock) as a VDB points grid 'rocks' in its own file. ") +
        normalMapHelp() +
        " With --carve SOLID.vdb --count N, a chain of N rocks is subtracted from the solid (§9: "
        "caves). The output's rockvdb:params replays it: vdb_fractal_rock --params FILE -o OUT.");
    CLI::App& app = tool.app();
    tool.addParams(app, rockSchema());
    std::string meshPath, mapPath, up = "z";
    app.add_option("--mesh", meshPath, "Also write the mesh: .obj (normals, UVs) or .ply (normals)");
    app.add_option("--mesh-up", up, "Up axis of the mesh file: z (rockvdb) or y (Blender's OBJ "
                                    "import default, Houdini)")->check(CLI::IsMember({"z", "y"}))
        ->capture_default_str();
    app.add_option("--normal-map", mapPath, "Also write the normal map (.exr; layout above; one rock)");
    std::string groundPath, pointsPath;
    app.add_option("--ground", groundPath, "Scatter ground: a heightfield image (.exr, .png; "
                                           "--ground-cell-size, --ground-height-scale) or a level "
                                           "set .vdb (--ground-grid); default the plane z = 0");
    std::string carvePath;
    app.add_option("--carve", carvePath, "Cave (§9): subtract a chain of --count rocks from this "
                                         "solid (a level set .vdb: 'surface' or its only one), "
                                         "on its voxels; writes the carved solid and 'cave'");
    app.add_option("--points", pointsPath, "Scatter: also write the instances as a VDB points "
                                           "grid 'rocks' (P, orient, pscale, rock) to this .vdb");
    tool.addOutput(app, "Output .vdb: level set 'surface' ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        const FractalRockParams p = rockSchema().fromJson(tool.givenParams(rockSchema()));
        const UpAxis upAxis = upAxisFromString(up, "--mesh-up");
        cli::distinctOutputs({{"-o", tool.output()}, {"--mesh", meshPath}, {"--normal-map", mapPath},
                              {"--points", pointsPath}});
        for (const auto& path : {meshPath, mapPath}) {
            if (!path.empty()) requireWritable(path);
        }
        // Wrong extensions are refused before any work, so no output is written half.
        auto ends = [](const std::string& s, const char* ext) {
            const std::string e(ext);
            return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
        };
        if (!mapPath.empty() && !ends(mapPath, ".exr")) {
            fail<ValueError>("fractal: --normal-map '", mapPath, "' must end in .exr");
        }
        if (!meshPath.empty() && meshPath != "-" && !ends(meshPath, ".obj") && !ends(meshPath, ".ply")) {
            fail<ValueError>("fractal: --mesh '", meshPath, "' must end in .obj or .ply");
        }
        if (!mapPath.empty() && ends(meshPath, ".ply")) {
            fail<ValueError>("fractal: a normal map needs the OBJ's UVs; write --mesh as .obj");
        }
        if (!carvePath.empty()) {
            if (!mapPath.empty() || !groundPath.empty() || !pointsPath.empty() || !meshPath.empty()) {
                fail<ValueError>("fractal: --carve writes the carved solid only (no --normal-map, "
                                 "--ground, --points or --mesh)");
            }
            const openvdb::GridPtrVecPtr grids = readGrids(carvePath);
            const auto solid = findLevelSet(*grids, "", carvePath);
            auto bar = tool.taskBar();
            Task task(bar.get());
            const CarveResult r = runCarve(p, *solid, {{"carve", carvePath}}, task);
            bar->clear();
            char line[200];
            std::snprintf(line, sizeof line, "carved a chain of %zu rocks (%zu cave voxels)",
                          r.rocks.size(), size_t(r.cave->activeVoxelCount()));
            tool.info(line);
            writeGrids(tool.output(), {r.surface, r.cave});
            return;
        }
        if (p.count > 0) {
            if (!mapPath.empty()) fail<ValueError>("fractal: --normal-map is for a single rock (count 0)");
            if (!pointsPath.empty()) requireWritable(pointsPath);
            const auto ground = loadGround(groundPath, p);
            auto bar = tool.taskBar();
            Task task(bar.get());
            nlohmann::json inputs = nlohmann::json::object();
            if (!groundPath.empty()) inputs["ground"] = groundPath;
            const ScatterResult r = runScatter(p, *ground, inputs, !pointsPath.empty(), !meshPath.empty(), task);
            bar->clear();
            char line[300];
            std::snprintf(line, sizeof line,
                          "placed %zu of %zu rocks (%zu candidates: %zu by density, %zu by overlap); "
                          "place %.3f s, meshes %.3f s, level set %.3f s (%.0f rocks/s)",
                          r.stats.placed, r.stats.asked, r.stats.candidates, r.stats.rejectedDensity,
                          r.stats.rejectedOverlap, r.stats.placeSeconds, r.stats.meshSeconds,
                          r.stats.levelSetSeconds,
                          double(r.stats.placed) / std::max(1e-9, r.stats.placeSeconds + r.stats.meshSeconds + r.stats.levelSetSeconds));
            tool.info(line);
            if (r.stats.placed < r.stats.asked) {
                std::snprintf(line, sizeof line, "warning: only %zu of %zu rocks fit (raise --attempts or "
                              "--area, lower --size or --density-contrast)", r.stats.placed, r.stats.asked);
                tool.info(line);
            }
            if (!meshPath.empty()) writeMesh(r.mesh, meshPath, upAxis);
            if (r.points) writeGrids(pointsPath, {r.points});
            openvdb::GridCPtrVec out{r.rockId};
            if (r.material) out.push_back(r.material);
            out.push_back(r.surface);
            writeGrids(tool.output(), out);
            return;
        }
        if (!groundPath.empty() || !pointsPath.empty()) {
            fail<ValueError>("fractal: --ground and --points are for a scatter (--count N)");
        }
        auto bar = tool.taskBar();
        Task task(bar.get());
        const RockResult r = runRock(p, true, !mapPath.empty(), task);
        bar->clear();
        char line[300];
        std::snprintf(line, sizeof line,
                      "%zu triangles, %zu vertices, volume %.4f m3; mesh %.4f s, level set %.4f s "
                      "(%zu active voxels)%s",
                      r.stats.triangles, r.stats.vertices, r.stats.volume, r.stats.meshSeconds,
                      r.stats.levelSetSeconds, r.stats.activeVoxels,
                      mapPath.empty() ? "" : (", normal map " + std::to_string(r.stats.normalMapSeconds) + " s").c_str());
        tool.info(line);
        if (!meshPath.empty()) writeMesh(r.mesh, meshPath, upAxis);
        if (!mapPath.empty()) writeRgbExr(mapPath, r.normalMapWidth, r.normalMapHeight, r.normalMap);
        writeGrids(tool.output(), {r.surface});
    });
}
