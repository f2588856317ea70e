// SPDX-License-Identifier: Apache-2.0
// vdb_asset — a level set as a game asset: one GLB with levels of detail (meshoptimizer), a UV
// atlas, normal and occlusion maps per LOD baked from the level set, and a convex collision
// hull (ops/asset, runAsset); one block or rock by --id, or every one by --each-id.
#include "Cli.h"

#include <rockvdb/asset/AssetStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

using namespace rockvdb;
using namespace rockvdb::asset;

namespace {

bool endsWithGlb(const std::string& s)
{
    return s.size() >= 4 && s.compare(s.size() - 4, 4, ".glb") == 0;
}

} // namespace

int main(int argc, char** argv)
{
    cli::Tool tool(kAssetTool, assetSchema().summary() +
        " Each LOD is a node <name>_LOD<i> with POSITION, NORMAL, TANGENT, TEXCOORD_0 and its "
        "own material with normal and occlusion maps; rockvdb's z up becomes glTF's y up; the "
        "provenance sits in the asset's extras. --id N cuts one block or rock out of the id "
        "grid; --each-id writes one GLB per id, -o holding '{id}' (e.g. rocks/rock_{id}.glb); "
        "--tiles makes the input a rock pile's points (vdb_rockpile pile --points): one GLB whose "
        "unique rocks are drawn at every instance by EXT_mesh_gpu_instancing.");
    CLI::App& app = tool.app();
    std::string input, gridName, idGridName, tilesPath, maskGrid;
    bool eachId = false;
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid (default: 'surface', else the only level set)");
    app.add_option("--id-grid", idGridName,
                   "Id grid for --id / --each-id (default: 'block_id', else 'rock_id')");
    app.add_option("--mask-grid", maskGrid,
                   "Bake this id grid of the input (e.g. material, block_id) into a grey mask "
                   "texture per LOD: the id at each texel, 255 (65535 with --map-bits 16) where "
                   "none is; referenced from the material's extras 'rockvdb_mask'");
    app.add_flag("--each-id", eachId, "One asset per id of the id grid, named <name>_<id>, written "
                 "where -o's '{id}' is replaced by the id");
    app.add_option("--tiles", tilesPath,
                   "The tile set (vdb_rockpile tiles) of a pile whose points are the input: its "
                   "unique rocks as assets <name>_<rock>, instanced (EXT_mesh_gpu_instancing)");
    tool.addParams(app, assetSchema());
    tool.addOutput(app, "Output .glb ('-' = stdout; with --each-id a path holding '{id}')", {".glb"});
    tool.addStats(app);

    return tool.run(argc, argv, [&] {
        const AssetParams p = assetSchema().fromJson(tool.givenParams(assetSchema()));
        const std::string out = tool.output();
        if (out != "-" && !endsWithGlb(out)) {
            fail<ValueError>("the output must be a .glb file (got '", out, "')");
        }
        const size_t slot = out.find("{id}");
        if (eachId && slot == std::string::npos) {
            fail<ValueError>("--each-id writes one file per id: -o must hold '{id}' (got '", out, "')");
        }
        if (!eachId && slot != std::string::npos) {
            fail<ValueError>("-o holds '{id}' but --each-id is not given (got '", out, "')");
        }
        if (eachId && p.id >= 0) fail<ValueError>("--each-id and --id exclude each other");
        auto at = [&](int id) {
            return out.substr(0, slot) + std::to_string(id) + out.substr(slot + 4);
        };
        requireWritable(eachId ? at(0) : out);

        if (!tilesPath.empty()) {
            if (eachId || p.id >= 0 || !gridName.empty() || !idGridName.empty() || !maskGrid.empty()) {
                fail<ValueError>("--tiles makes the input a pile's points: --each-id, --id, --grid, "
                                 "--id-grid and --mask-grid do not apply");
            }
            if (input == "-") fail<ValueError>("--tiles: the points must be a file, not stdin");
            const AssetResult r = tool.stage([&](Task& task) {
                const PileInstances pile = readPileInstances(input, tilesPath, 3.0, task);
                return runAssetInstances(p, pile, {{"input", input}, {"tiles", tilesPath}}, task);
            });
            writeFileAtomic(out, r.glb);
            return;
        }

        const auto grids = readGrids(input);
        AssetInputs in;
        in.grid = findLevelSet(*grids, gridName, input);
        in.names = {{"input", input}, {"grid", in.grid->getName()}};
        if (eachId || p.id >= 0) {
            in.ids = findIdGrid(*grids, idGridName, input);
            in.names["id-grid"] = in.ids->getName();
        }
        if (!maskGrid.empty()) {
            in.mask = findIdGrid(*grids, maskGrid, input);
            in.names["mask-grid"] = in.mask->getName();
        }
        if (eachId) {
            const AssetSetResult r = tool.stage([&](Task& task) { return runAssetEach(p, in, task); });
            for (const auto& [id, glb] : r.glbs) writeFileAtomic(at(id), glb);
            return;
        }
        const AssetResult r = tool.stage([&](Task& task) { return runAsset(p, in, task); });
        writeFileAtomic(out, r.glb);
    });
}
