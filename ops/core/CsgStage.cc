// SPDX-License-Identifier: Apache-2.0
// The CSG stage (see CsgStage.h).
#include "CsgStage.h"

#include <rockvdb/core/Error.h>

namespace rockvdb {

using nlohmann::json;

const Schema<CsgParams>& csgSchema()
{
    static const Schema<CsgParams> s = [] {
        Schema<CsgParams> t("csg",
            "Combine level sets: union, intersection or difference (the first minus the others), "
            "folded left to right; optional smooth radius (implicit-blocks §4.2 operator). Inputs "
            "on other voxel sizes are resampled onto the first. The inputs' id grids come along.");
        t.member(param("smooth", ParamType::Real, "m", 0.0, Range::atLeast(0),
                       "Smooth blend radius R; 0 = hard CSG"), &CsgParams::smooth);
        t.member(param("ids", ParamType::Bool, "", true, Range::any(),
                       "Carry the inputs' id grids (block_id, rock_id, material, ...): a voxel takes "
                       "the id of the input whose surface the result follows there (in a difference, "
                       "the first input's); --no-ids: the surface only"), &CsgParams::ids);
        t.member(maxMemoryRow("Refuse a CSG whose resampled inputs or widened bands are estimated "
                              "above this (0 = 75% of RAM)"), &CsgParams::maxMemoryGB);
        return t;
    }();
    return s;
}

CsgParams::CsgParams() { csgSchema().reset(*this); }

StageResult runCsg(CsgOp op, const CsgParams& params, const std::vector<CsgInput>& inputs,
                   const json& names, Task& task)
{
    csgSchema().validate(params);
    if (inputs.empty()) fail<ValueError>("csg: give at least one level set");
    std::vector<CsgInput> used = inputs;
    if (!params.ids) {
        for (auto& in : used) in.ids.clear();
    }
    task.phase("csg", 1.0);
    openvdb::GridPtrVec grids = csgWithIds(op, used, params.smooth, params.maxMemoryGB * 1e9);
    task.check();
    StageResult r;
    json prov = stageProvenance(csgSchema().toJson(params), names);
    prov["operation"] = csgOpName(op);
    stampResult(r, kCsgTool, grids, prov);
    json ids = json::array();
    std::string carried;
    for (size_t k = 1; k < grids.size(); ++k) {
        ids.push_back(grids[k]->getName());
        carried += (carried.empty() ? ", id grids carried: " : ", ") + grids[k]->getName();
    }
    const size_t active = size_t(grids[0]->activeVoxelCount());
    r.report.push_back(std::to_string(active) + " active voxels" + carried);
    task.done();
    r.stats = {{"active_voxels", active}, {"id_grids", ids}, {"phases", phasesJson(task)}};
    return r;
}

} // namespace rockvdb
