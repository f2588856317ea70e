// SPDX-License-Identifier: Apache-2.0
// vdb_rockpile — rock tiles in contact (aperiodic corner cubes or one periodic cube) and rock
// piles: options from the stage's tables, work in runTiles / runPile (RockPileStage.h).
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/rockpile/RockPileStage.h>


using namespace rockvdb;
using namespace rockvdb::rockpile;

namespace {

void tilesCommand(cli::Tool& tool, const std::string& library, double maxMemoryGB)
{
    const RockTileParams p = tilesSchema().fromJson(tool.givenParams(tilesSchema()));
    cli::distinctOutputs({{"-o", tool.output()}, {"--library", library}});
    if (!library.empty()) requireWritable(library);
    const TilesResult r = tool.stage([&](Task& task) {
        return runTiles(p, !library.empty(), task, maxMemoryGB * 1e9);
    });
    if (r.library) writeGrids(library, {r.libraryIds, r.library});
    writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
}

void pileCommand(cli::Tool& tool, PileInputs in, const std::string& pointsPath,
                 const std::string& library)
{
    const PileParams p = pileSchema().fromJson(tool.givenParams(pileSchema()));
    cli::distinctOutputs({{"-o", tool.output()}, {"--points", pointsPath}, {"--library", library}});
    for (const auto& path : {pointsPath, library}) {
        if (!path.empty()) requireWritable(path);
    }
    in.points = !pointsPath.empty();
    in.library = !library.empty();
    const PileResult r = tool.stage([&](Task& task) { return runPile(p, in, task); });
    if (r.points) writeGrids(pointsPath, {r.points});
    if (r.library) writeGrids(library, {r.libraryIds, r.library});
    writeGrids(tool.output(), {r.grids.begin(), r.grids.end()});
}

} // namespace

int main(int argc, char** argv)
{
    cli::Tool tool(kToolName,
        "Rocks in contact without simulation (aperiodic-rock-piles.txt; arches §5). 'tiles' "
        "generates a tile set: cubes of n³ cells with seeds, each rock the discrete "
        "(anisotropic, d_k = f_k/g_k) Voronoi cell of its seed, contacts found by bisection on "
        "[p_i p_j], and spheroidal erosion damped within a..b of the contacts. Aperiodic sets "
        "hold the 2 vertex, 12 edge, 48 face and 256 centre regions of the 2-colour corner "
        "cubes, so rocks straddling cube faces match in every compatible neighbour. The file "
        "is a .vdb: fog volume 'rho' with every unique rock's erosion state in its own slot "
        "(the rock field is r = 2 rho - 1, trilinear), and the tile description as metadata "
        "'rockvdb:tiles'; --library writes the rocks' level sets too. Lengths in cells unless "
        "stated (a cell is cube-size / n metres). 'pile' fills a support with a tile set's "
        "rocks. Every grid's rockvdb:params replays it: vdb_rockpile <subcommand> --params "
        "FILE -o OUT.");
    CLI::App& app = tool.app();
    app.require_subcommand(1);

    auto* tiles = app.add_subcommand("tiles", tilesSchema().summary());
    tool.addParams(*tiles, tilesSchema());
    std::string library;
    tiles->add_option("--library", library,
                      "Also write every rock's level set, each in its own slot of level set "
                      "'library', with 'rock_id' (the rock's index on its voxels), to this .vdb")
        ->check(cli::writes({".vdb"}));
    double tilesMaxMemoryGB = 0;
    tiles->add_option("--max-memory", tilesMaxMemoryGB,
                      "Refuse a tile set estimated above this before any work (GB; 0 = 75% of RAM)")
        ->capture_default_str();
    tool.addOutput(*tiles, "Output tile set (.vdb, or .tiles: a .vdb by another name; '-' = stdout)",
                   {".vdb", ".tiles"});
    tool.addStats(*tiles);

    auto* pile = app.add_subcommand("pile", pileSchema().summary());
    std::string tilesPath, supportPath, pointsPath, pileLibrary;
    pile->add_option("--tiles", tilesPath, "Tile set file written by 'tiles'")->required();
    pile->add_option("--support", supportPath,
                     "The pile's shape: a level set .vdb, a JSON expression of primitives "
                     "(.json, as vdb_primitive expr) or a closed mesh (.obj, .stl, .ply)")
        ->required();
    tool.addParams(*pile, pileSchema());
    pile->add_option("--points", pointsPath,
                     "Also write the instances as a VDB points grid 'rocks' for Houdini's Copy to "
                     "Points (P, orient, pscale, variant = the library's rock_id, pivot = that "
                     "rock's seed in the library, id, rock, tile) to this .vdb")
        ->check(cli::writes({".vdb"}));
    pile->add_option("--library", pileLibrary,
                     "Also write every library rock's level set (slot offsets in metadata) and "
                     "'rock_id' to this .vdb")
        ->check(cli::writes({".vdb"}));
    tool.addOutput(*pile, "Output .vdb: surface (union of the rocks) and rock_id ('-' = stdout)");
    tool.addStats(*pile);
    tool.addDistribution(*pile);

    return tool.run(argc, argv, [&] {
        if (tiles->parsed()) {
            tilesCommand(tool, library, tilesMaxMemoryGB);
        } else {
            PileInputs in;
            in.tilesPath = tilesPath;
            in.supportPath = supportPath;
            pileCommand(tool, in, pointsPath, pileLibrary);
        }
    });
}
