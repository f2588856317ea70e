// SPDX-License-Identifier: Apache-2.0
// vdb_primitive — bake a primitive or a CSG expression of primitives into a level set.
#include "Cli.h"

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/Primitives.h>

#include <nlohmann/json.hpp>

using namespace rockvdb;

namespace {

// --planes 'nx,ny,nz,d;...' (n·p <= d is inside).
std::vector<Plane> parsePlanes(const std::string& planesText)
{
    std::vector<Plane> planes;
    std::stringstream ss(planesText);
    std::string item;
    while (std::getline(ss, item, ';')) {
        std::vector<double> v;
        std::stringstream is(item);
        std::string tok;
        while (std::getline(is, tok, ',')) {
            try { v.push_back(std::stod(tok)); } catch (...) {
                fail<ValueError>("polytope: cannot read '", tok, "' in --planes");
            }
        }
        if (v.size() != 4) fail<ValueError>("polytope: each plane needs nx,ny,nz,d (got '", item, "')");
        planes.push_back({Vec3d(v[0], v[1], v[2]), v[3]});
    }
    return planes;
}

// The expression file ('-' = stdin); relative paths in it resolve against its folder.
FieldPtr expressionField(const std::string& exprFile, uint64_t seed)
{
    ExpressionContext ctx;
    ctx.seed = seed;
    nlohmann::json j;
    if (exprFile == "-") {
        try { std::cin >> j; } catch (const nlohmann::json::exception& e) {
            fail<ValueError>("expression: malformed JSON on stdin: ", e.what());
        }
    } else {
        j = readJsonFile(exprFile);
        const auto slash = exprFile.find_last_of('/');
        ctx.baseDir = slash == std::string::npos ? "." : exprFile.substr(0, slash);
    }
    return fieldFromJson(j, ctx);
}

// The subcommands: one shape each, with its options.
struct Shapes
{
    std::vector<double> center{0, 0, 0}, size{1, 1, 1}, a{0, 0, 0}, b{0, 0, 1}, normal{0, 0, 1};
    double radius = 1.0, rounding = 0.0, smooth = 0.0;
    std::string planesText, exprFile, attribute;
    CLI::App *sSphere, *sBox, *sCapsule, *sPlane, *sPoly, *sExpr;

    void declare(CLI::App& app)
    {
        sSphere = app.add_subcommand("sphere", "Sphere of --radius at --center");
        sSphere->add_option("--radius", radius, "Radius (m)")->capture_default_str();
        sSphere->add_option("--center", center, "Centre x,y,z (m)")->delimiter(',')->expected(3)
            ->capture_default_str();

        sBox = app.add_subcommand("box", "Axis-aligned box with rounded edges");
        sBox->add_option("--center", center, "Centre x,y,z (m)")->delimiter(',')->expected(3)
            ->capture_default_str();
        sBox->add_option("--size", size, "Edge lengths x,y,z (m)")->delimiter(',')->expected(3)
            ->capture_default_str();
        sBox->add_option("--rounding", rounding, "Edge radius (m)")->capture_default_str();

        sCapsule = app.add_subcommand("capsule", "Points within --radius of segment [a, b]");
        sCapsule->add_option("--a", a, "First end x,y,z (m)")->delimiter(',')->expected(3)
            ->capture_default_str();
        sCapsule->add_option("--b", b, "Second end x,y,z (m)")->delimiter(',')->expected(3)
            ->capture_default_str();
        sCapsule->add_option("--radius", radius, "Radius (m)")->capture_default_str();

        sPlane = app.add_subcommand("plane", "Half-space behind a plane (needs --region)");
        sPlane->add_option("--point", center, "Point on the plane x,y,z (m)")->delimiter(',')
            ->expected(3)->capture_default_str();
        sPlane->add_option("--normal", normal, "Outward normal x,y,z")->delimiter(',')->expected(3)
            ->capture_default_str();

        sPoly = app.add_subcommand("polytope", "Convex polytope: intersection of half-spaces");
        sPoly->add_option("--planes", planesText,
                          "Planes 'nx,ny,nz,d;...' (n·p <= d is inside)")->required();
        sPoly->add_option("--smooth", smooth,
                          "Smooth-intersection radius R (m), implicit-blocks §4.2")->capture_default_str();

        sExpr = app.add_subcommand("expr", "A JSON expression of primitives and operators "
                                                 "(see ops/core/Expression.h)");
        sExpr->add_option("file", exprFile, "Expression .json ('-' = stdin)")->required();
        sExpr->add_option("--attribute", attribute,
                          "Also write an id grid with this name (e.g. block_id) from the ids "
                          "tagged in the expression");
    }

    // The chosen shape's field; an expression's --attribute goes into @a settings.
    FieldPtr make(BakeSettings& settings, uint64_t seed) const
    {
        FieldPtr field;
        if (*sSphere) field = sphere(cli::toVec3(center, "--center"), radius);
        else if (*sBox) field = box(cli::toVec3(center, "--center"), cli::toVec3(size, "--size") * 0.5, rounding);
        else if (*sCapsule) field = capsule(cli::toVec3(a, "--a"), cli::toVec3(b, "--b"), radius);
        else if (*sPlane) {
            if (!settings.region) fail<ValueError>("plane: a plane is unbounded; give --region");
            field = halfSpace(cli::toVec3(center, "--point"), cli::toVec3(normal, "--normal"));
        } else if (*sPoly) {
            field = convexPolytope(parsePlanes(planesText), smooth);
        } else {
            field = expressionField(exprFile, seed);
            if (!attribute.empty()) {
                settings.withAttribute = true;
                settings.attributeName = attribute;
            }
        }
        return field;
    }
};

} // namespace

int main(int argc, char** argv)
{
    cli::Tool tool("vdb_primitive",
                   "Bake an analytic primitive, or a CSG expression of primitives from JSON, "
                   "into a narrow-band level set (grid 'surface'). Units: metres, degrees.");
    CLI::App& app = tool.app();
    app.require_subcommand(1);
    tool.addParams(app, fieldBakeSchema());
    tool.addSeed(app);
    tool.addOutput(app, "Output .vdb ('-' = stdout)");

    Shapes shapes;
    shapes.declare(app);

    return tool.run(argc, argv, [&] {
        BakeSettings settings =
            fieldBakeSchema().fromJson(tool.givenParams(fieldBakeSchema())).bake.settings();
        const FieldPtr field = shapes.make(settings, tool.seed());
        cli::bakeAndWrite(tool, *field, settings);
    });
}
