// vdb_heightfield — a heightfield image to a narrow-band level set of the terrain solid.
#include "Cli.h"

#include <rockvdb/core/Heightfield.h>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_heightfield",
        "Bake a heightfield image (single-channel float EXR or 16-bit greyscale PNG) into a "
        "narrow-band level set of the terrain solid (grid 'surface'), with true Euclidean "
        "distance near the surface, steep slopes included. Pixel column i, row j (row 0 = first "
        "row stored in the file) sits at x = i*cell-size, y = j*cell-size, z = "
        "value*height-scale; EXR values are metres before scaling, 16-bit PNG values map "
        "0..65535 to 0..1 before scaling. The solid is closed by vertical walls at the image "
        "border and a floor base-depth below the lowest sample.");
    CLI::App& app = tool.app();
    std::string input;
    double cellSize = 1.0, heightScale = 1.0, baseDepth = 1.0;
    app.add_option("image", input, "Heightfield .exr or .png")->required();
    app.add_option("--cell-size", cellSize, "Distance between pixel centres (m)")->capture_default_str();
    app.add_option("--height-scale", heightScale, "Metres per image unit")->capture_default_str();
    app.add_option("--base-depth", baseDepth, "Floor depth below the lowest sample (m)")
        ->capture_default_str();
    tool.addBakeOptions(app);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        const BakeSettings settings = tool.bake().settings();
        auto hf = std::make_shared<Heightfield>(loadHeightfield(input, cellSize, heightScale,
                                                                   settings.maxMemoryBytes));
        HeightfieldSettings hs;
        hs.baseDepth = baseDepth;
        cli::bakeAndWrite(tool, *heightfieldField(hf, hs), settings);
        tool.info(std::to_string(hf->nx) + "x" + std::to_string(hf->ny) + " samples");
    });
}
