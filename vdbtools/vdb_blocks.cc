// vdb_blocks — fractured block tiles (implicit-blocks-rocky-scenery.txt §4).
#include "Cli.h"

#include <blocks/BlockTile.h>
#include <core/Error.h>
#include <core/Expression.h>
#include <core/Image.h>
#include <core/Mesh.h>
#include <core/VdbIO.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>

using namespace rockvdb;
using namespace rockvdb::blocks;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_blocks",
        "Generate a periodic tile of fractured rock blocks (Paris et al., 'Modeling rocky "
        "scenery using implicit blocks', sec. 4): Poisson-sphere points in a periodic cube, a "
        "neighbour graph, fracture discs per block type cutting its edges, clusters split until "
        "no disc separates two of their points, one block per cluster = smooth intersection "
        "of its convex hull's planes, warped by a triplanar relief. Writes grid 'surface' and "
        "grid 'block_id' (float ids) over --periods tile periods, the tile description as "
        "metadata 'rockvdb:tile' (and with --tile as a standalone .tile file, what vdb_amplify "
        "reads), and statistics like the paper's Table 1 on stderr, ending with the line "
        "'vdb_blocks: generation: N.NNN s' (sampling through hulls).");
    CLI::App& app = tool.app();
    TileParams p;
    std::string type = "equidimensional", fractures, authored, tileOut, fromTile, meshes;
    std::vector<double> discRadius, axis{0, 0, 1};
    std::vector<int> periods{1, 1, 1};
    app.add_option("--type", type,
                   "Block type: equidimensional, prismatic, polyhedral, rhombohedral, tabular, "
                   "columnar")->capture_default_str();
    app.add_option("--tile-size", p.tileSize, "Tile side s (m)")->capture_default_str();
    app.add_option("--point-radius", p.pointRadius,
                   "Poisson radius of the sample points (m; 0 = 0.034*s, ~14 500 points)")
        ->capture_default_str();
    app.add_option("--neighbour-radius", p.neighbourRadius,
                   "Longest graph edge (m; 0 = 2*point radius)")->capture_default_str();
    app.add_option("--disc-count", p.discCount,
                   "Generated fracture discs (-1 = the type's default, 0 = none)")
        ->capture_default_str();
    app.add_option("--disc-spacing", p.discSpacing,
                   "Poisson radius of the disc centres (m; 0 = type default)")->capture_default_str();
    app.add_option("--disc-radius", discRadius, "Disc radius range min,max (m; type default)")
        ->delimiter(',')->expected(2);
    app.add_option("--jitter", p.jitterDeg, "Random tilt of the set normals (degrees; -1 = default)")
        ->capture_default_str();
    app.add_option("--irregular-fraction", p.irregularFraction,
                   "Share of discs with a random normal (-1 = default)")->capture_default_str();
    app.add_option("--axis", axis, "Dominant axis: bedding normal / column axis")
        ->delimiter(',')->expected(3)->capture_default_str();
    app.add_option("--oblique-angle", p.obliqueDeg,
                   "Rhombohedral: angle between the three set normals (degrees)")->capture_default_str();
    app.add_option("--fractures", fractures,
                   "JSON file of extra fracture discs: [{\"center\":[x,y,z],\"normal\":[x,y,z],"
                   "\"radius\":r}, ...] (tile coordinates, m)");
    app.add_option("--authored", authored,
                   "JSON file of authored blocks: [{\"type\":\"box\",\"center\":[..],\"size\":[..],"
                   "\"rotate\":[..]} or {\"type\":\"polytope\",\"planes\":[[nx,ny,nz,d],...]}, ...]");
    app.add_option("--min-points", p.minPoints,
                   "Clusters with fewer points join a neighbour whose joint hull holds no "
                   "third cluster's point, else stay blocks (with --no-fill: are dropped)")->capture_default_str();
    app.add_flag("--fill,!--no-fill", p.fill,
                 "Grow each block to its fractures: neighbours share a separating plane (the "
                 "disc's own where it separates them) and stand --fracture-width apart; "
                 "--no-fill: the paper's hull-only reading (neighbours about a point spacing "
                 "apart, small clusters dropped)")
        ->capture_default_str();
    app.add_option("--fracture-width", p.fractureWidth,
                   "Gap between neighbouring blocks across a fracture (m; -1 = 0.002 x tile "
                   "size; with --no-fill unused)")
        ->capture_default_str();
    app.add_option("--smooth-radius", p.smoothRadius,
                   "R of the smooth intersection of the hull planes (m)")->capture_default_str();
    app.add_option("--warp-amplitude", p.relief.amplitude,
                   "Relief warp amplitude (m; the surface moves at most this; 0 = off)")
        ->capture_default_str();
    app.add_option("--relief-image", p.relief.image,
                   "Relief image (single-channel EXR or 16-bit PNG, tiled; bright = bump); "
                   "default: procedural turbulence");
    app.add_option("--relief-scale", p.relief.scale,
                   "Relief wavelength / world size of one image tile (m)")->capture_default_str();
    app.add_option("--relief-octaves", p.relief.octaves, "Turbulence octaves")->capture_default_str();
    app.add_option("--relief-sharpness", p.relief.sharpness,
                   "Exponent p of the triplanar weights |g.u_i|^p (1 = the paper's)")
        ->capture_default_str();
    app.add_option("--periods", periods, "Tile periods baked along x,y,z")
        ->delimiter(',')->expected(3)->capture_default_str();
    app.add_option("--tile", tileOut, "Also write the tile description to this .tile file");
    app.add_option("--from-tile", fromTile,
                   "Bake an existing tile (.tile or a vdb_blocks .vdb) instead of generating one");
    app.add_option("--meshes", meshes, "Write one mesh per block (home frame) to .obj or .ply");
    std::string up = "z";
    app.add_option("--up", up, "Up axis of the --meshes file: z (rockvdb) or y (Blender's OBJ "
                               "import default, Houdini)")->capture_default_str();
    tool.addSeed(app);
    tool.addBakeOptions(app);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        const BakeSettings settings = tool.bake().settings();
        const UpAxis upAxis = upAxisFromString(up, "blocks: --up");
        {
            // The tile field is exact up to s/4 from the blocks; a renormalised bake reads
            // values up to about 2·band + a voxel + 2·amplitude. Refuse before generating.
            const double need = (2.0 * settings.halfWidth * settings.voxelSize +
                                 settings.voxelSize + 2.0 * p.relief.amplitude) * 1.01;
            if (fromTile.empty() && need > p.tileSize / 4) {
                fail<ValueError>("blocks: voxel size ", settings.voxelSize, " m is too coarse for a ",
                                 p.tileSize, " m tile (the band needs ", need,
                                 " m, the tile field is exact to tile size / 4)");
            }
        }
        if (!tileOut.empty()) requireWritable(tileOut);
        if (!meshes.empty()) requireWritable(meshes);
        std::shared_ptr<BlockTile> tile;
        if (!fromTile.empty()) {
            tile = std::make_shared<BlockTile>(readTile(fromTile));
        } else {
            p.type = blockTypeFromString(type);
            p.seed = tool.seed();
            if (!discRadius.empty()) {
                require(std::isfinite(discRadius[0]) && discRadius[0] > 0, "blocks",
                        "disc radius (min)", "> 0", discRadius[0]);
                p.discRadiusMin = discRadius[0];
                p.discRadiusMax = discRadius[1];
            }
            p.axis = cli::toVec3(axis, "--axis");
            if (!fractures.empty()) {
                const nlohmann::json j = readJsonFile(fractures);
                p.extraDiscs = TileParams::fromJson({{"fractures", j}}).extraDiscs;
            }
            if (!authored.empty()) {
                const nlohmann::json j = readJsonFile(authored);
                p.authored = TileParams::fromJson({{"authored", j}}).authored;
            }
            if (!p.relief.image.empty() && p.relief.amplitude > 0) {
                // Fail before generating: unreadable or multi-channel reliefs are errors.
                readGrayImage(p.relief.image, "relief");
            }
            tile = std::make_shared<BlockTile>(generateTile(p));
            const TileStats& s = tile->stats;
            char line[512];
            std::snprintf(line, sizeof line,
                          "%s tile %g m: #P %zu points, #D %zu discs, #B %zu blocks, mean #Pi %.1f "
                          "(%zu edges, %zu cut; %zu visibility splits, %zu wrap cuts; dropped %zu "
                          "clusters, %zu points; merged %zu, %zu small blocks)",
                          blockTypeName(tile->params.type), tile->size(), s.points, s.discs,
                          s.blocks, s.meanPoints, s.edges, s.cutEdges, s.visibilitySplits,
                          s.wrapCuts, s.droppedClusters, s.droppedPoints, s.mergedClusters,
                          s.smallBlocks);
            tool.info(line);
            std::snprintf(line, sizeof line,
                          "sampling %.3f s, graph %.3f s, fracturing %.3f s, clustering %.3f s, "
                          "hulls %.3f s",
                          s.sampling, s.graph, s.fracturing, s.clustering, s.hulls);
            tool.info(line);
            std::snprintf(line, sizeof line, "generation: %.3f s", s.generation);
            tool.info(line);
        }
        TileFieldOptions opt;
        opt.periods = {periods[0], periods[1], periods[2]};
        BakeSettings bs = settings;
        bs.withAttribute = true;
        bs.attributeName = "block_id";
        auto field = tileField(tile, opt);
        auto bar = tool.progress("baking");
        BakeResult r = bake(*field, bs, bar.get());
        bar->end();
        char line[256];
        std::snprintf(line, sizeof line, "bake: %zu active voxels, cull %.3f s, fill %.3f s, "
                      "finish %.3f s", r.stats.activeVoxels, r.stats.cullSeconds,
                      r.stats.fillSeconds, r.stats.finishSeconds);
        tool.info(line);
        const std::string params = tool.paramsJson();
        stampProvenance(*r.surface, tool.name(), params);
        stampProvenance(*r.attribute, tool.name(), params);
        r.surface->insertMeta("rockvdb:tile", openvdb::StringMetadata(tileToJson(*tile).dump()));
        writeGrids(tool.output(), {r.surface, r.attribute});
        // The tile file after the grids: a failed bake leaves no file at all.
        if (!tileOut.empty()) writeTile(*tile, tileOut);

        if (!meshes.empty()) {
            Mesh all;
            all.groupName = "block";
            for (size_t j = 0; j < tile->blocks.size(); ++j) {
                BakeSettings one = settings;
                auto g = bake(*blockField(tile, j), one).surface;
                appendMesh(all, meshLevelSet(*g), int(j));
            }
            writeMesh(all, meshes, upAxis);
            tool.info("wrote " + std::to_string(tile->blocks.size()) + " block meshes to " + meshes);
        }
    });
}
