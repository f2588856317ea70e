// SPDX-License-Identifier: Apache-2.0
// rockvdb — Schema: one table per stage's parameters, the single truth behind every interface.
//
// Each row names a parameter once: its name, type, unit, default, range and help, and the
// Params member it sets. From the table come
//   - the CLI options and --help            (vdbtools/Cli: Tool::addParams),
//   - JSON: --params files and provenance   (fromJson / toJson),
//   - the Python keyword arguments, their defaults and docstrings (describe(), read by
//     python/rockvdb),
//   - validation: one message naming op, parameter, range and value.
// A default therefore exists in exactly one place, and the CLI, Python and a file's own
// rockvdb:params give the same Params, hence the same grids.
//
// Names are the CLI's ("cube-size"); JSON keys are the same; Python spells them with
// underscores ("cube_size"). Unknown keys are errors that suggest the closest name.
#pragma once

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Field.h>

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

namespace rockvdb {

/// A parameter value of the wrong type (a string where a number belongs). A ValueError for
/// the CLI (exit 2); Python raises an exception that is both TypeError and ValueError.
class ParamTypeError : public ValueError
{
public:
    using ValueError::ValueError;
};

/// Json: a JSON object or array given inline, or the path of a file holding it (the CLI
/// gives paths; --params, provenance and Python may give either).
enum class ParamType { Bool, Int, Real, Text, Ints, Reals, Json };

/// Allowed values of a number (each value of a list): [min, max], ends open or closed.
struct Range
{
    double min = -std::numeric_limits<double>::infinity();
    double max = std::numeric_limits<double>::infinity();
    bool minOpen = false, maxOpen = false;

    static Range any() { return {}; }
    static Range atLeast(double v) { return {v, std::numeric_limits<double>::infinity(), false, false}; }
    static Range above(double v) { return {v, std::numeric_limits<double>::infinity(), true, false}; }
    static Range closed(double a, double b) { return {a, b, false, false}; }
    static Range open(double a, double b) { return {a, b, true, true}; }            ///< (a, b)
    static Range halfOpen(double a, double b) { return {a, b, false, true}; }  ///< [a, b)
    static Range openClosed(double a, double b) { return {a, b, true, false}; } ///< (a, b]

    bool contains(double v) const;
    /// "in [1, 64]", "> 0", ">= 0", "any number"
    std::string text() const;
};

/// One row of a stage's table.
struct ParamInfo
{
    std::string name;               ///< CLI option and JSON key ("cube-size")
    ParamType type = ParamType::Real;
    std::string unit;               ///< "m", "cells", "voxels", "degrees" or "" (none)
    nlohmann::json defaultValue;    ///< null: unset by default (the help says what that means)
    size_t count = 1;               ///< values in an Ints / Reals list
    Range range;
    std::vector<std::string> choices; ///< Text: the allowed values (empty = any text)
    std::string help;
    /// A derived default: what the row's default stands for ("0.034 x tile-size"), computed
    /// by the table's rule from other rows (Schema::derived). Empty: the default is itself.
    std::string derived;
    /// The row only sets how finely or where the same shape is sampled (voxel size, band,
    /// region, chunks, memory limit), never the look: the CLI lists these rows apart, so an
    /// artist can tune the look at a coarse voxel and bake it fine.
    bool resolution = false;
    /// Where a front-end shows the row (the Blender add-on's sub-panels): "Shape", "Surface",
    /// "Placement", "Input" or "Resolution". Empty: "Resolution" for a resolution row, else
    /// "Shape" (groupName()).
    std::string group;
    std::string groupName() const;
    /// The value may name a file (an image, a JSON file, a tile set): front-ends offer a file
    /// browser. Json rows always may.
    bool file = false;
    /// The Python keyword: the name with '_' for '-'.
    std::string pythonName() const;
};

/// @brief One row: the way every table spells its rows.
ParamInfo param(const char* name, ParamType type, const char* unit, nlohmann::json defaultValue,
                Range range, std::string help, size_t count = 1);

/// Rows several stages share, spelt once: name, type, unit and range here; the stage gives
/// the default (and, where its meaning differs, the help).
ParamInfo seedRow(std::string help = "Random seed (same seed, same bits)");
ParamInfo voxelSizeRow(nlohmann::json defaultValue, std::string help = "Voxel edge length");
ParamInfo halfWidthRow(nlohmann::json defaultValue, std::string help = "Narrow-band half width");
ParamInfo maxMemoryRow(std::string help = "Refuse work estimated above this (0 = 75% of RAM)");

/// @brief Preview quality: the rule that makes a quick look of any stage (the Blender add-on's
/// default quality; Final is the tables' defaults, the CLI's). The same parameters baked at
/// a coarser voxel: kPreviewVoxelsAcross voxels across the result's largest extent @a extent
/// (m), never finer than @a finalVoxel (m) nor coarser than kPreviewCoarsest times it, and
/// meshed with kPreviewAdaptivity. Only resolution changes, never the look: the same blocks,
/// the same rocks, and features of a few final voxels still resolved.
double previewVoxelSize(double finalVoxel, double extent);
extern const double kPreviewVoxelsAcross;
extern const double kPreviewCoarsest;
extern const double kPreviewAdaptivity;
/// The gradient warp's rows (implicit blocks §4.2), in order: warp-amplitude, warp-relief,
/// warp-scale, warp-octaves, warp-sharpness. Stages differ in two defaults: the amplitude and
/// the exponent p (whose help says why).
std::array<ParamInfo, 5> warpRows(double amplitude, double sharpness, std::string sharpnessHelp);

/// @brief A Json row's value as JSON: a string is a file path, read; anything else is itself.
nlohmann::json jsonOrFile(const nlohmann::json& value);

/// @brief The name in @a names closest to @a key (edit distance, '_' counts as '-'), or "" when
/// none is close enough to suggest.
std::string closestName(const std::string& key, const std::vector<std::string>& names);

/// @brief Check that @a j is an object whose keys are all among @a keys: a JSON input's own
/// table (every reader of user JSON calls it, so a misspelt key is an error, not ignored).
/// @throw ValueError "<op>: <where>: unknown key 'k' (keys: a, b; did you mean 'x'?)", or
/// "<op>: <where> must be an object".
void requireKnownKeys(const nlohmann::json& j, const std::vector<std::string>& keys, const std::string& op,
                      const std::string& where);

/// The table without its binding to a Params type: what interfaces read.
class SchemaBase
{
public:
    SchemaBase(std::string op, std::string summary) : mOp(std::move(op)), mSummary(std::move(summary)) {}
    virtual ~SchemaBase() = default;

