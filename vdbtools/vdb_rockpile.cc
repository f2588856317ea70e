// vdb_rockpile — rock tiles in contact (aperiodic corner cubes or one periodic cube).
#include "Cli.h"

#include <core/Error.h>
#include <core/VdbIO.h>
#include <rockpile/RockPile.h>
#include <rockpile/RockTiles.h>

#include <nlohmann/json.hpp>

#include <cstdio>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_rockpile",
        "Rocks in contact without simulation (aperiodic-rock-piles.txt; arches §5). 'tiles' "
        "generates a tile set: cubes of n³ cells with seeds, each rock the discrete "
        "(anisotropic, d_k = f_k/g_k) Voronoi cell of its seed, contacts found by bisection on "
        "[p_i p_j], and spheroidal erosion damped within a..b of the contacts. Aperiodic sets "
        "hold the 2 vertex, 12 edge, 48 face and 256 centre regions of the 2-colour corner "
        "cubes, so rocks straddling cube faces match in every compatible neighbour. The file "
        "is a .vdb: fog volume 'rho' with every unique rock's erosion state in its own slot "
        "(the rock field is r = 2 rho - 1, trilinear), and the tile description as metadata "
        "'rockvdb:tiles'; --library writes the rocks' level sets too. Lengths in cells unless stated (a cell is "
        "cube-size / n metres).");
    CLI::App& app = tool.app();
    app.require_subcommand(1);
    rockpile::TileParams p;
    std::string tiling = "aperiodic";
    std::vector<int> seeds{1, 1};
    std::vector<double> aniso{1, 1, 1}, radii{p.contactInner, p.contactOuter};
    auto* tiles = app.add_subcommand("tiles", "Generate a tile set");
    tiles->add_option("--tiling", tiling, "aperiodic (2-colour corner cubes) | periodic (one cube)")
        ->capture_default_str();
    tiles->add_option("--n", p.n, "Cells per cube edge (aperiodic >= 4, periodic >= 3)")
        ->capture_default_str();
    tiles->add_option("--seeds-per-cell", seeds, "Seeds per cell n_k in [min,max] (s = max)")
        ->expected(2)->delimiter(',')->capture_default_str();
    tiles->add_option("--anisotropy", aniso,
                      "alpha,beta,gamma: relative rock extents along each seed's random frame "
                      "(5,5,1: flat rocks)")
        ->expected(3)->delimiter(',')->capture_default_str();
    tiles->add_option("--anisotropy-jitter", p.anisotropyJitter,
                      "Each coefficient uniform in [v(1-j), v]")->capture_default_str();
    tiles->add_option("--g-max", p.gMax, "g_k uniform in [1, g-max] (relative rock size)")
        ->capture_default_str();
    tiles->add_option("--voxels-per-cell", p.voxelsPerCell, "m: n_G = m n voxels per cube")
        ->capture_default_str();
    tiles->add_option("--cube-size", p.cubeSize, "Cube edge (m)")->capture_default_str();
    tiles->add_option("--contact-radii", radii, "a,b: no erosion within a, full beyond b (cells)")
        ->expected(2)->delimiter(',')->capture_default_str();
    tiles->add_option("--erosion-steps", p.erosionSteps, "Spheroidal erosion iterations")
        ->capture_default_str();
    tiles->add_option("--erosion-rate", p.erosionRate, "Erosion per step at full exposure")
        ->capture_default_str();
    tiles->add_option("--poisson-radius", p.poissonRadius,
                      "Periodic: seed spacing in cells (0 = 0.8)")->capture_default_str();
    std::string library;
    tiles->add_option("--library", library,
                      "Also write every rock's level set, each in its own slot of level set "
                      "'library', to this .vdb");
    tool.addSeed(*tiles);
    tool.addOutput(*tiles, "Output tile set (.vdb / .tiles; '-' = stdout)");
    auto* pile = app.add_subcommand("pile", "Fill a support object with a tile set's rocks");
    std::string tilesPath, supportPath, pointsPath, pileLibrary;
    rockpile::PileParams pp;
    bool keepDeep = false;
    pile->add_option("--tiles", tilesPath, "Tile set file written by 'tiles'")->required();
    pile->add_option("--support", supportPath,
                     "The pile's shape: a level set .vdb, a JSON expression of primitives "
                     "(.json, as vdb_primitive expr) or a closed mesh (.obj, .stl, .ply)")
        ->required();
    rockpile::SupportOptions supportOptions;
    std::string up = "z";
    pile->add_option("--support-grid", supportOptions.grid,
                     "Level set to read from a .vdb support (default: 'surface', else the "
                     "file's only level set)");
    pile->add_option("--up", up, "Up axis of a mesh support: z (rockvdb) or y (Blender's OBJ "
                                 "export default, Houdini)")->capture_default_str();
    pile->add_option("--material", pp.material,
                     "Also write grid 'material' holding this id on every rock voxel (to unite "
                     "the pile with other stages' material grids); -1 = none")
        ->capture_default_str();
    pile->add_option("--threshold", pp.threshold,
                     "Place a rock when this fraction of its anchors (voxel centres and seed) "
                     "is inside")->capture_default_str();
    pile->add_flag("--keep-deep", keepDeep,
                   "Keep rocks deeper than twice the largest embedding radius (dropped by default)");
    pile->add_option("--points", pointsPath,
                     "Also write the instances as a VDB points grid 'rocks' (P, rock, tile, "
                     "instance) to this .vdb");
    pile->add_option("--library", pileLibrary,
                     "Also write every library rock's level set (slot offsets in metadata)");
    tool.addSeed(*pile);
    tool.addOutput(*pile, "Output .vdb: surface (union of the rocks) and rock_id ('-' = stdout)");
    return tool.run(argc, argv, [&] {
        if (pile->parsed()) {
            auto grids = readGrids(tilesPath);
            openvdb::FloatGrid::Ptr rho;
            for (auto& g : *grids) {
                if (g->getName() == "rho") rho = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
            }
            if (!rho) fail<ValueError>("rockpile: ", tilesPath, " holds no tile set (grid 'rho')");
            const rockpile::TileSet set = rockpile::tilesFromGrid(*rho);
            pp.dropDeep = !keepDeep;
            pp.seed = tool.seed();
            pp.validate();
            supportOptions.up = upAxisFromString(up, "rockpile: --up");
            const FieldPtr support = rockpile::loadSupport(supportPath, set, tool.seed(),
                                                           supportOptions);
            rockpile::PileStats st;
            auto instances = rockpile::selectRocks(set, *support, pp, &st);
            rockpile::Pile result = rockpile::buildPile(set, instances, pp);
            char line[300];
            std::snprintf(line, sizeof line,
                          "placed %zu rocks (%zu candidates in %zu tile features, %zu too deep); "
                          "select %.3f s, level sets %.3f s (%.0f rocks/s)",
                          st.placed, st.candidates, st.features, st.droppedDeep, st.selectSeconds,
                          result.stats.levelSetSeconds,
                          double(st.placed) / std::max(1e-9, st.selectSeconds + result.stats.levelSetSeconds));
            tool.info(line);
            if (!pointsPath.empty()) {
                auto pts = rockpile::instancePoints(result.instances, set.params.cubeSize / set.params.n);
                stampProvenance(*pts, tool.name(), tool.paramsJson());
                writeGrids(pointsPath, {pts});
            }
            if (!pileLibrary.empty()) {
                auto lib = rockpile::libraryGrid(set);
                stampProvenance(*lib, tool.name(), tool.paramsJson());
                writeGrids(pileLibrary, {lib});
            }
            openvdb::GridCPtrVec out{result.surface, result.rockId};
            if (result.material) out.push_back(result.material);
            for (auto& g : out) {
                stampProvenance(*openvdb::ConstPtrCast<openvdb::GridBase>(g), tool.name(),
                                tool.paramsJson());
            }
            writeGrids(tool.output(), out);
            return;
        }
        if (tiling == "aperiodic") p.tiling = rockpile::Tiling::Aperiodic;
        else if (tiling == "periodic") p.tiling = rockpile::Tiling::Periodic;
        else fail<ValueError>("rockpile: --tiling must be aperiodic or periodic (got '", tiling, "')");
        p.seedsMin = seeds[0];
        p.seedsMax = seeds[1];
        for (int a = 0; a < 3; ++a) p.anisotropy[a] = aniso[size_t(a)];
        p.contactInner = radii[0];
        p.contactOuter = radii[1];
        p.seed = tool.seed();
        p.validate();
        rockpile::TileSet set = rockpile::generateTiles(p);
        openvdb::GridCPtrVec grids{rockpile::tileGrid(set)};
        const auto& st = set.stats;
        char line[256];
        std::snprintf(line, sizeof line, "%zu stones (%zu regions, %zu seeds, %zu contacts)",
                      st.stones, st.regions, st.seeds, st.contacts);
        tool.info(line);
        double lsSeconds = -1;
        if (!library.empty()) {
            auto lib = rockpile::libraryGrid(set, 3.0, &lsSeconds);
            stampProvenance(*lib, tool.name(), tool.paramsJson());
            writeGrids(library, {lib});
        }
        std::snprintf(line, sizeof line, "phases: seeds %.3f s, voronoi + erosion %.3f s%s",
                      st.seedSeconds, st.voronoiSeconds,
                      lsSeconds >= 0 ? (", level sets " + std::to_string(lsSeconds).substr(0, 5) + " s").c_str() : "");
        tool.info(line);
        for (auto& g : grids) {
            stampProvenance(*openvdb::ConstPtrCast<openvdb::GridBase>(g), tool.name(),
                            tool.paramsJson());
        }
        writeGrids(tool.output(), grids);
    });
}
