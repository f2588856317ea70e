// SPDX-License-Identifier: Apache-2.0
// rockvdb.block_tile, BlockTile.bake and load_tile's native half: the block-tile stage's one
// entry point, runBlocks (BlocksStage.h), with the table's JSON from the Python wrapper. The
// wrapper (rockvdb/__init__.py) checks types and spells keywords; values are checked here, by
// the table, and every guard of the stage is runBlocks' own.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/blocks/BlocksStage.h>

#include <pybind11/stl.h>

using nlohmann::json;

namespace rockvdb {
namespace pyhost {

namespace {

/// runBlocks on a generated tile (tile None) or a given one; (tile, surface, block_id, stats),
/// the grids None without bake.
py::tuple runBlocks(const std::string& params, std::optional<PyTile> tile, bool bake)
{
    const blocks::BlocksParams p = blocks::blocksSchema().fromJson(parseParams(params, "blocks"));
    blocks::BlocksInputs in;
    if (tile) in.tile = tile->tile;
    in.bake = bake;
    const blocks::BlocksResult r = withTask([&](Task& task) {
        return blocks::runBlocks(p, in, task);
    });
    return py::make_tuple(PyTile{r.tile}, r.bake.surface, r.bake.attribute, pyJson(r.stats));
}

} // namespace

void bindBlocks(py::module_& m)
{
    py::class_<PyTile>(m, "Tile", "A fractured block tile (implicit-blocks §4); see rockvdb.block_tile")
        .def("to_json", [](const PyTile& t) { return jsonText(blocks::tileToJson(*t.tile)); },
             "The tile file's JSON text")
        .def("save", [](const PyTile& t, const std::string& path) { blocks::writeTile(*t.tile, path); },
             py::arg("path"), "Write the tile file (atomic)")
        .def("field", [](const PyTile& t, const std::array<int, 3>& periods, bool periodic) {
            blocks::TileFieldOptions o;
            o.periods = periods;
            o.periodic = periodic;
            return PyField{blocks::tileField(t.tile, o),
                           {{"type", "block_tile"}, {"tile", t.tile->params.toJson()},
                            {"periods", periods}, {"periodic", periodic}}};
        }, py::arg("periods") = std::array<int, 3>{1, 1, 1}, py::arg("periodic") = false,
           "The tile as a Field (union of its blocks; periodic=True tiles all of space)");
    m.def("run_blocks", &runBlocks, py::arg("params"), py::arg("tile"), py::arg("bake"),
          "The block-tile stage (vdb_blocks): (tile, surface, block_id, stats) from the table's "
          "JSON, generating the tile when tile is None");
    m.def("load_tile", [](const std::string& path) {
        return PyTile{std::make_shared<const blocks::BlockTile>(blocks::readTile(path))};
    }, py::arg("path"), "Read a .tile file or a vdb_blocks .vdb");
}

} // namespace pyhost
} // namespace rockvdb
