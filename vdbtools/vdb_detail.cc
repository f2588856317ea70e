// vdb_detail — surface detail on any level set: gradient warp (implicit-blocks §4.2) and
// Gabor details (gabor-details-implicit-surfaces §3–§4).
#include "Cli.h"

#include <core/Error.h>
#include <core/Expression.h>
#include <core/VdbIO.h>
#include <detail/Detail.h>

#include <nlohmann/json.hpp>

#include <cstdio>

using namespace rockvdb;

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_detail",
        "Add small-scale rock detail to a level set and re-bake it (renormalised); the file's "
        "id grids (block_id, material, ...) are carried onto the result. Gradient "
        "warp (Paris et al. sec. 4.2): the surface moves along its normal by a relief d seen "
        "through three axis projections blended by |g.u_i|^p (p = --warp-sharpness; 8, the "
        "arches paper's texture blend, keeps one projection's detail sharp instead of "
        "ghosting three; 1 is the blocks paper's weights). Gabor details (Gabor surface noise "
        "in local frames (n, t, b), b = n ^ W): each point near the surface is projected on it "
        "(along the normal, or tilted by --tilt) and the field is raised or lowered by "
        "D(noise)·(1 - |p p_S|/R)^6. W comes from --direction-axis, --direction-skeleton or "
        "--direction-curvature. Amplitudes are in metres and bound the displacement; 0 "
        "disables an operator.");
    CLI::App& app = tool.app();
    std::string input, gridName = "surface";
    app.add_option("input", input, "Input .vdb ('-' = stdin)")->required();
    app.add_option("--grid", gridName, "Level-set grid to detail")->capture_default_str();
    // Defaults are DetailParams::fromJson's (the Python names); the options fill that JSON.
    detail::DetailParams p = detail::DetailParams::fromJson(nlohmann::json::object());
    std::string relief = "turbulence";
    app.add_option("--warp-amplitude", p.warp.amplitude, "Warp: largest displacement (m); 0 = off")
        ->capture_default_str();
    app.add_option("--warp-relief", relief,
                   "Warp relief: 'turbulence' or an EXR / 16-bit PNG image (bright = bump)")
        ->capture_default_str();
    app.add_option("--warp-scale", p.warp.scale,
                   "Warp: turbulence wavelength, or world size of one image tile (m)")
        ->capture_default_str();
    app.add_option("--warp-octaves", p.warp.octaves, "Warp: turbulence octaves")->capture_default_str();
    app.add_option("--warp-sharpness", p.warp.sharpness,
                   "Warp: exponent p of the projection weights |g.u_i|^p (1 = blocks paper)")
        ->capture_default_str();
    detail::GaborParams& g = p.gabor;
    app.add_option("--gabor-amplitude", g.amplitude, "Gabor: largest displacement (m); 0 = off")
        ->capture_default_str();
    app.add_option("--gabor-frequency", g.frequency,
                   "Gabor: F0, cycles per metre (below the voxel Nyquist limit); 0 = 1/(10 x "
                   "amplitude), ridges ten times as wide as they are high")->capture_default_str();
    app.add_option("--gabor-bandwidth", g.bandwidth, "Gabor: a (1/m); 0 = F0/2")->capture_default_str();
    app.add_option("--gabor-orientation", g.orientationDeg,
                   "Gabor: frequency direction in the frame, degrees from t towards b")
        ->capture_default_str();
    app.add_option("--gabor-impulses", g.impulses, "Gabor: impulses per kernel")->capture_default_str();
    app.add_option("--gabor-falloff", g.falloff, "Gabor: R of K(r) = (1 - r/R)^6 (m); 0 = 12 x amplitude, the smallest R that keeps the field monotone along normals")
        ->capture_default_str();
    app.add_flag("--gabor-isotropic", g.isotropic, "Gabor: isotropic noise (no frames)");
    std::vector<double> tilt{0.0, 0.0};
    app.add_option("--tilt", tilt, "Gabor: projection tilt alpha,theta (degrees from the normal, "
                   "azimuth from t towards b)")->delimiter(',')->expected(2)->capture_default_str();
    std::vector<double> axis;
    std::string skeleton;
    bool curvature = false;
    auto* oAxis = app.add_option("--direction-axis", axis, "W = this axis (default 0,0,1)")
                      ->delimiter(',')->expected(3);
    auto* oSkel = app.add_option("--direction-skeleton", skeleton,
                                 "W = weighted skeleton direction from segments in a JSON file: "
                                 "{\"segments\": [{\"a\": [x,y,z], \"b\": [x,y,z], \"radius\": r}]}");
    auto* oCurv = app.add_flag("--direction-curvature", curvature,
                               "W = principal direction of largest curvature of the input");
    oAxis->excludes(oSkel)->excludes(oCurv);
    oSkel->excludes(oCurv);
    std::string singular = "auto";
    app.add_option("--singular", singular,
                   "Near frame singularities: cancel the noise, or fade to isotropic noise; auto = "
                   "isotropic for curvature frames, cancel otherwise")
        ->check(CLI::IsMember({"auto", "cancel", "isotropic"}))->capture_default_str();
    std::string blendFile, blendMask, blendGrid;
    app.add_option("--blend", blendFile,
                   "Blend towards a second parameter set (JSON file with warp_amplitude, "
                   "gabor_amplitude, gabor_frequency, gabor_orientation, gabor_falloff, tilt) "
                   "where --blend-mask reads 1; parameters are interpolated, not the results");
    app.add_option("--blend-mask", blendMask,
                   "Scalar .vdb grid of blend weights in [0, 1] (world space)");
    app.add_option("--blend-mask-grid", blendGrid,
                   "Grid name in --blend-mask (default: its only or first float grid)");
    tool.addSeed(app);
    tool.addBakeOptions(app, /*inputDefaults=*/true);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    return tool.run(argc, argv, [&] {
        // The level set, and the file's other float grids (ids) to carry onto the result.
        auto all = readGrids(input);
        auto grid = findLevelSet(*all, gridName, input);
        std::vector<openvdb::FloatGrid::Ptr> idGrids;
        for (const auto& gb : *all) {
            auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(gb);
            if (f && f != grid && f->getGridClass() != openvdb::GRID_LEVEL_SET) idGrids.push_back(f);
        }
        BakeSettings settings = tool.bake().settings();
        // Voxel size and band default to the input's.
        if (app.count("--voxel-size") == 0) settings.voxelSize = grid->voxelSize()[0];
        if (app.count("--half-width") == 0) {
            settings.halfWidth = double(grid->background()) / grid->voxelSize()[0];
        }
        settings.gridName = grid->getName().empty() ? "surface" : grid->getName();
        nlohmann::json o = {
            {"warp_amplitude", p.warp.amplitude}, {"warp_relief", relief},
            {"warp_scale", p.warp.scale}, {"warp_octaves", p.warp.octaves},
            {"warp_sharpness", p.warp.sharpness}, {"gabor_amplitude", g.amplitude},
            {"gabor_frequency", g.frequency}, {"gabor_bandwidth", g.bandwidth},
            {"gabor_orientation", g.orientationDeg}, {"gabor_impulses", g.impulses},
            {"gabor_falloff", g.falloff}, {"gabor_isotropic", g.isotropic}, {"tilt", tilt},
            {"singular", singular}, {"seed", tool.seed()}, {"direction_curvature", curvature}};
        if (!axis.empty()) o["direction_axis"] = axis;
        if (!skeleton.empty()) o["direction_skeleton"] = skeleton;
        if (!blendFile.empty()) o["blend"] = readJsonFile(blendFile);
        if (!blendFile.empty() && blendMask.empty()) {
            fail<ValueError>("detail: --blend needs --blend-mask (the weights)");
        }
        detail::DetailParams params = detail::DetailParams::fromJson(o);
        if (!blendMask.empty()) {
            auto grids = readGrids(blendMask);
            for (const auto& gb : *grids) {
                auto f = openvdb::gridPtrCast<openvdb::FloatGrid>(gb);
                if (f && (blendGrid.empty() || f->getName() == blendGrid)) {
                    params.blendMask = f;
                    break;
                }
            }
            if (!params.blendMask) {
                fail<ValueError>("detail: no float grid", blendGrid.empty() ? "" : " '" + blendGrid + "'",
                                 " in ", blendMask);
            }
            if (blendFile.empty()) fail<ValueError>("detail: --blend-mask needs --blend (the parameters)");
        }
        auto bar = tool.progress("detailing");
        BakeResult r = detail::detailLevelSet(grid, params, settings, bar.get());
        bar->end();
        char line[200];
        std::snprintf(line, sizeof line, "bake: %zu active voxels in %zu leaves (%zu candidates, "
                      "%.1f M evaluations), cull %.3f s, fill %.3f s, finish %.3f s",
                      r.stats.activeVoxels, r.stats.leaves, r.stats.candidateLeaves,
                      double(r.stats.fieldEvaluations) / 1e6, r.stats.cullSeconds,
                      r.stats.fillSeconds, r.stats.finishSeconds);
        tool.info(line);
        nlohmann::json prov = nlohmann::json::parse(tool.paramsJson());
        // What was used, not the option's unset default: the input's voxel size and band.
        prov["voxel-size"] = settings.voxelSize;
        prov["half-width"] = settings.halfWidth;
        if (auto src = provenance(*grid)) {
            prov["source"] = {{"generator", src->generator},
                                {"params", nlohmann::json::parse(src->params, nullptr, false)}};
        }
        openvdb::GridCPtrVec out{r.surface};
        for (const auto& ids : idGrids) {
            auto carried = detail::carryAttribute(*grid, *r.surface, *ids);
            stampProvenance(*carried, tool.name(), prov.dump());
            out.push_back(carried);
        }
        stampProvenance(*r.surface, tool.name(), prov.dump());
        writeGrids(tool.output(), out);
    });
}