    const std::string& op() const { return mOp; }
    const std::string& summary() const { return mSummary; }
    const std::vector<ParamInfo>& params() const { return mInfo; }
    const ParamInfo* find(const std::string& name) const;

    /// @brief Put the rows @a names in front-end group @a group (ParamInfo::group).
    /// @throw std::logic_error for a name the table does not have.
    SchemaBase& group(const std::string& group, const std::vector<std::string>& names);
    /// @brief Mark the rows @a names as naming files (ParamInfo::file).
    SchemaBase& files(const std::vector<std::string>& names);

    /// @brief The complete parameters @a j stands for, canonical, with every derived default
    /// filled by its rule (what a front-end shows beside an Auto box). Without derived rows:
    /// resolve(@a j).
    /// @throw ValueError as fromJson.
    virtual nlohmann::json derivedValues(const nlohmann::json& j) const { return resolve(j); }

    /// @brief Check one JSON value against its row and return it in canonical form (ints for
    /// Int, doubles for Real, lists of the right length).
    /// @throw ParamTypeError for a wrong type, ValueError for a value out of range.
    nlohmann::json coerce(const ParamInfo& info, const nlohmann::json& value) const;

    /// @brief Defaults merged with @a j, every key checked and coerced.
    /// @throw ValueError for an unknown key (suggesting the closest name) or a bad value.
    nlohmann::json resolve(const nlohmann::json& j) const;

    /// @brief The table as JSON: [{name, python, type, unit, default, count, range, choices, help,
    /// derived, min, max, min_open, max_open, resolution}]: Python, the Blender add-on, docs.
    nlohmann::json describe() const;

protected:
    std::string mOp, mSummary;
    std::vector<ParamInfo> mInfo;
};

namespace schema_detail {
template<typename T> struct Conv
{
    static nlohmann::json get(const T& v) { return v; }
    static void set(T& m, const nlohmann::json& j) { m = j.get<T>(); }
};
template<typename T> struct Conv<std::optional<T>>
{
    static nlohmann::json get(const std::optional<T>& v)
    {
        return v ? Conv<T>::get(*v) : nlohmann::json(nullptr);
    }
    static void set(std::optional<T>& m, const nlohmann::json& j)
    {
        if (j.is_null()) {
            m.reset();
        } else {
            T v{};
            Conv<T>::set(v, j);
            m = v;
        }
    }
};
template<> struct Conv<Vec3d>
{
    static nlohmann::json get(const Vec3d& v) { return {v[0], v[1], v[2]}; }
    static void set(Vec3d& m, const nlohmann::json& j)
    {
        m = Vec3d(j.at(0).get<double>(), j.at(1).get<double>(), j.at(2).get<double>());
    }
};
} // namespace schema_detail

template<typename P>
class Schema : public SchemaBase
{
public:
    using Getter = std::function<nlohmann::json(const P&)>;
    using Setter = std::function<void(P&, const nlohmann::json&)>;
    using Rule = std::function<void(const P&)>;

