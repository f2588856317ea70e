// SPDX-License-Identifier: Apache-2.0
#include "Schema.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/Expression.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace rockvdb {

using nlohmann::json;

namespace {

std::string number(double v)
{
    // whole numbers as integers (an id's limit 16777215, not 1.67772e+07)
    if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string((long long)v);
    std::ostringstream os;
    os << v;
    return os.str();
}

std::string typeWord(const ParamInfo& info)
{
    switch (info.type) {
    case ParamType::Bool: return "true or false";
    case ParamType::Int: return "an integer";
    case ParamType::Real: return "a number";
    case ParamType::Text: return "a string";
    case ParamType::Ints: return "a list of " + std::to_string(info.count) + " integers";
    case ParamType::Reals: return "a list of " + std::to_string(info.count) + " numbers";
    case ParamType::Json: return "a JSON object or a file path";
    }
    return "a value";
}

const char* typeName(ParamType t)
{
    switch (t) {
    case ParamType::Bool: return "bool";
    case ParamType::Int: return "int";
    case ParamType::Real: return "float";
    case ParamType::Text: return "str";
    case ParamType::Ints: return "ints";
    case ParamType::Reals: return "floats";
    case ParamType::Json: return "json";
    }
    return "";
}

size_t editDistance(const std::string& a, const std::string& b)
{
    std::vector<size_t> row(b.size() + 1);
    for (size_t k = 0; k <= b.size(); ++k) row[k] = k;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diag = row[0];
        row[0] = i;
        for (size_t k = 1; k <= b.size(); ++k) {
            const size_t up = row[k];
            const bool same = a[i - 1] == b[k - 1] || (a[i - 1] == '_' && b[k - 1] == '-');
            row[k] = std::min({row[k] + 1, row[k - 1] + 1, diag + (same ? 0 : 1)});
            diag = up;
        }
    }
    return row[b.size()];
}

} // namespace

bool Range::contains(double v) const
{
    if (std::isnan(v)) return false;
    if (minOpen ? !(v > min) : !(v >= min)) return false;
    if (maxOpen ? !(v < max) : !(v <= max)) return false;
    return true;
}

std::string Range::text() const
{
    const bool lo = std::isfinite(min), hi = std::isfinite(max);
    if (lo && hi) {
        return std::string("in ") + (minOpen ? "(" : "[") + number(min) + ", " + number(max) +
               (maxOpen ? ")" : "]");
    }
    if (lo) return std::string(minOpen ? "> " : ">= ") + number(min);
    if (hi) return std::string(maxOpen ? "< " : "<= ") + number(max);
    return "a finite number";
}

ParamInfo param(const char* name, ParamType type, const char* unit, json defaultValue,
                Range range, std::string help, size_t count)
{
    ParamInfo p;
    p.name = name;
    p.type = type;
    p.unit = unit;
    p.defaultValue = std::move(defaultValue);
    p.range = range;
    p.help = std::move(help);
    p.count = count;
    return p;
}

ParamInfo seedRow(std::string help)
{
    return param("seed", ParamType::Int, "", 0, Range::atLeast(0), std::move(help));
}

ParamInfo voxelSizeRow(json defaultValue, std::string help)
{
    ParamInfo row = param("voxel-size", ParamType::Real, "m", std::move(defaultValue),
                          Range::closed(1e-6, 1e6), std::move(help));
    row.resolution = true;
    return row;
}

ParamInfo halfWidthRow(json defaultValue, std::string help)
{
    ParamInfo row = param("half-width", ParamType::Real, "voxels", std::move(defaultValue),
                          Range::closed(1, 64), std::move(help));
    row.resolution = true;
    return row;
}

ParamInfo maxMemoryRow(std::string help)
{
    ParamInfo row = param("max-memory", ParamType::Real, "GB", 0.0, Range::atLeast(0),
                          std::move(help));
    row.resolution = true;
    return row;
}

