// SPDX-License-Identifier: Apache-2.0
// vdb_preview — a shaded PNG of a level set, camera framing its bounding box.
#include "Cli.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Preview.h>
#include <rockvdb/core/VdbIO.h>

#include <cstdio>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_preview", previewSchema().summary() + " --ids tints each id; --texture textures the "
                                  "ground by its weight_* grids (arches §6).");
    CLI::App& app = tool.app();
    std::string input, gridName = "surface", idsName;
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid to render")->capture_default_str();
    app.add_option("--ids", idsName, "Id grid (e.g. block_id) to tint surfaces by id");
    tool.addParams(app, previewSchema());
    std::string palette;
    app.add_option("--palette", palette,
                   "Colours per id for --ids, ID=#rrggbb[,ID=#rrggbb...] (sRGB); other ids get "
                   "a colour hashed from the id");
    tool.addOutput(app, "Output .png", {".png"});

    return tool.run(argc, argv, [&] {
        PreviewSettings s = previewSchema().fromJson(tool.givenParams(previewSchema()));
        if (!palette.empty()) s.palette = parsePalette(palette, "preview: --palette");
        auto grids = readGrids(input);
        const std::string src = input == "-" ? "<stdin>" : input;
        auto grid = findLevelSet(*grids, gridName, src);
        openvdb::FloatGrid::Ptr ids;
        if (!idsName.empty()) {
            for (const auto& g : *grids) {
                if (g && g->getName() == idsName) ids = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
            }
            if (!ids) fail<ValueError>("no float grid '", idsName, "' in '", src, "'");
        }
        PreviewStats st;
        const std::vector<PreviewMaterial> materials = s.texture ? previewMaterials(*grids) : std::vector<PreviewMaterial>();
        if (s.texture && materials.empty()) {
            fail<ValueError>("preview: --texture needs weight_* grids, and '", src, "' has none (vdb_arches writes "
                             "them unless --no-weights)");
        }
        writePreview(*grid, tool.output(), s, ids.get(), &st, &materials);
        // What the picture shows, per id: a part that is hidden shows up here as 0%.
        char line[64];
        std::snprintf(line, sizeof line, "surface %.1f%% of the image",
                      100.0 * double(st.surfacePixels) / double(st.pixels));
        std::string msg = line;
        if (ids) {
            msg += "; by " + idsName + ":";
            for (const auto& [id, n] : st.idPixels) {
                std::snprintf(line, sizeof line, " %d %.1f%%", id,
                              100.0 * double(n) / double(st.pixels));
                msg += line;
            }
        }
        if (!materials.empty()) {
            msg += "; by material:";
            for (const auto& [name, n] : st.materialPixels) {
                std::snprintf(line, sizeof line, " %s %.1f%%", name.c_str(), 100.0 * double(n) / double(st.pixels));
                msg += line;
            }
        }
        tool.info(msg);
    });
}
