// SPDX-License-Identifier: Apache-2.0
// rockvdb.asset's native half: the asset stage's entry points, runAsset, runAssetEach and
// runAssetInstances
// (asset/AssetStage.h), and the GLB bytes written atomically like every rockvdb output.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/asset/AssetStage.h>

#include <pybind11/stl.h>

namespace rockvdb {
namespace pyhost {

namespace {

asset::AssetInputs inputs(const Grid& grid, const std::optional<Grid>& ids,
                          const std::optional<Grid>& mask = std::nullopt)
{
    if (!grid) throw py::type_error("asset: the input grid is None");
    asset::AssetInputs in;
    in.grid = grid;
    in.names = {{"grid", grid->getName()}};
    if (ids) {
        if (!*ids) throw py::type_error("asset: the id grid is None");
        in.ids = *ids;
        in.names["id-grid"] = (*ids)->getName();
    }
    if (mask) {
        if (!*mask) throw py::type_error("asset: the mask grid is None");
        in.mask = *mask;
        in.names["mask-grid"] = (*mask)->getName();
    }
    return in;
}

} // namespace

void bindAsset(py::module_& m)
{
    m.def("asset", [](Grid grid, const std::string& params, std::optional<Grid> ids,
                      std::optional<std::string> path, std::optional<Grid> mask) {
        const asset::AssetParams p = asset::assetSchema().fromJson(parseParams(params, "asset"));
        const asset::AssetInputs in = inputs(grid, ids, mask);
        if (path) requireWritable(*path);
        const asset::AssetResult r = withTask([&](Task& task) { return asset::runAsset(p, in, task); });
        if (path) writeFileAtomic(*path, r.glb);
        return py::make_tuple(py::bytes(r.glb), pyJson(r.stats));
    }, py::arg("grid"), py::arg("params"), py::arg("ids") = std::nullopt,
       py::arg("path") = std::nullopt, py::arg("mask") = std::nullopt);
    m.def("asset_each", [](Grid grid, const std::string& params, Grid ids, std::optional<Grid> mask) {
        const asset::AssetParams p = asset::assetSchema().fromJson(parseParams(params, "asset"));
        const asset::AssetInputs in = inputs(grid, ids, mask);
        const asset::AssetSetResult r = withTask([&](Task& task) { return asset::runAssetEach(p, in, task); });
        py::list out;
        for (const auto& [id, glb] : r.glbs) out.append(py::make_tuple(id, py::bytes(glb)));
        return py::make_tuple(out, pyJson(r.stats));
    }, py::arg("grid"), py::arg("params"), py::arg("ids"), py::arg("mask") = std::nullopt);
    m.def("asset_instances", [](const std::string& points, const std::string& tiles,
                                const std::string& params, std::optional<std::string> path) {
        const asset::AssetParams p = asset::assetSchema().fromJson(parseParams(params, "asset"));
        if (path) requireWritable(*path);
        const asset::AssetResult r = withTask([&](Task& task) {
            const asset::PileInstances pile = asset::readPileInstances(points, tiles, 3.0, task);
            return asset::runAssetInstances(p, pile, {{"input", points}, {"tiles", tiles}}, task);
        });
        if (path) writeFileAtomic(*path, r.glb);
        return py::make_tuple(py::bytes(r.glb), pyJson(r.stats));
    }, py::arg("points"), py::arg("tiles"), py::arg("params"), py::arg("path") = std::nullopt);
    m.def("asset_ids", [](Grid grid, Grid ids) { return asset::assetIds(inputs(grid, ids)); },
          py::arg("grid"), py::arg("ids"));
}

} // namespace pyhost
} // namespace rockvdb
