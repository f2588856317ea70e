// The rockvdb Python module: fields that compose like fogleman/sdf, bakes that return
// pyopenvdb.FloatGrid objects, CSG, heightfields and I/O helpers.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/amplify/AmplifyStage.h>
#include <rockvdb/blocks/BlocksStage.h>
#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/GridCsg.h>
#include <rockvdb/core/GridField.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Image.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/Preview.h>
#include <rockvdb/core/Primitives.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/detail/DetailStage.h>
#include <rockvdb/fractal/FractalStage.h>
#include <rockvdb/rockpile/RockPileStage.h>

#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>

namespace py = pybind11;
using namespace rockvdb;
using namespace rockvdb::pyhost;
using nlohmann::json;
using Grid = openvdb::FloatGrid::Ptr;

namespace {

using V3 = std::array<double, 3>;
Vec3d v3(const V3& a) { return Vec3d(a[0], a[1], a[2]); }
json j3(const V3& a) { return json::array({a[0], a[1], a[2]}); }

/// A field plus the expression that rebuilds it (its provenance).
struct PyField
{
    FieldPtr field;
    json expr;
};

PyField build(const json& expr)
{
    ExpressionContext ctx;
    return {fieldFromJson(expr, ctx), expr};
}

PyField combine(const char* type, const PyField& a, const PyField& b, double smooth)
{
    json e = {{"type", type}, {"children", {a.expr, b.expr}}};
    if (smooth > 0) e["smooth"] = smooth;
    return {csg(csgOpFromString(type), {a.field, b.field}, smooth), e};
}

py::object bakeField(const PyField& f, double voxelSize, double halfWidth,
                     const std::string& renormalize, int trackerSteps,
                     std::optional<std::array<double, 6>> region,
                     std::optional<std::string> attribute, const std::string& generator,
                     const json& params)
{
    BakeSettings s;
    s.voxelSize = voxelSize;
    s.halfWidth = halfWidth;
    s.renormalize = renormalizeFromString(renormalize);
    s.trackerSteps = trackerSteps;
    if (region) {
        const auto& r = *region;
        s.region = BBoxd(Vec3d(r[0], r[1], r[2]), Vec3d(r[3], r[4], r[5]));
    }
    if (attribute) {
        s.withAttribute = true;
        s.attributeName = *attribute;
    }
    BakeResult r;
    {
        py::gil_scoped_release release;
        r = bake(*f.field, s);
    }
    json p = params;
    p["voxel_size"] = voxelSize;
    p["half_width"] = halfWidth;
    p["renormalize"] = renormalize;
    p["tracker_steps"] = trackerSteps;
    if (region) p["region"] = *region;
    stampProvenance(*r.surface, generator, p.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
    if (!r.attribute) return py::cast(r.surface);
    stampProvenance(*r.attribute, generator, p.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
    return py::make_tuple(py::cast(r.surface), py::cast(r.attribute));
}

struct PyTile
{
    std::shared_ptr<const blocks::BlockTile> tile;
};

// BlockTile.bake / block_tile(bake=True): the stage's bakeTile with the table's defaults for
// what the call leaves out (periods and the bake's rows).
py::tuple bakeTile(const PyTile& t, const std::string& params)
{
    blocks::BlocksParams p = blocks::blocksSchema().fromJson(parseParams(params, "blocks"));
    blocks::BlocksResult r;
    {
        py::gil_scoped_release release;
        PyTaskHost host;
        Task task(&host);
        r = blocks::bakeTile(t.tile, p, json::object(), task);
    }
    return py::make_tuple(py::cast(r.bake.surface), py::cast(r.bake.attribute));
}

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
    amplify::AmplifyRun r;
    {
        py::gil_scoped_release release;
        PyTaskHost host;
        Task task(&host);
        r = amplify::runAmplify(p, in, task);
    }
    const amplify::AmplifyStats& stats = r.stats;
    py::dict st;
    st["replicated"] = stats.replicated;
    st["cells"] = stats.cells;
    st["block_field_bytes"] = stats.blockBytes;
    st["active_voxels"] = stats.bake.activeVoxels;
    st["presence_seconds"] = stats.presenceSeconds;
    st["bake_seconds"] = stats.bakeSeconds;
    st["split_seconds"] = stats.splitSeconds;
    return py::make_tuple(py::cast(r.grids.surface), py::cast(r.grids.blockId),
                          py::cast(r.grids.material), st);
}

} // namespace

// Ctrl-C while a file's bytes are checked in readGrids' child process (a corrupt file can
// keep it busy for its whole CPU budget): only the thread that imported the module, as the
// interpreter's main thread, sees Python's signals.
static std::thread::id gImportThread;

static bool pyReadInterrupt()
{
    if (std::this_thread::get_id() != gImportThread || !Py_IsInitialized()) return false;
    py::gil_scoped_acquire gil;
    if (PyErr_CheckSignals() == 0) return false;
    PyErr_Clear(); // raised again as KeyboardInterrupt by the Interrupted translator
    return true;
}

PYBIND11_MODULE(_rockvdb, m)
{
    m.doc() = "rockvdb: procedural rocks as OpenVDB level sets (metres, negative inside)";
    py::module_::import("pyopenvdb");
    initialize();
    gImportThread = std::this_thread::get_id();
    setReadInterrupt(&pyReadInterrupt);

    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const ValueError& e) {
            PyErr_SetString(PyExc_ValueError, e.what());
        } catch (const IoError& e) {
            PyErr_SetString(PyExc_IOError, e.what());
        } catch (const Interrupted& e) {
            PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
        } catch (const openvdb::IoError& e) {
            PyErr_SetString(PyExc_IOError, e.what());
        }
    });
    m.attr("__version__") = version();

    py::class_<PyField>(m, "Field", "A signed-distance field (metres, negative inside)")
        .def("eval", [](const PyField& f, const V3& p) { return f.field->eval(v3(p)); },
             py::arg("p"), "Value at world point p")
        .def("bounds", [](const PyField& f) {
            const BBoxd b = f.field->bounds();
            return py::make_tuple(py::make_tuple(b.min()[0], b.min()[1], b.min()[2]),
                                  py::make_tuple(b.max()[0], b.max()[1], b.max()[2]));
        })
        .def_property_readonly("lipschitz", [](const PyField& f) { return f.field->lipschitz(); })
        .def_property_readonly("exact", [](const PyField& f) { return f.field->exact(); })
        .def_property_readonly("expression", [](const PyField& f) { return f.expr.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace); },
                               "JSON expression (vdb_primitive expr) that rebuilds this field")
        .def("union", [](const PyField& a, const PyField& b, double r) { return combine("union", a, b, r); },
             py::arg("other"), py::arg("smooth") = 0.0)
        .def("intersection", [](const PyField& a, const PyField& b, double r) { return combine("intersection", a, b, r); },
             py::arg("other"), py::arg("smooth") = 0.0)
        .def("difference", [](const PyField& a, const PyField& b, double r) { return combine("difference", a, b, r); },
             py::arg("other"), py::arg("smooth") = 0.0)
        .def("__or__", [](const PyField& a, const PyField& b) { return combine("union", a, b, 0); })
        .def("__and__", [](const PyField& a, const PyField& b) { return combine("intersection", a, b, 0); })
        .def("__sub__", [](const PyField& a, const PyField& b) { return combine("difference", a, b, 0); })
        .def("transform", [](const PyField& f, const V3& t, const V3& r, py::object scale) {
            json e = {{"type", "transform"}, {"translate", j3(t)}, {"rotate", j3(r)}, {"child", f.expr}};
            if (py::isinstance<py::float_>(scale) || py::isinstance<py::int_>(scale)) e["scale"] = scale.cast<double>();
            else e["scale"] = j3(scale.cast<V3>());
            return build(e);
        }, py::arg("translate") = V3{0, 0, 0}, py::arg("rotate") = V3{0, 0, 0},
           py::arg("scale") = 1.0, "Scale, rotate (XYZ degrees), then translate")
        .def("warp", [](const PyField& f, double amplitude, double frequency, int octaves, uint64_t seed) {
            return build({{"type", "warp"}, {"amplitude", amplitude}, {"frequency", frequency},
                          {"octaves", octaves}, {"seed", seed}, {"child", f.expr}});
        }, py::arg("amplitude"), py::arg("frequency") = 1.0, py::arg("octaves") = 3, py::arg("seed") = 0,
           "Domain warp by vector fBm noise (amplitude in metres)")
        .def("tag", [](const PyField& f, int id) {
            json e = f.expr;
            e["id"] = id;
            return build(e);
        }, py::arg("id"), "Tag with an integer id for attribute grids")
        .def("bake", [](const PyField& f, double voxelSize, double halfWidth, const std::string& renorm,
                        int steps, std::optional<std::array<double, 6>> region,
                        std::optional<std::string> attribute) {
            return bakeField(f, voxelSize, halfWidth, renorm, steps, region, attribute,
                             "rockvdb.Field.bake", {{"expression", f.expr}});
        }, py::arg("voxel_size") = 0.05, py::arg("half_width") = 3.0, py::arg("renormalize") = "auto",
           py::arg("tracker_steps") = 0, py::arg("region") = py::none(), py::arg("attribute") = py::none(),
           "Bake to a level set (pyopenvdb.FloatGrid named 'surface'); with attribute='block_id' "
           "returns (surface, ids)");

    py::class_<PyTile>(m, "Tile", "A fractured block tile (implicit-blocks §4); see rockvdb.block_tile")
        .def("to_json", [](const PyTile& t) { return blocks::tileToJson(*t.tile).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace); },
             "The tile file's JSON text")
        .def("save", [](const PyTile& t, const std::string& path) { blocks::writeTile(*t.tile, path); },
             py::arg("path"), "Write the tile file (atomic)")
        .def("bake", &bakeTile, py::arg("params"),
             "Bake (surface, block_id): periods and bake rows of vdb_blocks' table (JSON)")
        .def("field", [](const PyTile& t, const std::array<int, 3>& periods, bool periodic) {
            blocks::TileFieldOptions o;
            o.periods = periods;
            o.periodic = periodic;
            return PyField{blocks::tileField(t.tile, o),
                           {{"type", "block_tile"}, {"tile", t.tile->params.toJson()},
                            {"periods", periods}, {"periodic", periodic}}};
        }, py::arg("periods") = std::array<int, 3>{1, 1, 1}, py::arg("periodic") = false,
           "The tile as a Field (union of its blocks; periodic=True tiles all of space)");
    m.def("generate_tile", [](const std::string& params) {
        const blocks::BlockTileParams p = blocks::tileSchema().fromJson(parseParams(params, "blocks"));
        std::shared_ptr<const blocks::BlockTile> t;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            t = blocks::makeTile(p, task);
        }
        return PyTile{t};
    }, py::arg("params"), "A tile from the tile rows of vdb_blocks' table (JSON)");
    m.def("load_tile", [](const std::string& path) {
        return PyTile{std::make_shared<const blocks::BlockTile>(blocks::readTile(path))};
    }, py::arg("path"), "Read a .tile file or a vdb_blocks .vdb");

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

    m.def("sphere", [](double radius, const V3& c) {
        return build({{"type", "sphere"}, {"radius", radius}, {"center", j3(c)}});
    }, py::arg("radius") = 1.0, py::arg("center") = V3{0, 0, 0});
    m.def("box", [](const V3& size, const V3& c, double rounding) {
        return build({{"type", "box"}, {"size", j3(size)}, {"center", j3(c)}, {"rounding", rounding}});
    }, py::arg("size") = V3{1, 1, 1}, py::arg("center") = V3{0, 0, 0}, py::arg("rounding") = 0.0);
    m.def("capsule", [](const V3& a, const V3& b, double radius) {
        return build({{"type", "capsule"}, {"a", j3(a)}, {"b", j3(b)}, {"radius", radius}});
    }, py::arg("a"), py::arg("b"), py::arg("radius"));
    m.def("plane", [](const V3& point, const V3& normal) {
        return build({{"type", "plane"}, {"point", j3(point)}, {"normal", j3(normal)}});
    }, py::arg("point") = V3{0, 0, 0}, py::arg("normal") = V3{0, 0, 1});
    m.def("polytope", [](const std::vector<std::array<double, 4>>& planes, double smooth) {
        json ps = json::array();
        for (const auto& p : planes) ps.push_back({p[0], p[1], p[2], p[3]});
        return build({{"type", "polytope"}, {"planes", ps}, {"smooth", smooth}});
    }, py::arg("planes"), py::arg("smooth") = 0.0, "Intersection of n·p <= d half-spaces");
    m.def("expression", [](const std::string& text) {
        return build(parseJson(text, "expression"));
    }, py::arg("json"), "A field from a JSON expression (see vdb_primitive expr)");

    m.def("heightfield", [](const std::string& path, double cellSize, double heightScale,
                            double baseDepth, double voxelSize, double halfWidth) {
        auto hf = std::make_shared<Heightfield>(loadHeightfield(path, cellSize, heightScale));
        HeightfieldSettings hs;
        hs.baseDepth = baseDepth;
        PyField f{heightfieldField(hf, hs), json()};
        return bakeField(f, voxelSize, halfWidth, "auto", 0, std::nullopt, std::nullopt,
                         "rockvdb.heightfield",
                         {{"file", path}, {"cell_size", cellSize}, {"height_scale", heightScale},
                          {"base_depth", baseDepth}});
    }, py::arg("path"), py::arg("cell_size") = 1.0, py::arg("height_scale") = 1.0,
       py::arg("base_depth") = 1.0, py::arg("voxel_size") = 0.05, py::arg("half_width") = 3.0,
       "Heightfield image (EXR / 16-bit PNG) to a level set of the terrain solid");

    m.def("write_heightfield", [](const std::string& path, py::array_t<float, py::array::c_style | py::array::forcecast> a) {
        if (a.ndim() != 2) throw ValueError("write_heightfield: expected a 2D array (rows, columns)");
        GrayImage img;
        img.height = int(a.shape(0));
        img.width = int(a.shape(1));
        img.pixels.assign(a.data(), a.data() + a.size());
        writeGrayImage(path, img);
    }, py::arg("path"), py::arg("array"), "Write a 2D array as float EXR or 16-bit PNG (row 0 first)");

    m.def("detail", [](Grid grid, const std::string& params, std::optional<Grid> blendMask) {
        if (!grid) throw py::type_error("detail: the input grid is None");
        const detailing::DetailStageParams p =
            detailing::detailSchema().fromJson(parseParams(params, "detail"));
        detailing::DetailInputs in;
        in.grid = grid;
        if (blendMask) in.blendMask = *blendMask;
        detailing::DetailResult r;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            r = detailing::runDetail(p, in, task);
        }
        return r.bake.surface;
    }, py::arg("grid"), py::arg("params"), py::arg("blend_mask") = std::nullopt);

    // Stage tables: the Python wrappers build their signatures, defaults and docstrings
    // from these (python/rockvdb/__init__.py).
    bindArches(m);

    m.def("schema", [](const std::string& stage) {
        if (stage == "rock_tiles") return rockpile::tilesSchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "rock_pile") return rockpile::pileSchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "detail") return detailing::detailSchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "block_tile") return blocks::blocksSchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "tile") return blocks::tileSchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "amplify") return amplify::amplifySchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "fractal_rock" || stage == "fractal_scatter") return fractal::rockSchema().describe().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        if (stage == "arches") return archesSchemaText();
        throw ValueError("schema: no stage '" + stage + "'");
    }, py::arg("stage"));

    m.def("rock_tiles", [](const std::string& params, double maxMemoryGB) {
        const rockpile::RockTileParams p = rockpile::tilesSchema().fromJson(parseParams(params, "rockpile"));
        require(std::isfinite(maxMemoryGB) && maxMemoryGB >= 0, "rockpile", "max_memory", ">= 0 GB",
                maxMemoryGB);
        py::gil_scoped_release release;
        PyTaskHost host;
        Task task(&host);
        return rockpile::runTiles(p, false, task, maxMemoryGB * 1e9).rho;
    }, py::arg("params"), py::arg("max_memory") = 0.0);

    // One fractal rock: (surface or None, {points, triangles, normals[, uvs, triangle_uvs,
    // normal_map]} as numpy arrays).
    // Which rows of the fractal table each mode reads (the Python wrappers' signatures).
    m.def("fractal_rows", []() {
        py::dict d;
        d["scatter"] = fractal::scatterRows();
        d["single"] = fractal::singleRockRows();
        d["carve"] = fractal::carveRows();
        d["ground"] = fractal::groundRows();
        return d;
    });

    m.def("fractal_rock", [](const std::string& params, bool levelSet, bool normalMap) {
        const fractal::FractalRockParams p = fractal::rockSchema().fromJson(parseParams(params, "fractal"));
        fractal::RockResult r;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            r = fractal::runRock(p, levelSet, normalMap, task);
        }
        const Mesh& m = r.mesh;
        auto rows = [](const auto& v, size_t cols, auto type) {
            using T = decltype(type);
            py::array_t<T> a({v.size(), cols});
            T* out = a.mutable_data();
            for (size_t i = 0; i < v.size(); ++i)
                for (size_t c = 0; c < cols; ++c) out[i * cols + c] = T(v[i][c]);
            return a;
        };
        py::dict mesh;
        mesh["points"] = rows(m.points, 3, float());
        mesh["triangles"] = rows(m.triangles, 3, int32_t());
        mesh["normals"] = rows(m.normals, 3, float());
        if (!m.uvs.empty()) {
            mesh["uvs"] = rows(m.uvs, 2, float());
            mesh["triangle_uvs"] = rows(m.triangleUvs, 3, int32_t());
        }
        if (normalMap) {
            py::array_t<float> img({size_t(r.normalMapHeight), size_t(r.normalMapWidth), size_t(3)});
            std::copy(r.normalMap.begin(), r.normalMap.end(), img.mutable_data());
            mesh["normal_map"] = img;
        }
        py::object surface = r.surface ? py::cast(r.surface) : py::none();
        return py::make_tuple(surface, mesh);
    }, py::arg("params"), py::arg("level_set") = true, py::arg("normal_map") = false);

    // Fractal rocks scattered on a ground (a path, a level set grid or None: the plane).
    m.def("fractal_scatter", [](py::object ground, const std::string& params, bool withMesh) {
        const fractal::FractalRockParams p = fractal::rockSchema().fromJson(parseParams(params, "fractal"));
        json inputs = json::object();
        std::shared_ptr<const fractal::Ground> g;
        if (ground.is_none()) {
            g = fractal::planeGround();
        } else if (py::isinstance<py::str>(ground)) {
            inputs["ground"] = ground.cast<std::string>();
            g = fractal::loadGround(ground.cast<std::string>(), p);
        } else {
            Grid grid;
            try {
                grid = ground.cast<Grid>();
            } catch (const py::cast_error&) {
            }
            if (!grid) throw py::type_error("fractal_scatter: the ground must be None, a path or a pyopenvdb.FloatGrid level set");
            requireLevelSet(*grid, "fractal ground");
            inputs["ground"] = gridSource(*grid);
            g = fractal::levelSetGround(*grid);
        }
        fractal::ScatterResult r;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            r = fractal::runScatter(p, *g, inputs, false, withMesh, task);
        }
        py::dict stats;
        stats["asked"] = r.stats.asked;
        stats["placed"] = r.stats.placed;
        stats["candidates"] = r.stats.candidates;
        stats["rejected_density"] = r.stats.rejectedDensity;
        stats["rejected_overlap"] = r.stats.rejectedOverlap;
        stats["place_seconds"] = r.stats.placeSeconds;
        stats["mesh_seconds"] = r.stats.meshSeconds;
        stats["level_set_seconds"] = r.stats.levelSetSeconds;
        const size_t n = r.rocks.size();
        py::array_t<double> pos({n, size_t(3)}), orient({n, size_t(4)}), extent({n, size_t(3)}), radius(n);
        for (size_t i = 0; i < n; ++i) {
            const auto q = fractal::quaternionOf(r.rocks[i].rotation);
            for (int c = 0; c < 3; ++c) {
                pos.mutable_at(i, c) = r.rocks[i].position[c];
                extent.mutable_at(i, c) = r.rocks[i].extent[c];
            }
            for (int c = 0; c < 4; ++c) orient.mutable_at(i, c) = q[size_t(c)];
            radius.mutable_at(i) = r.rocks[i].radius;
        }
        stats["radii"] = radius;
        stats["positions"] = pos;
        stats["orients"] = orient;
        stats["extents"] = extent;
        py::object mesh = py::none();
        if (withMesh) {
            py::dict m;
            py::array_t<float> pts({r.mesh.points.size(), size_t(3)});
            py::array_t<int32_t> tris({r.mesh.triangles.size(), size_t(3)}), groups(r.mesh.triangleGroups.size());
            for (size_t i = 0; i < r.mesh.points.size(); ++i)
                for (int c = 0; c < 3; ++c) pts.mutable_at(i, c) = r.mesh.points[i][c];
            for (size_t i = 0; i < r.mesh.triangles.size(); ++i) {
                for (int c = 0; c < 3; ++c) tris.mutable_at(i, c) = int32_t(r.mesh.triangles[i][c]);
                groups.mutable_at(i) = r.mesh.triangleGroups[i];
            }
            m["points"] = pts;
            m["triangles"] = tris;
            m["rock"] = groups;
            mesh = m;
        }
        return py::make_tuple(Grid(r.surface), Grid(r.rockId), stats, mesh, Grid(r.material));
    }, py::arg("ground"), py::arg("params"), py::arg("mesh") = false);

    // Caves (§9): a chain of rocks subtracted from a solid (a path or a level set grid).
    m.def("fractal_carve", [](py::object solid, const std::string& params) {
        const fractal::FractalRockParams p = fractal::rockSchema().fromJson(parseParams(params, "fractal"));
        json inputs = json::object();
        Grid grid;
        if (py::isinstance<py::str>(solid)) {
            inputs["carve"] = solid.cast<std::string>();
            const auto grids = readGrids(solid.cast<std::string>());
            grid = findLevelSet(*grids, "", solid.cast<std::string>());
        } else {
            try {
                if (!solid.is_none()) grid = solid.cast<Grid>();
            } catch (const py::cast_error&) {
            }
            if (!grid) throw py::type_error("fractal_carve: the solid must be a path or a pyopenvdb.FloatGrid level set");
            inputs["carve"] = gridSource(*grid);
        }
        fractal::CarveResult r;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            r = fractal::runCarve(p, *grid, inputs, task);
        }
        return py::make_tuple(Grid(r.surface), Grid(r.cave));
    }, py::arg("solid"), py::arg("params"));

    m.def("write_mesh", [](py::array_t<float, py::array::c_style | py::array::forcecast> points,
                           py::array_t<int32_t, py::array::c_style | py::array::forcecast> triangles,
                           std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>> normals,
                           std::optional<py::array_t<float, py::array::c_style | py::array::forcecast>> uvs,
                           std::optional<py::array_t<int32_t, py::array::c_style | py::array::forcecast>> triangleUvs,
                           const std::string& path, const std::string& up) {
        Mesh m;
        auto check = [](const auto& a, py::ssize_t cols, const char* what) {
            if (a.ndim() != 2 || a.shape(1) != cols) {
                throw ValueError(std::string("write_mesh: ") + what + " must be an N x " + std::to_string(cols) + " array");
            }
        };
        check(points, 3, "points");
        check(triangles, 3, "triangles");
        for (py::ssize_t i = 0; i < points.shape(0); ++i) m.points.emplace_back(points.at(i, 0), points.at(i, 1), points.at(i, 2));
        for (py::ssize_t i = 0; i < triangles.shape(0); ++i) {
            for (int c = 0; c < 3; ++c) {
                if (triangles.at(i, c) < 0 || triangles.at(i, c) >= points.shape(0)) throw ValueError("write_mesh: triangle index out of range");
            }
            m.triangles.emplace_back(unsigned(triangles.at(i, 0)), unsigned(triangles.at(i, 1)), unsigned(triangles.at(i, 2)));
        }
        if (normals) {
            check(*normals, 3, "normals");
            if (normals->shape(0) != points.shape(0)) throw ValueError("write_mesh: one normal per point");
            for (py::ssize_t i = 0; i < normals->shape(0); ++i) m.normals.emplace_back(normals->at(i, 0), normals->at(i, 1), normals->at(i, 2));
        }
        if (uvs && triangleUvs) {
            check(*uvs, 2, "uvs");
            check(*triangleUvs, 3, "triangle_uvs");
            if (triangleUvs->shape(0) != triangles.shape(0)) throw ValueError("write_mesh: one triangle_uvs row per triangle");
            for (py::ssize_t i = 0; i < uvs->shape(0); ++i) m.uvs.emplace_back(uvs->at(i, 0), uvs->at(i, 1));
            for (py::ssize_t i = 0; i < triangleUvs->shape(0); ++i) {
                for (int c = 0; c < 3; ++c) {
                    if (triangleUvs->at(i, c) < 0 || triangleUvs->at(i, c) >= uvs->shape(0)) throw ValueError("write_mesh: uv index out of range");
                }
                m.triangleUvs.emplace_back(unsigned(triangleUvs->at(i, 0)), unsigned(triangleUvs->at(i, 1)), unsigned(triangleUvs->at(i, 2)));
            }
        }
        writeMesh(m, path, upAxisFromString(up, "up"));
    }, py::arg("points"), py::arg("triangles"), py::arg("normals") = std::nullopt,
       py::arg("uvs") = std::nullopt, py::arg("triangle_uvs") = std::nullopt, py::arg("path"),
       py::arg("up") = "z");

    m.def("write_rgb_exr", [](const std::string& path, py::array_t<float, py::array::c_style | py::array::forcecast> a) {
        if (a.ndim() != 3 || a.shape(2) != 3) throw ValueError("write_rgb_exr: expected an H x W x 3 array");
        std::vector<float> rgb(a.data(), a.data() + a.size());
        writeRgbExr(path, int(a.shape(1)), int(a.shape(0)), rgb);
    }, py::arg("path"), py::arg("image"));

    m.def("rock_library", [](Grid tiles) {
        if (!tiles) throw py::type_error("rockpile: the tile set grid is None");
        const rockpile::TileSet set = rockpile::tilesFromGrid(*tiles);
        Grid lib;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            lib = rockpile::libraryGrid(set, task);
        }
        stampProvenance(*lib, rockpile::kToolName,
                        json{{"tiles", rockpile::tilesSchema().toJson(set.params)}}.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
        return lib;
    }, py::arg("tiles"));

    m.def("rock_pile", [](py::object tiles, py::object support, const std::string& params) {
        const rockpile::PileParams p = rockpile::pileSchema().fromJson(parseParams(params, "rockpile"));
        json inputs;
        rockpile::TileSet set;
        if (py::isinstance<py::str>(tiles)) {
            inputs["tiles"] = tiles.cast<std::string>();
            set = rockpile::readTileSet(tiles.cast<std::string>());
        } else {
            Grid g = tiles.is_none() ? Grid() : tiles.cast<Grid>();
            if (!g) throw py::type_error("rockpile: the tile set grid is None");
            inputs["tiles"] = gridSource(*g);
            set = rockpile::tilesFromGrid(*g);
        }
        FieldPtr field;
        if (py::isinstance<py::str>(support)) {
            inputs["support"] = support.cast<std::string>();
            field = rockpile::loadSupport(support.cast<std::string>(), set, p.seed, p.support);
        } else if (py::isinstance<PyField>(support)) {
            const PyField& f = support.cast<const PyField&>();
            field = f.field;
            inputs["support"] = f.expr;
        } else {
            Grid g;
            try {
                if (!support.is_none()) g = support.cast<Grid>();
            } catch (const py::cast_error&) {
            }
            if (!g) {
                throw py::type_error("rockpile: the support must be a pyopenvdb.FloatGrid level "
                                     "set, a rockvdb Field or a file path");
            }
            requireLevelSet(*g, "rockpile support");
            field = rockpile::levelSetSupport(g, set);
            inputs["support"] = gridSource(*g);
        }
        rockpile::PileResult r;
        {
            py::gil_scoped_release release;
            PyTaskHost host;
            Task task(&host);
            r = rockpile::runPile(set, *field, p, inputs, false, false, task);
        }
        py::dict stats;
        stats["placed"] = r.stats.placed;
        stats["candidates"] = r.stats.candidates;
        stats["features"] = r.stats.features;
        stats["dropped_deep"] = r.stats.droppedDeep;
        stats["select_seconds"] = r.stats.selectSeconds;
        stats["level_set_seconds"] = r.stats.levelSetSeconds;
        py::list rocks, positions;
        for (const auto& in : r.pile.instances) {
            rocks.append(in.rock);
            positions.append(py::make_tuple(in.position[0], in.position[1], in.position[2]));
        }
        stats["rocks"] = rocks;
        stats["positions"] = positions;
        return py::make_tuple(Grid(r.pile.surface), Grid(r.pile.rockId), Grid(r.pile.material), stats);
    }, py::arg("tiles"), py::arg("support"), py::arg("params"));

    m.def("read_image", [](const std::string& path, const std::string& op) {
        GrayImage img = readGrayImage(path, op.c_str());
        py::array_t<float> a({img.height, img.width});
        std::copy(img.pixels.begin(), img.pixels.end(), a.mutable_data());
        return a;
    }, py::arg("path"), py::arg("op") = "image",
       "Read a float EXR / 16-bit PNG (0..1) as a 2D array (row 0 first)");

    m.def("csg", [](const std::string& op, const std::vector<Grid>& grids, double smooth,
                    const std::vector<std::vector<Grid>>& ids, double maxMemoryGB) -> py::object {
        require(std::isfinite(maxMemoryGB) && maxMemoryGB >= 0, "csg", "max_memory", ">= 0 GB",
                maxMemoryGB);
        std::vector<openvdb::FloatGrid::ConstPtr> in(grids.begin(), grids.end());
        if (!ids.empty() && ids.size() != grids.size()) {
            throw ValueError("csg: ids needs one list of id grids per input grid");
        }
        // Id grids by name, in order of first appearance (as vdb_csg carries them).
        std::vector<std::string> names;
        for (const auto& list : ids) {
            for (const auto& g : list) {
                if (std::find(names.begin(), names.end(), g->getName()) == names.end()) {
                    names.push_back(g->getName());
                }
            }
        }
        Grid g;
        std::vector<Grid> carried;
        {
            py::gil_scoped_release release;
            g = csgGrids(csgOpFromString(op), in, smooth, maxMemoryGB * 1e9);
            for (const auto& name : names) {
                std::vector<openvdb::FloatGrid::ConstPtr> per;
                for (const auto& list : ids) {
                    openvdb::FloatGrid::ConstPtr found;
                    for (const auto& x : list) {
                        if (x->getName() == name && !found) found = x;
                    }
                    per.push_back(found);
                }
                carried.push_back(csgAttribute(csgOpFromString(op), in, per, *g, name));
            }
        }
        json sources = json::array();
        for (const auto& in : grids) {
            auto p = provenance(*in);
            sources.push_back(p ? json{{"generator", p->generator},
                                       {"params", jsonOrText(p->params)}}
                                : json(nullptr));
        }
        const std::string prov = json({{"op", op}, {"smooth", smooth}, {"sources", sources}}).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
        stampProvenance(*g, "rockvdb.csg", prov);
        if (ids.empty()) return py::cast(g);
        py::list out;
        for (const auto& c : carried) {
            stampProvenance(*c, "rockvdb.csg", prov);
            out.append(py::cast(c));
        }
        return py::make_tuple(py::cast(g), out);
    }, py::arg("op"), py::arg("grids"), py::arg("smooth") = 0.0,
       py::arg("ids") = std::vector<std::vector<Grid>>{}, py::arg("max_memory") = 0.0,
       "union / intersection / difference of level-set grids (inputs untouched)");

    m.def("read", [](const std::string& path, const std::string& name) { return readLevelSet(path, name); },
          py::arg("path"), py::arg("grid") = "surface", "Read a float level set by name");
    m.def("write", [](const std::string& path, const std::vector<Grid>& grids) {
        // Every grid written carries provenance; foreign grids get it on a shallow copy (the
        // caller's grid and its metadata are left as they are).
        openvdb::GridCPtrVec v;
        for (const auto& g : grids) {
            if (provenance(*g)) { v.push_back(g); continue; }
            auto copy = g->copyGrid();
            stampProvenance(*copy, "rockvdb.write", "{}");
            v.push_back(copy);
        }
        writeGrids(path, v);
    }, py::arg("path"), py::arg("grids"), "Write grids atomically (Blosc compressed); grids "
       "without rockvdb provenance are stamped generator 'rockvdb.write'");
    m.def("mesh", [](Grid grid, const std::string& path, double isovalue, double adaptivity,
                     const std::string& up) {
        requireLevelSet(*grid, "mesh input");
        const UpAxis axis = upAxisFromString(up, "mesh: up");
        Mesh mesh;
        {
            py::gil_scoped_release release;
            mesh = meshLevelSet(*grid, isovalue, adaptivity);
        }
        writeMesh(mesh, path, axis);
    }, py::arg("grid"), py::arg("path"), py::arg("isovalue") = 0.0, py::arg("adaptivity") = 0.0,
       py::arg("up") = "z");
    m.def("preview", [](Grid grid, const std::string& path, int width, int height, double azimuth,
                        double elevation, double zoom, std::optional<Grid> ids,
                        const std::string& palette) {
        PreviewSettings s;
        s.width = width;
        s.height = height;
        s.azimuth = azimuth;
        s.elevation = elevation;
        s.zoom = zoom;
        if (!palette.empty()) s.palette = parsePalette(palette, "preview: palette");
        PreviewStats st;
        {
            py::gil_scoped_release release;
            writePreview(*grid, path, s, ids ? ids->get() : nullptr, &st);
        }
        py::dict out;
        out["surface"] = double(st.surfacePixels) / double(st.pixels);
        py::dict byId;
        for (const auto& [id, n] : st.idPixels) byId[py::int_(id)] = double(n) / double(st.pixels);
        out["ids"] = byId;
        return out;
    }, py::arg("grid"), py::arg("path"), py::arg("width") = 960, py::arg("height") = 540,
       py::arg("azimuth") = 35.0, py::arg("elevation") = 30.0, py::arg("zoom") = 1.0,
       py::arg("ids") = py::none(), py::arg("palette") = "");
    m.def("provenance", [](Grid grid) -> py::object {
        auto p = provenance(*grid);
        if (!p) return py::none();
        return py::make_tuple(p->version, p->generator, p->params);
    }, py::arg("grid"), "(version, generator, params JSON) or None");
}
