// SPDX-License-Identifier: Apache-2.0
#include "Expression.h"

#include <rockvdb/core/Combinators.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Heightfield.h>
#include <rockvdb/core/Primitives.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cmath>
#include <cstdint>
#include <set>

namespace rockvdb {

using nlohmann::json;

namespace {

class Builder
{
public:
    explicit Builder(const ExpressionContext& ctx) : mCtx(ctx) {}

    FieldPtr build(const json& n, const std::string& path)
    {
        if (!n.is_object()) bad(path, "expected an object with a \"type\"");
        if (!n.contains("type") || !n["type"].is_string()) bad(path, "missing \"type\"");
        const std::string type = n["type"];
        FieldPtr f;
        try {
            f = buildTyped(type, n, path);
        } catch (const ValueError& e) {
            const std::string msg = e.what();
            if (msg.rfind("expression", 0) == 0) throw;
            bad(path, msg);
        }
        if (n.contains("id")) f = tag(f, float(num(n, "id", path)));
        return f;
    }

private:
    FieldPtr buildTyped(const std::string& type, const json& n, const std::string& path)
    {
        if (type == "sphere") {
            allow(n, path, {"center", "radius"});
            return sphere(vec(n, "center", path, Vec3d(0)), num(n, "radius", path));
        }
        if (type == "box") {
            allow(n, path, {"center", "size", "rounding"});
            return box(vec(n, "center", path, Vec3d(0)), vec(n, "size", path) * 0.5,
                       num(n, "rounding", path, 0.0));
        }
        if (type == "capsule") {
            allow(n, path, {"a", "b", "radius"});
            return capsule(vec(n, "a", path), vec(n, "b", path), num(n, "radius", path));
        }
        if (type == "plane") {
            allow(n, path, {"point", "normal"});
            return halfSpace(vec(n, "point", path, Vec3d(0)), vec(n, "normal", path));
        }
        if (type == "polytope") {
            allow(n, path, {"planes", "smooth"});
            const json& ps = field(n, "planes", path);
            if (!ps.is_array()) bad(path + "/planes", "expected an array of [nx, ny, nz, d]");
            std::vector<Plane> planes;
            for (size_t i = 0; i < ps.size(); ++i) {
                const json& p = ps[i];
                if (!p.is_array() || p.size() != 4 || !std::all_of(p.begin(), p.end(),
                        [](const json& v) { return v.is_number(); })) {
                    bad(path + "/planes/" + std::to_string(i), "expected [nx, ny, nz, d]");
                }
                planes.push_back({Vec3d(p[0].get<double>(), p[1].get<double>(),
                                        p[2].get<double>()), p[3].get<double>()});
            }
            return convexPolytope(planes, num(n, "smooth", path, 0.0));
        }
        if (type == "union" || type == "intersection" || type == "difference") {
            allow(n, path, {"children", "smooth"});
            const json& cs = field(n, "children", path);
            if (!cs.is_array() || cs.empty()) bad(path + "/children", "expected a non-empty array");
            std::vector<FieldPtr> children;
            for (size_t i = 0; i < cs.size(); ++i) {
                children.push_back(build(cs[i], path + "/children/" + std::to_string(i)));
            }
            return csg(csgOpFromString(type), children, num(n, "smooth", path, 0.0));
        }
        if (type == "transform") {
            allow(n, path, {"translate", "rotate", "scale", "child"});
            Vec3d scale(1.0);
            if (n.contains("scale") && n["scale"].is_number()) scale = Vec3d(n["scale"].get<double>());
            else if (n.contains("scale")) scale = vec(n, "scale", path);
            const FieldPtr child = build(field(n, "child", path), path + "/child");
            return transform(child, makeTransform(vec(n, "translate", path, Vec3d(0)),
                                                  vec(n, "rotate", path, Vec3d(0)), scale));
        }
        if (type == "warp") {
            allow(n, path, {"amplitude", "frequency", "octaves", "seed", "lacunarity", "gain",
                            "child"});
            const FieldPtr child = build(field(n, "child", path), path + "/child");
            return warp(child, noiseDisplacement(num(n, "amplitude", path),
                                                 num(n, "frequency", path, 1.0),
                                                 integer(n, "octaves", path, 3), seed(n, path),
                                                 num(n, "lacunarity", path, 2.0),
                                                 num(n, "gain", path, 0.5)));
        }
        if (auto hf = buildHeightfield(type, n, path)) {
            HeightfieldSettings hs;
            hs.baseDepth = hf->baseDepth;
            return heightfieldField(hf->heightfield, hs);
        }
        bad(path + "/type", "unknown type '" + type + "'");
    }

public:
    /// The heightfield of a heightfield node (nullopt for other types).
    std::optional<HeightfieldNode> buildHeightfield(const std::string& type, const json& n,
                                                    const std::string& path)
    {
        if (type == "heightfield") {
            allow(n, path, {"file", "cell_size", "height_scale", "base_depth"});
            const json& f = field(n, "file", path);
            if (!f.is_string()) bad(path + "/file", "expected a path string");
            std::string file = f.get<std::string>();
            if (!file.empty() && file[0] != '/') file = mCtx.baseDir + "/" + file;
            return HeightfieldNode{std::make_shared<Heightfield>(loadHeightfield(
                                       file, num(n, "cell_size", path, 1.0),
                                       num(n, "height_scale", path, 1.0))),
                                   num(n, "base_depth", path, 1.0)};
        }
        if (type == "noise_terrain") {
            allow(n, path, {"samples", "cell_size", "amplitude", "frequency", "octaves", "seed",
                            "base_depth", "lacunarity", "gain"});
            const auto samples = sampleCount(n, path);
            noise::Fbm fbm;
            fbm.frequency = num(n, "frequency", path, 0.1);
            fbm.octaves = integer(n, "octaves", path, 5);
            fbm.lacunarity = num(n, "lacunarity", path, 2.0);
            fbm.gain = num(n, "gain", path, 0.5);
            return HeightfieldNode{std::make_shared<Heightfield>(noiseHeightfield(
                                       samples[0], samples[1], num(n, "cell_size", path, 1.0),
                                       num(n, "amplitude", path, 1.0), fbm, seed(n, path))),
                                   num(n, "base_depth", path, 1.0)};
        }
        if (type == "sea_cliff") {
            allow(n, path, {"samples", "cell_size", "height", "floor", "coast", "width",
                            "waviness", "coast_frequency", "roughness", "roughness_frequency",
                            "seed", "base_depth"});
            SeaCliff c;
            if (n.contains("samples")) {
                const auto samples = sampleCount(n, path);
                c.nx = samples[0];
                c.ny = samples[1];
            }
            c.cellSize = num(n, "cell_size", path, c.cellSize);
            c.height = num(n, "height", path, c.height);
            c.floor = num(n, "floor", path, c.floor);
            c.coast = num(n, "coast", path, 0.5 * (c.nx - 1) * c.cellSize);
            c.width = num(n, "width", path, c.width);
            c.waviness = num(n, "waviness", path, c.waviness);
            c.coastFrequency = num(n, "coast_frequency", path, c.coastFrequency);
            c.roughness = num(n, "roughness", path, c.roughness);
            c.roughnessFrequency = num(n, "roughness_frequency", path, c.roughnessFrequency);
            c.seed = seed(n, path);
            return HeightfieldNode{std::make_shared<Heightfield>(seaCliffHeightfield(c)),
                                   num(n, "base_depth", path, 1.0)};
        }
        return std::nullopt;
    }

private:
    static std::array<int, 2> sampleCount(const json& n, const std::string& path)
    {
        const json& s = field(n, "samples", path);
        auto fits = [](const json& v) {
            return v.is_number_integer() && v.get<int64_t>() >= 0 && v.get<int64_t>() <= INT32_MAX;
        };
        if (!s.is_array() || s.size() != 2 || !fits(s[0]) || !fits(s[1])) {
            bad(path + "/samples", "expected [nx, ny] integers from 0 to 2147483647");
        }
        return {s[0].get<int>(), s[1].get<int>()};
    }

