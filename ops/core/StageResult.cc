// SPDX-License-Identifier: Apache-2.0
#include "StageResult.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/VdbIO.h>

#include <cstdio>

namespace rockvdb {

using nlohmann::json;

json stageProvenance(json params, const json& inputs)
{
    if (inputs.is_object()) {
        for (auto it = inputs.begin(); it != inputs.end(); ++it) params[it.key()] = it.value();
    }
    return params;
}

json gridSource(const openvdb::GridBase& g)
{
    auto p = provenance(g);
    if (!p) return {{"grid", g.getName()}};
    return {{"grid", g.getName()}, {"generator", p->generator}, {"params", jsonOrText(p->params)}};
}

void stampResult(StageResult& result, const char* tool, openvdb::GridPtrVec grids,
                 const json& provenance)
{
    const std::string text = jsonText(provenance);
    for (const auto& g : grids) {
        if (g) stampProvenance(*g, tool, text);
    }
    result.grids = std::move(grids);
    result.provenance = provenance;
}

void stampExtras(const StageResult& result, const char* tool, const openvdb::GridPtrVec& extras)
{
    const std::string text = jsonText(result.provenance);
    for (const auto& g : extras) {
        if (g) stampProvenance(*g, tool, text);
    }
}

json bakeStatsJson(const BakeStats& s)
{
    return {{"active_voxels", s.activeVoxels}, {"leaves", s.leaves},
            {"candidate_leaves", s.candidateLeaves}, {"field_evaluations", s.fieldEvaluations},
            {"cull_seconds", s.cullSeconds}, {"fill_seconds", s.fillSeconds},
            {"finish_seconds", s.finishSeconds}, {"renormalized", s.renormalized}};
}

std::string bakeReport(const BakeStats& b)
{
    char line[256];
    std::snprintf(line, sizeof line, "bake: %zu active voxels, cull %.3f s, fill %.3f s, "
                  "finish %.3f s", b.activeVoxels, b.cullSeconds, b.fillSeconds, b.finishSeconds);
    return line;
}

json phasesJson(const Task& task)
{
    json out = json::array();
    for (const auto& [name, seconds] : task.phases()) {
        out.push_back({{"name", name}, {"seconds", seconds}});
    }
    return out;
}

} // namespace rockvdb
