// SPDX-License-Identifier: Apache-2.0
// rockvdb.rock_tiles, rock_library and rock_pile's native half: the rock-pile stage's entry
// points, runTiles and runPile (RockPileStage.h).
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/core/GridUtil.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/rockpile/RockPileStage.h>
#include <rockvdb/rockpile/RockTiles.h>

#include <openvdb/tools/SignedFloodFill.h>
#include <pybind11/numpy.h>
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
        for (const auto& g : r.grids) {
            if (g->getName() == "library") return openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        }
        throw ValueError("rock_library: the library stage returned no grid 'library'");
    }, py::arg("tiles"));

    // Every rock of a tile set meshed in its canonical frame (voxel v at v·voxel size): a
    // pile's instance i is library rock rocks[i] moved by shifts[i] voxels. For front-ends
    // that instance the rocks (the Blender add-on): [(points N x 3, triangles M x 3)] for
    // the rocks @a which (indices into the tile set's rocks).
    m.def("rock_meshes", [](Grid tiles, const std::vector<size_t>& which) {
        if (!tiles) throw py::type_error("rockpile: the tile set grid is None");
        const rockpile::TileSet set = rockpile::tilesFromGrid(*tiles);
        for (size_t r : which) {
            if (r >= set.rocks.size()) {
                throw ValueError("rock_meshes: rock " + std::to_string(r) + " is not in the tile "
                                 "set (" + std::to_string(set.rocks.size()) + " rocks)");
            }
        }
        const double dx = set.params.voxelSize(), halfWidth = 3.0;
        std::vector<Mesh> meshes(which.size());
        withTask([&](Task& task) {
            task.phase("rock meshes", 1.0);
            parallelFor(task, which.size(), 4, [&](size_t i) {
                auto g = emptyLevelSet("rock", dx, float(halfWidth * dx));
                for (auto* leaf : rockpile::rockLeavesShifted(set.rocks[which[i]], dx,
                                                              openvdb::Coord(0), halfWidth)) {
                    g->tree().addLeaf(leaf);
                }
                openvdb::tools::signedFloodFill(g->tree());
                meshes[i] = meshLevelSet(*g, 0.0, 0.0);
            });
            task.done();
            return 0;
        });
        py::list out;
        for (const Mesh& mesh : meshes) {
            const size_t nt = mesh.triangles.size() + 2 * mesh.quads.size();
            py::array_t<float> P({mesh.points.size(), size_t(3)});
            py::array_t<int64_t> T({nt, size_t(3)});
            auto p = P.mutable_unchecked<2>();
            auto t = T.mutable_unchecked<2>();
            for (size_t i = 0; i < mesh.points.size(); ++i)
                for (int a = 0; a < 3; ++a) p(i, a) = mesh.points[i][a];
            size_t k = 0;
            for (const auto& tri : mesh.triangles) {
                for (int a = 0; a < 3; ++a) t(k, a) = tri[a];
                ++k;
            }
            for (const auto& q : mesh.quads) { // (a, b, c, d) -> (a, b, c), (a, c, d)
                t(k, 0) = q[0], t(k, 1) = q[1], t(k, 2) = q[2];
                t(k + 1, 0) = q[0], t(k + 1, 1) = q[2], t(k + 1, 2) = q[3];
                k += 2;
            }
            out.append(py::make_tuple(P, T));
        }
        return out;
    }, py::arg("tiles"), py::arg("which"));

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
        py::list rocks, positions, shifts;
        for (const auto& i : r.pile.instances) {
            rocks.append(i.rock);
            positions.append(py::make_tuple(i.position[0], i.position[1], i.position[2]));
            shifts.append(py::make_tuple(i.shift[0], i.shift[1], i.shift[2]));
        }
        stats["rocks"] = rocks;
        stats["positions"] = positions;
        stats["shifts"] = shifts; // voxels added to the library rock's canonical voxels

        return py::make_tuple(Grid(r.pile.surface), Grid(r.pile.rockId), Grid(r.pile.material), stats);
    }, py::arg("tiles"), py::arg("support"), py::arg("params"));
}

} // namespace pyhost
} // namespace rockvdb