    /// An integer member, default @a def; its range is the consumer's check (a double past an
    /// int's range was an undefined conversion: fuzz_json's octaves of 8.9e116).
    static int integer(const json& n, const char* key, const std::string& path, int def)
    {
        const double v = num(n, key, path, double(def));
        if (!(v >= double(INT32_MIN) && v <= double(INT32_MAX)) || v != std::floor(v)) {
            bad(path + "/" + key, "expected an integer (got " + json(v).dump() + ")");
        }
        return int(v);
    }

    [[noreturn]] static void bad(const std::string& path, const std::string& what)
    {
        fail<ValueError>("expression: at ", path.empty() ? "/" : path, ": ", what);
    }

    static void allow(const json& n, const std::string& path, std::set<std::string> keys)
    {
        keys.insert("type");
        keys.insert("id");
        for (auto it = n.begin(); it != n.end(); ++it) {
            if (!keys.count(it.key())) bad(path, "unknown key '" + it.key() + "'");
        }
    }

    static const json& field(const json& n, const char* key, const std::string& path)
    {
        if (!n.contains(key)) bad(path, std::string("missing \"") + key + "\"");
        return n[key];
    }

    static double num(const json& n, const char* key, const std::string& path)
    {
        const json& v = field(n, key, path);
        if (!v.is_number()) bad(path + "/" + key, "expected a number");
        return v.get<double>();
    }
    static double num(const json& n, const char* key, const std::string& path, double def)
    {
        return n.contains(key) ? num(n, key, path) : def;
    }

    static Vec3d vec(const json& n, const char* key, const std::string& path)
    {
        const json& v = field(n, key, path);
        if (!v.is_array() || v.size() != 3 || !v[0].is_number() || !v[1].is_number() ||
            !v[2].is_number()) {
            bad(path + "/" + key, "expected [x, y, z]");
        }
        return Vec3d(v[0].get<double>(), v[1].get<double>(), v[2].get<double>());
    }
    static Vec3d vec(const json& n, const char* key, const std::string& path, const Vec3d& def)
    {
        return n.contains(key) ? vec(n, key, path) : def;
    }

    uint64_t seed(const json& n, const std::string& path) const
    {
        if (!n.contains("seed")) return mCtx.seed;
        const json& v = n["seed"];
        if (!v.is_number_integer() || v.get<int64_t>() < 0) bad(path + "/seed", "expected an integer >= 0");
        return v.get<uint64_t>();
    }

    const ExpressionContext& mCtx;
};

} // namespace

FieldPtr fieldFromJson(const json& node, const ExpressionContext& ctx)
{
    return Builder(ctx).build(node, "");
}

std::optional<HeightfieldNode> heightfieldFromJson(const json& node, const ExpressionContext& ctx)
{
    if (!node.is_object() || !node.contains("type") || !node["type"].is_string()) return std::nullopt;
    Builder b(ctx);
    try {
        return b.buildHeightfield(node["type"].get<std::string>(), node, "");
    } catch (const ValueError& e) {
        const std::string msg = e.what();
        if (msg.rfind("expression", 0) == 0) throw;
        fail<ValueError>("expression: at /: ", msg);
    }
}

FieldPtr fieldFromJsonText(const std::string& text, const ExpressionContext& ctx)
{
    return fieldFromJson(parseJson(text, "expression"), ctx);
}

} // namespace rockvdb
