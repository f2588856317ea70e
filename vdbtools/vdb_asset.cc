// vdb_asset — a level set as a game asset: one GLB with levels of detail (meshoptimizer), a UV
// atlas and a normal map per LOD baked from the level set (ops/asset, runAsset).
#include "Cli.h"

#include <rockvdb/asset/AssetStage.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

using namespace rockvdb;
using namespace rockvdb::asset;

int main(int argc, char** argv)
{
    cli::Tool tool(kAssetTool, assetSchema().summary() +
        " Each LOD is a node <name>_LOD<i> with POSITION, NORMAL, TANGENT, TEXCOORD_0 and its "
        "own material and normal map; rockvdb's z up becomes glTF's y up; the provenance sits "
        "in the asset's extras.");
    CLI::App& app = tool.app();
    std::string input, gridName;
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid (default: 'surface', else the only level set)");
    tool.addParams(app, assetSchema());
    tool.addOutput(app, "Output .glb ('-' = stdout)");
    tool.addStats(app);

    return tool.run(argc, argv, [&] {
        const AssetParams p = assetSchema().fromJson(tool.givenParams(assetSchema()));
        const std::string out = tool.output();
        if (out != "-" && (out.size() < 4 || out.compare(out.size() - 4, 4, ".glb") != 0)) {
            fail<ValueError>("the output must be a .glb file (got '", out, "')");
        }
        requireWritable(out);
        AssetInputs in;
        in.grid = readLevelSet(input, gridName);
        in.names = {{"input", input}, {"grid", in.grid->getName()}};
        const AssetResult r = tool.stage([&](Task& task) { return runAsset(p, in, task); });
        writeFileAtomic(out, r.glb);
    });
}
