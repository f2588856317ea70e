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
    m.def("detail", [](Grid grid, const std::string& params, std::optional<Grid> blendMask) {
        if (!grid) throw py::type_error("detail: the input grid is None");
        const detail::DetailStageParams p =
            detail::detailSchema().fromJson(parseParams(params, "detail"));
        detail::DetailInputs in;
        in.grid = grid;
        if (blendMask) in.blendMask = *blendMask;
        const detail::DetailResult r = withTask([&](Task& task) {
            return detail::runDetail(p, in, task);
        });
        return py::make_tuple(r.bake.surface, pyJson(r.stats));
    }, py::arg("grid"), py::arg("params"), py::arg("blend_mask") = std::nullopt);
}

} // namespace pyhost
} // namespace rockvdb
