// SPDX-License-Identifier: Apache-2.0
#include "HeightfieldStage.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Heightfield.h>

#include <cstdio>
#include <memory>

namespace rockvdb {

using nlohmann::json;

const Schema<HeightfieldParams>& heightfieldSchema()
{
    static const Schema<HeightfieldParams> s = [] {
        Schema<HeightfieldParams> t("heightfield",
            "Bake a heightfield image (single-channel float EXR or 16-bit greyscale PNG) into a "
            "narrow-band level set of the terrain solid (grid 'surface'), with true Euclidean "
            "distance near the surface, steep slopes included. Pixel column i, row j (row 0 = "
            "first row stored in the file) sits at x = i*cell-size, y = j*cell-size, z = "
            "value*height-scale; EXR values are metres before scaling, 16-bit PNG values map "
            "0..65535 to 0..1 before scaling. The solid is closed by vertical walls at the "
            "image border and a floor base-depth below the lowest sample.");
        t.member(param("cell-size", ParamType::Real, "m", 1.0, Range::openClosed(0, 1e6),
                       "Distance between pixel centres"), &HeightfieldParams::cellSize);
        t.member(param("height-scale", ParamType::Real, "", 1.0, Range::closed(-1e6, 1e6),
                       "Metres per image unit"), &HeightfieldParams::heightScale);
        t.member(param("base-depth", ParamType::Real, "m", 1.0, Range::openClosed(0, 1e6),
                       "Floor depth below the lowest sample"), &HeightfieldParams::baseDepth);
        addBakeRows(t, &HeightfieldParams::bake, defaultVoxelSize(), defaultHalfWidth());
        return t;
    }();
    return s;
}

HeightfieldParams::HeightfieldParams() { heightfieldSchema().reset(*this); }

StageResult runHeightfield(const HeightfieldParams& params, const std::string& image, Task& task)
{
    heightfieldSchema().validate(params);
    const BakeSettings settings = params.bake.settings();
    auto hf = std::make_shared<Heightfield>(
        loadHeightfield(image, params.cellSize, params.heightScale, settings.maxMemoryBytes));
    HeightfieldSettings hs;
    hs.baseDepth = params.baseDepth;
    task.phase("bake", 1.0);
    const BakeResult b = bake(*heightfieldField(hf, hs), settings, task.interrupter());
    task.check();
    if (b.surface->activeVoxelCount() == 0) {
        fail<ValueError>("heightfield: the result is empty (no active voxels): the terrain lies "
                         "outside the baked region");
    }
    StageResult r;
    stampResult(r, kHeightfieldTool, {b.surface},
                stageProvenance(heightfieldSchema().toJson(params), {{"image", image}}));
    task.done();
    char line[256];
    std::snprintf(line, sizeof line,
                  "%zu active voxels in %zu leaves; cull %.3f s, fill %.3f s, finish %.3f s%s",
                  b.stats.activeVoxels, b.stats.leaves, b.stats.cullSeconds, b.stats.fillSeconds,
                  b.stats.finishSeconds, b.stats.renormalized ? " (renormalised)" : "");
    r.report = {line, std::to_string(hf->nx) + "x" + std::to_string(hf->ny) + " samples"};
    r.stats = {{"samples", {hf->nx, hf->ny}}, {"bake", bakeStatsJson(b.stats)},
               {"phases", phasesJson(task)}};
    return r;
}

} // namespace rockvdb
