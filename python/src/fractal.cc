// SPDX-License-Identifier: Apache-2.0
// rockvdb.fractal_rock, fractal_scatter and fractal_carve's native half: the fractal-rock
// stage's one entry point, runFractal (FractalStage.h), with the table's JSON from the Python
// wrappers, which name the mode; the entry refuses what the mode does not read.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/fractal/FractalStage.h>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

using nlohmann::json;

namespace rockvdb {
namespace pyhost {

namespace {

/// Rows of vectors as an N x cols numpy array of T.
template<typename T, typename V>
py::array_t<T> rows(const std::vector<V>& v, size_t cols)
{
    py::array_t<T> a({v.size(), cols});
    T* out = a.mutable_data();
    for (size_t i = 0; i < v.size(); ++i)
        for (size_t c = 0; c < cols; ++c) out[i * cols + c] = T(v[i][c]);
    return a;
}

/// The rock's mesh: points, triangles, normals (and uvs, triangle_uvs, normal_map).
py::dict rockMesh(const fractal::RockResult& r, bool normalMap)
{
    py::dict mesh;
    mesh["points"] = rows<float>(r.mesh.points, 3);
    mesh["triangles"] = rows<int32_t>(r.mesh.triangles, 3);
    mesh["normals"] = rows<float>(r.mesh.normals, 3);
    if (!r.mesh.uvs.empty()) {
        mesh["uvs"] = rows<float>(r.mesh.uvs, 2);
        mesh["triangle_uvs"] = rows<int32_t>(r.mesh.triangleUvs, 3);
    }
    if (normalMap) {
        py::array_t<float> img({size_t(r.normalMapHeight), size_t(r.normalMapWidth), size_t(3)});
        std::copy(r.normalMap.begin(), r.normalMap.end(), img.mutable_data());
        mesh["normal_map"] = img;
    }
    return mesh;
}

/// Every scattered rock's mesh: points, triangles and the rock of each triangle.
py::dict scatterMesh(const Mesh& m)
{
    py::dict d;
    d["points"] = rows<float>(m.points, 3);
    d["triangles"] = rows<int32_t>(m.triangles, 3);
    py::array_t<int32_t> groups(m.triangleGroups.size());
    std::copy(m.triangleGroups.begin(), m.triangleGroups.end(), groups.mutable_data());
    d["rock"] = groups;
    return d;
}

/// The scattered rocks' placements, added to the stats: positions, orients (x, y, z, w),
/// extents (m) and footprint radii, as numpy arrays.
void addPlacements(py::dict& stats, const std::vector<fractal::Placed>& rocks)
{
    const size_t n = rocks.size();
    py::array_t<double> pos({n, size_t(3)}), orient({n, size_t(4)}), extent({n, size_t(3)}), radius(n);
    for (size_t i = 0; i < n; ++i) {
        const auto q = fractal::quaternionOf(rocks[i].rotation);
        for (int c = 0; c < 3; ++c) {
            pos.mutable_at(i, c) = rocks[i].position[c];
            extent.mutable_at(i, c) = rocks[i].extent[c];
        }
        for (int c = 0; c < 4; ++c) orient.mutable_at(i, c) = q[size_t(c)];
        radius.mutable_at(i) = rocks[i].radius;
    }
    stats["radii"] = radius;
    stats["positions"] = pos;
    stats["orients"] = orient;
    stats["extents"] = extent;
}

/// A path, a level set grid or None, into the inputs' path or grid (and provenance source).
void takeInput(py::object value, const char* key, const char* what, std::string& path,
               openvdb::FloatGrid::ConstPtr& grid, json& source)
{
    if (value.is_none()) return;
    if (py::isinstance<py::str>(value)) {
        path = value.cast<std::string>();
        return;
    }
    Grid g;
    try {
        g = value.cast<Grid>();
    } catch (const py::cast_error&) {
    }
    if (!g) throw py::type_error(std::string("fractal: ") + what);
    source[key] = gridSource(*g);
    grid = g;
}

/// runFractal in the given mode: (grids in the file's order, stats, mesh dict or None).
py::tuple runFractal(const std::string& mode, const std::string& params, py::object input,
                     bool levelSet, bool normalMap, bool withMesh)
{
    const fractal::FractalRockParams p =
        fractal::rockSchema().fromJson(parseParams(params, "fractal"));
    fractal::FractalInputs in;
    if (mode == "rock") {
        in.mode = fractal::FractalMode::Rock;
    } else if (mode == "scatter") {
        in.mode = fractal::FractalMode::Scatter;
        takeInput(input, "ground", "the ground must be None, a path or a pyopenvdb.FloatGrid level set",
                  in.groundPath, in.groundGrid, in.source);
    } else if (mode == "carve") {
        in.mode = fractal::FractalMode::Carve;
        if (input.is_none()) throw py::type_error("fractal_carve: the solid must be a path or a pyopenvdb.FloatGrid level set");
        takeInput(input, "carve", "the solid must be a path or a pyopenvdb.FloatGrid level set",
                  in.carvePath, in.carveGrid, in.source);
    } else {
        throw ValueError("fractal: no mode '" + mode + "' (rock, scatter, carve)");
    }
    in.levelSet = levelSet;
    in.normalMap = normalMap;
    in.mesh = withMesh;
    const fractal::FractalResult r = withTask([&](Task& task) {
        return fractal::runFractal(p, in, task);
    });
    py::list grids;
    for (const auto& g : r.grids) grids.append(openvdb::gridPtrCast<openvdb::FloatGrid>(g));
    py::dict stats = pyJson(r.stats).cast<py::dict>();
    py::object mesh = py::none();
    if (r.mode == fractal::FractalMode::Rock) {
        mesh = rockMesh(r.rock, normalMap);
        if (normalMap) mesh["normal_space"] = p.normalSpace;
    }
    if (r.mode == fractal::FractalMode::Scatter) {
        addPlacements(stats, r.scatter.rocks);
        if (withMesh) mesh = scatterMesh(r.scatter.mesh);
    }
    return py::make_tuple(grids, stats, mesh);
}

} // namespace

void bindFractal(py::module_& m)
{
    // Which rows of the fractal table each mode reads (the Python wrappers' signatures).
    m.def("fractal_rows", []() {
        py::dict d;
        d["scatter"] = fractal::scatterRows();
        d["single"] = fractal::singleRockRows();
        d["carve"] = fractal::carveRows();
        d["ground"] = fractal::groundRows();
        return d;
    });
    m.def("run_fractal", &runFractal, py::arg("mode"), py::arg("params"), py::arg("input"),
          py::arg("level_set") = true, py::arg("normal_map") = false, py::arg("mesh") = false,
          "The fractal-rock stage (vdb_fractal_rock) in mode 'rock', 'scatter' (input: the "
          "ground) or 'carve' (input: the solid): (grids, stats, mesh)");
    m.def("write_normal_map", [](const std::string& path,
                                 py::array_t<float, py::array::c_style | py::array::forcecast> a,
                                 const std::string& space, const std::string& up) {
        if (a.ndim() != 3 || a.shape(2) != 3) throw ValueError("write_normal_map: expected an H x W x 3 array");
        std::vector<float> rgb(a.data(), a.data() + a.size());
        fractal::writeNormalMap(path, int(a.shape(1)), int(a.shape(0)), std::move(rgb), space,
                                upAxisFromString(up, "mesh_up"));
    }, py::arg("path"), py::arg("image"), py::arg("space"), py::arg("up"),
          "vdb_fractal_rock --normal-map's writer: the map turned with a y-up mesh (object "
          "space), its space named in the EXR header");
}

} // namespace pyhost
} // namespace rockvdb