std::array<ParamInfo, 5> warpRows(double amplitude, double sharpness, std::string sharpnessHelp)
{
    // A derived amplitude's default (-1) lies outside the range: coerce() takes a derived
    // row's default as "derive".
    std::array<ParamInfo, 5> rows = {param("warp-amplitude", ParamType::Real, "m", amplitude,
                  Range::closed(0, 1e3),
                  "Warp: largest displacement of the surface (0 = off)"),
            param("warp-relief", ParamType::Text, "", "turbulence", Range::any(),
                  "Warp relief: 'turbulence' or an EXR / 16-bit PNG image (tiled; bright = bump)"),
            param("warp-scale", ParamType::Real, "m", 1.5, Range::openClosed(0, 1e4),
                  "Warp: turbulence wavelength, or world size of one image tile"),
            param("warp-octaves", ParamType::Int, "", 4, Range::closed(1, 12),
                  "Warp: turbulence octaves"),
            param("warp-sharpness", ParamType::Real, "", sharpness, Range::closed(1, 64),
                  std::move(sharpnessHelp))};
    rows[1].file = true; // an image
    return rows;
}

json jsonOrFile(const json& value)
{
    return value.is_string() ? readJsonFile(value.get<std::string>()) : value;
}

std::string ParamInfo::pythonName() const
{
    std::string s = name;
    std::replace(s.begin(), s.end(), '-', '_');
    return s;
}

std::string closestName(const std::string& key, const std::vector<std::string>& names)
{
    std::string best;
    size_t bestD = size_t(-1);
    for (const auto& n : names) {
        const size_t d = editDistance(key, n);
        if (d < bestD) {
            bestD = d;
            best = n;
        }
    }
    return bestD <= std::max<size_t>(2, key.size() / 3) ? best : std::string();
}

void requireKnownKeys(const json& j, const std::vector<std::string>& keys, const std::string& op,
                      const std::string& where)
{
    if (!j.is_object()) fail<ValueError>(op, ": ", where, " must be an object");
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (std::find(keys.begin(), keys.end(), it.key()) != keys.end()) continue;
        std::string list;
        for (const auto& k : keys) list += (list.empty() ? "" : ", ") + k;
        const std::string best = closestName(it.key(), keys);
        fail<ValueError>(op, ": ", where, ": unknown key '", it.key(), "' (keys: ", list,
                         best.empty() ? std::string() : "; did you mean '" + best + "'?", ")");
    }
}

const ParamInfo* SchemaBase::find(const std::string& name) const
{
    for (const auto& p : mInfo) {
        if (p.name == name) return &p;
    }
    return nullptr;
}

namespace {

/// Row @a name of @a rows (a table being built), else logic_error naming @a op and @a why.
ParamInfo& rowNamed(std::vector<ParamInfo>& rows, const std::string& name, const std::string& op,
                    const char* why)
{
    auto it = std::find_if(rows.begin(), rows.end(), [&](const ParamInfo& p) { return p.name == name; });
    if (it == rows.end()) throw std::logic_error(op + ": no row '" + name + "' to " + why);
    return *it;
}

} // namespace

SchemaBase& SchemaBase::group(const std::string& group, const std::vector<std::string>& names)
{
    for (const auto& name : names) rowNamed(mInfo, name, mOp, "group").group = group;
    return *this;
}

SchemaBase& SchemaBase::files(const std::vector<std::string>& names)
{
    for (const auto& name : names) rowNamed(mInfo, name, mOp, "mark as a file").file = true;
    return *this;
}

std::string ParamInfo::groupName() const
{
    if (!group.empty()) return group;
    return resolution ? "Resolution" : "Shape";
}

// The preview rule's numbers (measured on the 2-core machine, issue 55, bench/blender.py): the
// 20 m block tile at its defaults in 1.8 s with 251 k vertices (5.3 M at Final); a 40 m
// landscape amplified at 128 voxels across kept 1.8 k vertices and lost its blocks, hence the
// cap at 3 final voxels (its blocks' ~1 m faces keep 7+ voxels).
const double kPreviewVoxelsAcross = 128.0;
const double kPreviewCoarsest = 3.0;
const double kPreviewAdaptivity = 0.5;

double previewVoxelSize(double finalVoxel, double extent)
{
    require(std::isfinite(finalVoxel) && finalVoxel > 0, "preview", "voxel size", "> 0", finalVoxel);
    require(std::isfinite(extent) && extent >= 0, "preview", "extent", ">= 0", extent);
    return std::min(kPreviewCoarsest * finalVoxel, std::max(finalVoxel, extent / kPreviewVoxelsAcross));
}

