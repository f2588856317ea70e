// SPDX-License-Identifier: Apache-2.0
// rockvdb.Field's native half: fields built from JSON expressions (vdb_primitive expr's
// language), combined and baked with the bake table's rows; heightfield images baked likewise.
#include "GridCaster.h"
#include "Host.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/HeightfieldStage.h>
#include <rockvdb/core/VdbIO.h>

#include <pybind11/stl.h>

using nlohmann::json;

namespace rockvdb {
namespace pyhost {

namespace {

using V3 = std::array<double, 3>;
Vec3d v3(const V3& a) { return Vec3d(a[0], a[1], a[2]); }
json j3(const V3& a) { return json::array({a[0], a[1], a[2]}); }

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

py::object bakeField(const PyField& f, BakeSettings s, std::optional<std::string> attribute,
                     const std::string& generator, const json& p)
{
    if (attribute) {
        s.withAttribute = true;
        s.attributeName = *attribute;
    }
    BakeResult r;
    {
        py::gil_scoped_release release;
        r = bake(*f.field, s);
    }
    stampProvenance(*r.surface, generator, jsonText(p));
    if (!r.attribute) return py::cast(r.surface);
    stampProvenance(*r.attribute, generator, jsonText(p));
    return py::make_tuple(py::cast(r.surface), py::cast(r.attribute));
}

} // namespace

void bindFields(py::module_& m)
{
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
        .def_property_readonly("expression", [](const PyField& f) { return jsonText(f.expr); },
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
        .def("bake", [](const PyField& f, const std::string& params, std::optional<std::string> attribute) {
            // The bake rows of fieldBakeSchema (the defaults every bake shares); provenance
            // keeps the keys Field.bake has always written.
            const BakeParams p = fieldBakeSchema().fromJson(parseParams(params, "bake")).bake;
            BakeSettings s = p.settings();
            json prov = {{"expression", f.expr}, {"voxel_size", s.voxelSize},
                         {"half_width", s.halfWidth}, {"renormalize", p.renormalize},
                         {"tracker_steps", p.trackerSteps}};
            if (p.region) prov["region"] = *p.region;
            return bakeField(f, s, attribute, "rockvdb.Field.bake", prov);
        }, py::arg("params"), py::arg("attribute") = py::none(),
           "Bake to a level set (the bake rows' JSON); with attribute='block_id' returns "
           "(surface, ids)");

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

    m.def("heightfield", [](const std::string& path, const std::string& params) {
        const HeightfieldParams p = heightfieldSchema().fromJson(parseParams(params, "heightfield"));
        const StageResult r = withTask([&](Task& task) { return runHeightfield(p, path, task); });
        return py::make_tuple(openvdb::gridPtrCast<openvdb::FloatGrid>(r.grids.at(0)), pyJson(r.stats));
    }, py::arg("path"), py::arg("params"),
       "vdb_heightfield: a heightfield image to a level set of the terrain solid (the table's JSON)");
}

} // namespace pyhost
} // namespace rockvdb
