// rockvdb.rock_tiles, rock_library and rock_pile's native half: the rock-pile stage's entry
// points, runTiles and runPile (RockPileStage.h).
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/rockpile/RockPileStage.h>

#include <pybind11/stl.h>


using nlohmann::json;

namespace rockvdb {
namespace pyhost {

void bindRockpile(py::module_& m)
{
    m.def("rock_tiles", [](const std::string& params, double maxMemoryGB) {
        const rockpile::RockTileParams p = rockpile::tilesSchema().fromJson(parseParams(params, "rockpile"));
        return withTask([&](Task& task) { return rockpile::runTiles(p, false, task, maxMemoryGB * 1e9).rho; });
    }, py::arg("params"), py::arg("max_memory") = 0.0);

    m.def("rock_library", [](Grid tiles) {
        if (!tiles) throw py::type_error("rockpile: the tile set grid is None");
        const rockpile::TileSet set = rockpile::tilesFromGrid(*tiles);
        const StageResult r = withTask([&](Task& task) { return rockpile::runLibrary(set, task); });
        return openvdb::gridPtrCast<openvdb::FloatGrid>(r.grids.at(0));
    }, py::arg("tiles"));

    m.def("rock_pile", [](py::object tiles, py::object support, const std::string& params) {
        const rockpile::PileParams p = rockpile::pileSchema().fromJson(parseParams(params, "rockpile"));
        rockpile::PileInputs in;
        if (py::isinstance<py::str>(tiles)) {
            in.tilesPath = tiles.cast<std::string>();
        } else {
            Grid g = tiles.is_none() ? Grid() : tiles.cast<Grid>();
            if (!g) throw py::type_error("rockpile: the tile set grid is None");
            in.tilesGrid = g;
        }
        if (py::isinstance<py::str>(support)) {
            in.supportPath = support.cast<std::string>();
        } else if (py::isinstance<PyField>(support)) {
            const PyField& f = support.cast<const PyField&>();
            in.supportField = f.field;
            in.supportExpression = f.expr;
        } else {
            try {
                if (!support.is_none()) in.supportGrid = support.cast<Grid>();
            } catch (const py::cast_error&) {
            }
            if (!in.supportGrid) {
                throw py::type_error("rockpile: the support must be a pyopenvdb.FloatGrid level "
                                     "set, a rockvdb Field or a file path");
            }
        }
        const rockpile::PileResult r = withTask([&](Task& task) {
            return rockpile::runPile(p, in, task);
        });
        py::dict stats = pyJson(r.stats).cast<py::dict>();
        py::list rocks, positions;
        for (const auto& i : r.pile.instances) {
            rocks.append(i.rock);
            positions.append(py::make_tuple(i.position[0], i.position[1], i.position[2]));
        }
        stats["rocks"] = rocks;
        stats["positions"] = positions;
        return py::make_tuple(Grid(r.pile.surface), Grid(r.pile.rockId), Grid(r.pile.material), stats);
    }, py::arg("tiles"), py::arg("support"), py::arg("params"));
}

} // namespace pyhost
} // namespace rockvdb