json SchemaBase::coerce(const ParamInfo& info, const json& v) const
{
    auto wrongType = [&]() {
        fail<ParamTypeError>(mOp, ": ", info.name, " must be ", typeWord(info), " (got ",
                             jsonText(v), ")");
    };
    auto number = [&](const json& x, bool integer) -> json {
        if (!x.is_number() || x.is_boolean()) wrongType();
        const double d = x.get<double>();
        if (integer && !(x.is_number_integer() || (std::isfinite(d) && d == std::floor(d)))) wrongType();
        // A derived row's default stands for its rule's value, outside the row's range.
        const bool derive = !info.derived.empty() && info.defaultValue.is_number() &&
                            d == info.defaultValue.get<double>();
        if (!derive && (!info.range.contains(d) || !std::isfinite(d))) {
            // A NaN dumps as JSON null: say what it is.
            fail<ValueError>(mOp, ": ", info.name, " must be ", info.range.text(), " (got ",
                             std::isnan(d) ? std::string("nan") : jsonText(x), ")");
        }
        if (!integer) return d;
        if (x.is_number_unsigned()) return x.get<uint64_t>();
        return x.is_number_integer() ? x.get<int64_t>() : int64_t(d);
    };
    if (v.is_null() && info.defaultValue.is_null()) return v; // optional, unset
    switch (info.type) {
    case ParamType::Bool:
        if (!v.is_boolean()) wrongType();
        return v;
    case ParamType::Int: return number(v, true);
    case ParamType::Real: return number(v, false);
    case ParamType::Text: {
        if (!v.is_string()) wrongType();
        const std::string s = v.get<std::string>();
        if (!info.choices.empty() &&
            std::find(info.choices.begin(), info.choices.end(), s) == info.choices.end()) {
            std::string list;
            for (const auto& c : info.choices) list += (list.empty() ? "" : ", ") + c;
            fail<ValueError>(mOp, ": ", info.name, " must be one of ", list, " (got '", s, "')");
        }
        return v;
    }
    case ParamType::Json:
        if (!v.is_string() && !v.is_object() && !v.is_array()) wrongType();
        return v;
    case ParamType::Ints:
    case ParamType::Reals: {
        if (!v.is_array() || v.size() != info.count) wrongType();
        json out = json::array();
        for (const auto& x : v) out.push_back(number(x, info.type == ParamType::Ints));
        return out;
    }
    }
    return v;
}

json SchemaBase::resolve(const json& j) const
{
    if (!j.is_object()) fail<ValueError>(mOp, ": parameters must be a JSON object (got ", jsonText(j), ")");
    std::vector<std::string> names;
    for (const auto& p : mInfo) names.push_back(p.name);
    for (auto it = j.begin(); it != j.end(); ++it) {
        if (find(it.key())) continue;
        const std::string best = closestName(it.key(), names);
        fail<ValueError>(mOp, ": unknown parameter '", it.key(), "'",
                         best.empty() ? std::string() : " (did you mean '" + best + "'?)");
    }
    json out = json::object();
    for (const auto& p : mInfo) {
        const auto it = j.find(p.name);
        out[p.name] = coerce(p, it == j.end() ? p.defaultValue : *it);
    }
    return out;
}

json SchemaBase::describe() const
{
    json rows = json::array();
    for (const auto& p : mInfo) {
        json range = nullptr;
        if (std::isfinite(p.range.min) || std::isfinite(p.range.max)) range = p.range.text();
        rows.push_back({{"name", p.name}, {"python", p.pythonName()}, {"type", typeName(p.type)},
                        {"unit", p.unit}, {"default", p.defaultValue}, {"count", p.count},
                        {"range", range}, {"choices", p.choices}, {"help", p.help},
                        {"derived", p.derived.empty() ? json() : json(p.derived)},
                        // The range as numbers (null: unbounded), for front-ends that set
                        // limits on a widget (the Blender add-on); "range" is its text.
                        {"min", std::isfinite(p.range.min) ? json(p.range.min) : json()},
                        {"max", std::isfinite(p.range.max) ? json(p.range.max) : json()},
                        {"min_open", p.range.minOpen}, {"max_open", p.range.maxOpen},
                        {"resolution", p.resolution}, {"group", p.groupName()},
                        {"file", p.file || p.type == ParamType::Json}});
    }
    return {{"op", mOp}, {"summary", mSummary}, {"params", rows}};
}

} // namespace rockvdb
