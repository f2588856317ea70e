// vdb_rockpile — rock tiles in contact (aperiodic corner cubes or one periodic cube) and rock
// piles: options from the stage's tables, work in runTiles / runPile (RockPileStage.h).
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/rockpile/RockPileStage.h>

#include <cstdio>

using namespace rockvdb;
using namespace rockvdb::rockpile;

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
                      "'library', to this .vdb");
    double tilesMaxMemoryGB = 0;
    tiles->add_option("--max-memory", tilesMaxMemoryGB,
                      "Refuse a tile set estimated above this before any work (GB; 0 = 75% of RAM)")
        ->capture_default_str();
    tool.addOutput(*tiles, "Output tile set (.vdb; '-' = stdout)");

    auto* pile = app.add_subcommand("pile", pileSchema().summary());
    std::string tilesPath, supportPath, pointsPath, pileLibrary;
    pile->add_option("--tiles", tilesPath, "Tile set file written by 'tiles'")->required();
    pile->add_option("--support", supportPath,
                     "The pile's shape: a level set .vdb, a JSON expression of primitives "
                     "(.json, as vdb_primitive expr) or a closed mesh (.obj, .stl, .ply)")
        ->required();
    tool.addParams(*pile, pileSchema());
    pile->add_option("--points", pointsPath,
                     "Also write the instances as a VDB points grid 'rocks' (P, rock, tile, "
                     "instance) to this .vdb");
    pile->add_option("--library", pileLibrary,
                     "Also write every library rock's level set (slot offsets in metadata)");
    tool.addOutput(*pile, "Output .vdb: surface (union of the rocks) and rock_id ('-' = stdout)");
    tool.addDistribution(*pile);

    return tool.run(argc, argv, [&] {
        auto bar = tool.taskBar();
        Task task(bar.get());
        char line[300];
        if (tiles->parsed()) {
            const RockTileParams p = tilesSchema().fromJson(tool.givenParams(tilesSchema()));
            cli::distinctOutputs({{"-o", tool.output()}, {"--library", library}});
            if (!library.empty()) requireWritable(library);
            require(std::isfinite(tilesMaxMemoryGB) && tilesMaxMemoryGB >= 0, "rockpile",
                    "--max-memory", ">= 0 GB", tilesMaxMemoryGB);
            const TilesResult r = runTiles(p, !library.empty(), task, tilesMaxMemoryGB * 1e9);
            bar->clear();
            const RockTileStats& st = r.set.stats;
            std::snprintf(line, sizeof line, "%zu stones (%zu regions, %zu seeds, %zu contacts); "
                          "seeds %.3f s, voronoi + erosion %.3f s", st.stones, st.regions,
                          st.seeds, st.contacts, st.seedSeconds, st.voronoiSeconds);
            tool.info(line);
            if (r.library) {
                std::snprintf(line, sizeof line, "level sets %.3f s", r.librarySeconds);
                tool.info(line);
                writeGrids(library, {r.library});
            }
            writeGrids(tool.output(), {r.rho});
            return;
        }
        const PileParams p = pileSchema().fromJson(tool.givenParams(pileSchema()));
        cli::distinctOutputs({{"-o", tool.output()}, {"--points", pointsPath}, {"--library", pileLibrary}});
        for (const auto& path : {pointsPath, pileLibrary}) {
            if (!path.empty()) requireWritable(path);
        }
        const TileSet set = readTileSet(tilesPath);
        const FieldPtr support = loadSupport(supportPath, set, p.seed, p.support);
        const PileResult r = runPile(set, *support, p, {{"tiles", tilesPath}, {"support", supportPath}},
                                     !pointsPath.empty(), !pileLibrary.empty(), task);
        bar->clear();
        std::snprintf(line, sizeof line,
                      "placed %zu rocks (%zu candidates in %zu tile features, %zu too deep); "
                      "select %.3f s, level sets %.3f s (%.0f rocks/s)",
                      r.stats.placed, r.stats.candidates, r.stats.features, r.stats.droppedDeep,
                      r.stats.selectSeconds, r.stats.levelSetSeconds,
                      double(r.stats.placed) / std::max(1e-9, r.stats.selectSeconds + r.stats.levelSetSeconds));
        tool.info(line);
        cli::refuseEmpty(*r.pile.surface, "no rock of the tile set lies in the support (is it "
                         "smaller than a rock, or only a thin shell?)");
        if (r.points) writeGrids(pointsPath, {r.points});
        if (r.library) writeGrids(pileLibrary, {r.library});
        openvdb::GridCPtrVec out{r.pile.surface, r.pile.rockId};
        if (r.pile.material) out.push_back(r.pile.material);
        writeGrids(tool.output(), out);
    });
}
