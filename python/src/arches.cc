// SPDX-License-Identifier: Apache-2.0
// rockvdb.Stacks' native half: material stacks (arches §3) built, stabilised, baked, saved and
// read from Python through the arches stage (ArchesStage.h), so Python and vdb_arches make the
// same stacks and grids from the same table JSON. The Python class (rockvdb/__init__.py) checks
// types and spells keywords; values are checked here, by the table.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/arches/ArchesStage.h>
#include <rockvdb/arches/StackFile.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <limits>
#include <optional>
#include <vector>

using nlohmann::json;

namespace rockvdb {
namespace pyhost {

namespace {

using namespace arches;

/// Stacks with the scene that made them: params is the table's JSON, its "stabilize" true once
/// the stacks have been stabilised, so a bake's provenance replays through vdb_arches.
struct PyStacks
{
    Stacks stacks;
    json params;
    json inputs = json::object(); ///< provenance on top of params (a grid terrain's source)
    std::string baseDir = ".";    ///< the scene file's folder (its relative paths)
};

ArchesParams paramsOf(const json& j) { return archesSchema().fromJson(j); }

py::dict stabilizeStats(const StabilizeStats& st) { return pyJson(stabilizeStatsJson(st)); }
py::dict editStats(const EditStats& e) { return pyJson(editStatsJson(e)); }

/// Every stack's layers, runs merged, bottom first: the walk the numpy views share.
template<typename Visit>
void eachLayer(const Stacks& s, Visit&& visit)
{
    s.forEachStack([&](size_t k, const uint16_t* codes, size_t n) {
        uint64_t z = 0;
        size_t i = 0;
        while (i < n) {
            const Material m = Stacks::codeMaterial(codes[i]);
            uint64_t t = 0;
            while (i < n && Stacks::codeMaterial(codes[i]) == m) t += Stacks::codeThickness(codes[i++]);
            visit(k, m, z, t);
            z += t;
        }
    });
}

MaterialMask maskFromNames(const std::vector<std::string>& names)
{
    MaterialMask mask = 0;
    for (const auto& n : names) mask |= maskOf(materialFromName(n, "Stacks: material"));
    return mask;
}

py::object bakeStacksPy(const PyStacks& s, const std::string& what, const std::string& overrides,
                        const std::optional<std::string>& pointsPath)
{
    const ArchesOutput output = archesOutputFromString(what, "Stacks.bake: material");
    ArchesParams p = paramsOf(s.params);
    p.baseDir = s.baseDir;
    if (pointsPath) requireWritable(*pointsPath);
    ArchesResult r;
    {
        py::gil_scoped_release release;
        PyTaskHost host;
        Task task(&host);
        r = bakeScene(p, s.stacks, s.inputs, parseParams(overrides, "arches"), output,
                      bool(pointsPath), task);
        // As vdb_arches --points writes them (no rock layers: no points).
        if (pointsPath) writeGrids(*pointsPath, {r.points});
    }
    using G = openvdb::FloatGrid::Ptr;
    switch (output) {
    case ArchesOutput::All: {
        // Every grid by name, in vdb_arches' file order: ids, weights, material level sets, the
        // ground last.
        py::dict d;
        d["material"] = py::cast(G(r.material));
        if (r.rockId) d["rock_id"] = py::cast(G(r.rockId));
        for (const auto& g : r.weights) d[py::str(g->getName())] = py::cast(G(g));
        for (const auto& g : r.materials) d[py::str(g->getName())] = py::cast(G(g));
        d["surface"] = py::cast(G(r.surface));
        return std::move(d);
    }
    case ArchesOutput::Weights: {
        py::list weights;
        for (const auto& g : r.weights) weights.append(py::cast(G(g)));
        return std::move(weights);
    }
    case ArchesOutput::Surface: return py::cast(G(r.surface));
    case ArchesOutput::Ids: return py::make_tuple(py::cast(G(r.surface)), py::cast(G(r.material)));
    default: return py::cast(G(r.materials.at(0)));
    }
}

} // namespace

const SchemaBase& archesSchemaBase() { return archesSchema(); }
std::string archesEditTools() { return jsonText(editTools()); }

void bindArches(py::module_& m)
{
    py::class_<PyStacks>(m, "Stacks", "Material stacks (arches §3.2); see rockvdb.Stacks")
        .def_property_readonly("shape", [](const PyStacks& s) {
            return py::make_tuple(s.stacks.geometry().ny, s.stacks.geometry().nx);
        })
        .def_property_readonly("cell_size", [](const PyStacks& s) { return s.stacks.geometry().cell; })
        .def_property_readonly("origin", [](const PyStacks& s) {
            const auto& g = s.stacks.geometry();
            return py::make_tuple(g.x0, g.y0, g.z0);
        })
        .def_property_readonly("quantum", [](const PyStacks& s) { return s.stacks.geometry().quantum; })
        .def_property_readonly("bytes", [](const PyStacks& s) { return s.stacks.bytes(); })
        .def_property_readonly("layer_count", [](const PyStacks& s) { return s.stacks.layerCount(); })
        .def_property_readonly("params", [](const PyStacks& s) { return jsonText(s.params); })
        .def("volume_quanta", [](const PyStacks& s, const std::string& name) {
            return s.stacks.volumeQuanta(materialFromName(name, "Stacks.volume: material"));
        }, py::arg("material"))
        .def("layers", [](const PyStacks& s, int i, int j) {
            const auto& g = s.stacks.geometry();
            if (i < 0 || j < 0 || i >= g.nx || j >= g.ny) {
                throw py::index_error("Stacks.layers: (" + std::to_string(i) + ", " + std::to_string(j) +
                                      ") is outside the " + std::to_string(g.nx) + " x " + std::to_string(g.ny) +
                                      " stacks");
            }
            std::vector<Layer> layers;
            s.stacks.layers(i, j, layers);
            py::list out;
            for (const auto& l : layers) {
                out.append(py::make_tuple(materialName(l.material), double(l.thickness) * g.quantum));
            }
            return out;
        }, py::arg("i"), py::arg("j"))
        .def("arrays", [](const PyStacks& s) {
            size_t n = 0;
            eachLayer(s.stacks, [&](size_t, Material, uint64_t, uint64_t) { ++n; });
            const size_t count = s.stacks.geometry().count();
            py::array_t<int64_t> offsets(count + 1);
            py::array_t<uint8_t> material(n);
            py::array_t<int64_t> bottom(n), thickness(n);
            int64_t* off = offsets.mutable_data();
            uint8_t* mat = material.mutable_data();
            int64_t* bot = bottom.mutable_data();
            int64_t* th = thickness.mutable_data();
            std::fill(off, off + count + 1, 0);
            size_t at = 0;
            eachLayer(s.stacks, [&](size_t k, Material m, uint64_t z, uint64_t t) {
                off[k + 1] = int64_t(at + 1);
                mat[at] = uint8_t(m);
                bot[at] = int64_t(z);
                th[at] = int64_t(t);
                ++at;
            });
            // Stacks without layers take the offset before them.
            for (size_t k = 1; k <= count; ++k) off[k] = std::max(off[k], off[k - 1]);
            py::dict d;
            d["offsets"] = offsets;
            d["material"] = material;
            d["bottom"] = bottom;
            d["thickness"] = thickness;
            return d;
        })
        .def("top", [](const PyStacks& s, const std::vector<std::string>& names) {
            const MaterialMask mask = maskFromNames(names);
            const auto& g = s.stacks.geometry();
            py::array_t<double> out({size_t(g.ny), size_t(g.nx)});
            double* o = out.mutable_data();
            std::fill(o, o + g.count(), std::numeric_limits<double>::quiet_NaN());
            eachLayer(s.stacks, [&](size_t k, Material m, uint64_t z, uint64_t t) {
                if (maskOf(m) & mask) o[k] = g.z0 + double(z + t) * g.quantum;
            });
            return out;
        }, py::arg("materials"))
        .def("thickness", [](const PyStacks& s, const std::vector<std::string>& names) {
            const MaterialMask mask = maskFromNames(names);
            const auto& g = s.stacks.geometry();
            py::array_t<double> out({size_t(g.ny), size_t(g.nx)});
            double* o = out.mutable_data();
            std::fill(o, o + g.count(), 0.0);
            eachLayer(s.stacks, [&](size_t k, Material m, uint64_t, uint64_t t) {
                if (maskOf(m) & mask) o[k] += double(t) * g.quantum;
            });
            return out;
        }, py::arg("materials"))
        .def("stabilize", [](PyStacks& s) {
            // Before any edit, stabilising is the scene's own row; after edits it is an edit
            // of its own, so the record replays in order.
            const bool asEdit = !s.params.at("edits").empty();
            ArchesParams p = paramsOf(s.params);
            p.stabilize = true;
            StabilizeStats st;
            {
                py::gil_scoped_release release;
                PyTaskHost host;
                Task task(&host);
                Stacks next = s.stacks;
                if (asEdit) {
                    st = applyEdit(next, json{{"tool", "stabilize"}}, s.params.at("edits").size(),
                                   editContext(p, next.geometry()), task).stabilize;
                } else {
                    st = stabilizeIfAsked(p, next, task);
                }
                s.stacks = std::move(next); // only once finished: Ctrl-C leaves the stacks as they were
            }
            if (asEdit) s.params["edits"].push_back({{"tool", "stabilize"}});
            else s.params["stabilize"] = true;
            return stabilizeStats(st);
        })
        .def("edit", [](PyStacks& s, const std::string& text) {
            const json e = parseParams(text, "arches");
            const size_t index = s.params.at("edits").size();
            const ArchesParams p = paramsOf(s.params);
            const EditStats st = withTask([&](Task& task) {
                return applyEdit(s.stacks, e, index, editContext(p, s.stacks.geometry()), task);
            });
            s.params["edits"].push_back(e);
            return editStats(st);
        }, py::arg("edit"))
        .def("bake", &bakeStacksPy, py::arg("material"), py::arg("overrides"), py::arg("points_path"))
        .def("save", [](const PyStacks& s, const std::string& path) {
            writeStackFile(path, s.stacks, jsonText(s.params));
        }, py::arg("path"))
        .def("__eq__", [](const PyStacks& a, const PyStacks& b) { return a.stacks == b.stacks; });

    // Build the stacks of a scene (the table's JSON), stabilised when it says so, as vdb_arches
    // does; grid: the level set of a {"type": "level_set"} terrain given in memory.
    // scene: a scene file read first (its folder resolves relative paths), params on top.
    m.def("arches_build", [](const std::string& params, std::optional<std::string> scene,
                             std::optional<openvdb::FloatGrid::Ptr> grid) {
        SceneInputs in;
        in.scenePath = scene.value_or("");
        in.given = parseParams(params, "arches");
        in.anchorGiven = bool(scene);
        if (grid) in.terrainGrid = *grid;
        Scene sc = withTask([&](Task& task) { return openScene(in, task); });
        PyStacks s;
        s.stacks = std::move(sc.stacks);
        s.params = archesSchema().toJson(sc.params);
        s.inputs = sc.inputs;
        s.baseDir = sc.params.baseDir;
        py::list es;
        for (const auto& e : sc.edits) es.append(editStats(e));
        return py::make_tuple(std::move(s), stabilizeStats(sc.stabilize), es);
    }, py::arg("params"), py::arg("scene") = std::nullopt, py::arg("grid") = std::nullopt);

    m.def("arches_edit_tools", &archesEditTools);
    m.def("arches_bake_rows", [] { return bakeOnlyRows(); });

    m.def("arches_load", [](const std::string& path) {
        StackFile f = readStackFile(path);
        PyStacks s;
        s.params = archesSchema().toJson(paramsOf(savedScene(f.params, path))); // every row present
        s.stacks = std::move(f.stacks);
        return s;
    }, py::arg("path"));
}

} // namespace pyhost
} // namespace rockvdb