    using SchemaBase::SchemaBase;

    /// @brief A row with its own conversion (enums, members split in two, ...).
    Schema& add(ParamInfo info, Getter get, Setter set)
    {
        mInfo.push_back(std::move(info));
        mGet.push_back(std::move(get));
        mSet.push_back(std::move(set));
        return *this;
    }

    /// @brief A row bound to a member (numbers, bools, strings, std::array, Vec3d).
    template<typename T>
    Schema& member(ParamInfo info, T P::*m)
    {
        return add(std::move(info),
                   [m](const P& p) { return schema_detail::Conv<T>::get(p.*m); },
                   [m](P& p, const nlohmann::json& j) { schema_detail::Conv<T>::set(p.*m, j); });
    }

    /// @brief A derived default: when row @a name holds its default, @a fill sets it from other
    /// rows (the tile size, the block type, ...). @a text says how ("0.034 x tile-size"); the
    /// help, --help and Python docstrings show it. Rules and derive() see filled values.
    Schema& derived(const std::string& name, std::string text, std::function<void(P&)> fill)
    {
        for (size_t i = 0; i < mInfo.size(); ++i) {
            if (mInfo[i].name != name) continue;
            mInfo[i].derived = text;
            const nlohmann::json& d = mInfo[i].defaultValue;
            const std::string unset = d.is_null() ? std::string("unset")
                : d.is_number() && d.get<double>() == double(int64_t(d.get<double>()))
                ? std::to_string(int64_t(d.get<double>())) : d.dump();
            mInfo[i].help += " (" + unset + " = " + text + ")";
            mDerive.push_back({i, std::move(fill)});
            return *this;
        }
        throw std::logic_error(mOp + ": no row '" + name + "' to derive");
    }

    /// @brief @a p with every row still at its default filled by its derived rule, in the
    /// order the rules were added (a rule may read an earlier one's value).
    P derive(P p) const
    {
        for (const auto& [i, fill] : mDerive) {
            if (mGet[i](p) == mInfo[i].defaultValue) fill(p);
        }
        return p;
    }

    /// @brief A rule between parameters (checked after every row, on derive()'s values):
    /// throws ValueError.
    Schema& rule(Rule r)
    {
        mRules.push_back(std::move(r));
        return *this;
    }

    /// @brief Every member set from the table's defaults.
    void reset(P& p) const
    {
        for (size_t i = 0; i < mInfo.size(); ++i) mSet[i](p, mInfo[i].defaultValue);
    }

    /// @brief Parameters from JSON: defaults for missing keys, unknown keys and bad values
    /// rejected with one message naming the op and the parameter.
    P fromJson(const nlohmann::json& j) const
    {
        const nlohmann::json all = resolve(j);
        P p;
        for (size_t i = 0; i < mInfo.size(); ++i) mSet[i](p, all.at(mInfo[i].name));
        checkRules(p);
        return p;
    }

    /// @brief Every parameter, canonical (what provenance records and --params replays).
    nlohmann::json toJson(const P& p) const
    {
        nlohmann::json j = nlohmann::json::object();
        for (size_t i = 0; i < mInfo.size(); ++i) j[mInfo[i].name] = mGet[i](p);
        return j;
    }

    nlohmann::json derivedValues(const nlohmann::json& j) const override
    {
        return toJson(derive(fromJson(j)));
    }

    /// @brief Ranges and rules of parameters set from C++ (ValueError naming the parameter).
    void validate(const P& p) const
    {
        for (size_t i = 0; i < mInfo.size(); ++i) coerce(mInfo[i], mGet[i](p));
        checkRules(p);
    }

private:
    void checkRules(const P& p) const
    {
        if (mRules.empty()) return;
        const P filled = mDerive.empty() ? p : derive(p);
        for (const auto& r : mRules) r(filled);
    }

    std::vector<Getter> mGet;
    std::vector<Setter> mSet;
    std::vector<Rule> mRules;
    std::vector<std::pair<size_t, std::function<void(P&)>>> mDerive;
};

} // namespace rockvdb
