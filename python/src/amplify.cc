// SPDX-License-Identifier: Apache-2.0
// rockvdb.amplify's native half: the amplify stage's entry point, runAmplify (AmplifyStage.h),
// with the table's JSON from the Python wrapper.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/amplify/AmplifyStage.h>
#include <rockvdb/core/Image.h>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

using nlohmann::json;

namespace rockvdb {
namespace pyhost {

namespace {

// rockvdb.amplify: the terrain (a level-set grid or a path), tiles with their names, an
// optional mask image and the table's parameters (JSON); the stage's runAmplify does the rest.
py::tuple amplifyTerrain(py::object terrain, const std::vector<PyTile>& tiles,
                         const std::vector<std::string>& names, std::optional<GrayImage> mask,
                         const std::string& params, const std::string& sources)
{
    const amplify::AmplifyParams p = amplify::amplifySchema().fromJson(parseParams(params, "amplify"));
    amplify::AmplifyInputs in;
    if (py::isinstance<py::str>(terrain)) {
        in.terrainPath = terrain.cast<std::string>();
        in.names["terrain"] = in.terrainPath;
    } else {
        Grid g = terrain.is_none() ? Grid() : terrain.cast<Grid>();
        if (!g) throw py::type_error("amplify: the terrain grid is None");
        in.terrainGrid = g;
        in.names["terrain"] = gridSource(*g);
    }
    for (const auto& t : tiles) in.tiles.push_back(t.tile);
    in.tileNames = names;
    // How provenance names the tiles and mask: paths as given (a tile object by its params).
    json src = parseParams(sources, "amplify");
    for (size_t i = 0; i < src["tiles"].size() && i < tiles.size(); ++i) {
        if (src["tiles"][i].is_null()) src["tiles"][i] = tiles[i].tile->params.toJson();
    }
    for (auto it = src.begin(); it != src.end(); ++it) in.names[it.key()] = it.value();
    if (mask) in.mask = std::make_shared<const GrayImage>(std::move(*mask));
    const amplify::AmplifyRun r = withTask([&](Task& task) {
        return amplify::runAmplify(p, in, task);
    });
    return py::make_tuple(py::cast(r.amplified.surface), py::cast(r.amplified.blockId),
                          py::cast(r.amplified.material), pyJson(r.stats));
}

} // namespace

void bindAmplify(py::module_& m)
{
    m.def("amplify", [](py::object terrain, const std::vector<PyTile>& tiles,
                        const std::vector<std::string>& names,
                        std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>> mask,
                        const std::string& params, const std::string& sources) {
        std::optional<GrayImage> img;
        if (mask) {
            if (mask->ndim() != 2) throw ValueError("amplify: mask must be a 2D array (rows = y)");
            img = GrayImage{int(mask->shape(1)), int(mask->shape(0)),
                            std::vector<float>(mask->data(), mask->data() + mask->size())};
        }
        return amplifyTerrain(std::move(terrain), tiles, names, std::move(img), params, sources);
    });
}

} // namespace pyhost
} // namespace rockvdb
