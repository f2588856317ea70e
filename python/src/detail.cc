// SPDX-License-Identifier: Apache-2.0
// rockvdb.detail's native half: the detail stage's entry point, runDetail (DetailStage.h).
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/detail/DetailStage.h>

#include <pybind11/stl.h>

using nlohmann::json;

namespace rockvdb {
namespace pyhost {

void bindDetail(py::module_& m)
{
    m.def("detail", [](Grid grid, const std::string& params, std::optional<Grid> blendMask,
                       const std::vector<Grid>& ids) {
        if (!grid) throw py::type_error("detail: the input grid is None");
        const detail::DetailStageParams p =
            detail::detailSchema().fromJson(parseParams(params, "detail"));
        detail::DetailInputs in;
        in.grid = grid;
        if (blendMask) in.blendMask = *blendMask;
        // Copies: the caller's id grids stay as they were (the stage may re-stamp them).
        for (const auto& g : ids) in.ids.push_back(g->deepCopy());
        const detail::DetailResult r = withTask([&](Task& task) {
            return detail::runDetail(p, in, task);
        });
        py::list carried;
        for (const auto& g : r.ids) carried.append(Grid(g));
        return py::make_tuple(r.bake.surface, pyJson(r.stats), carried);
    }, py::arg("grid"), py::arg("params"), py::arg("blend_mask") = std::nullopt,
       py::arg("ids") = std::vector<Grid>());
}

} // namespace pyhost
} // namespace rockvdb
