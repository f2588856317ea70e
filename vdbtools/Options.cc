// SPDX-License-Identifier: Apache-2.0
#include "Cli.h"
#include "CliDetail.h"

#include <rockvdb/core/Error.h>
#include <rockvdb/core/Json.h>

#include <algorithm>
#include <iterator>
#include <memory>

namespace rockvdb {
namespace cli {

using nlohmann::json;

std::string cliText(const nlohmann::json& v)
{
    if (v.is_string()) return v.get<std::string>();
    if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
    if (v.is_array()) {
        std::string s;
        for (const auto& x : v) s += (s.empty() ? "" : ",") + cliText(x);
        return s;
    }
    return jsonText(v);
}

// A command-line word as the JSON value its row expects; what does not parse stays a string
// and the table's check reports it ("n must be an integer (got "abc")").
nlohmann::json fromText(ParamType type, const std::string& text)
{
    const bool integer = type == ParamType::Int || type == ParamType::Ints;
    if (type == ParamType::Text || type == ParamType::Json) return text;
    try {
        size_t pos = 0;
        if (integer) {
            if (!text.empty() && text[0] != '-') {
                const unsigned long long u = std::stoull(text, &pos);
                if (pos == text.size()) return u;
            } else {
                const long long i = std::stoll(text, &pos);
                if (pos == text.size()) return i;
            }
        }
        const double d = std::stod(text, &pos);
        if (pos == text.size()) return d;
    } catch (...) {
    }
    return text;
}

namespace {

// JSON for CLI11: {"option-name": value, "subcommand": {...}}; arrays give multi-values.
class ConfigJson : public CLI::Config
{
public:
    explicit ConfigJson(const CLI::App* app) : mApp(app) {}

    std::string to_config(const CLI::App* app, bool defaultAlso, bool, std::string) const override
    {
        return toJson(app, defaultAlso).dump(2);
    }

    std::vector<CLI::ConfigItem> from_config(std::istream& input) const override
    {
        json j;
        try {
            const std::string text((std::istreambuf_iterator<char>(input)), std::istreambuf_iterator<char>());
            j = parseJson(text, "--params");
        } catch (const ValueError& e) {
            throw CLI::ConversionError(e.what());
        }
        if (!j.is_object()) throw CLI::ConversionError("--params JSON must be an object");
        if (mApp) checkKeys(mApp, j, "");
        std::vector<CLI::ConfigItem> items;
        collect(mApp, j, {}, items);
        return items;
    }

    static json toJson(const CLI::App* app, bool defaultAlso)
    {
        json j = json::object();
        for (const CLI::Option* opt : app->get_options()) {
            std::string name;
            if (!opt->get_lnames().empty()) name = opt->get_lnames().front();
            else if (opt->get_positional()) name = opt->get_name(true);
            else continue;
            if (name == "help" || name == "version" || name == "params") continue;
            std::vector<std::string> values;
            if (opt->count() > 0) values = opt->results();
            else if (defaultAlso && !opt->get_default_str().empty()) {
                std::string d = opt->get_default_str();
                if (d.size() >= 2 && d.front() == '[' && d.back() == ']') d = d.substr(1, d.size() - 2);
                if (d.empty()) continue;
                values = CLI::detail::split(d, ',');
            } else if (defaultAlso && opt->get_type_size() == 0) {
                values = {"false"};
            } else continue;
            std::vector<json> typed;
            for (auto v : values) typed.push_back(typedValue(v));
            const bool multi = opt->get_expected_max() > 1 || typed.size() > 1;
            j[name] = multi ? json(typed) : (typed.empty() ? json(nullptr) : typed.front());
        }
        for (const CLI::App* sub : app->get_subcommands({})) {
            if (sub->count() > 0) j[sub->get_name()] = toJson(sub, defaultAlso);
        }
        return j;
    }

private:
    // Every key names an option (or a subcommand, whose object is checked the same way); a
    // misspelt one is an error suggesting the closest name, never silently ignored.
    static void checkKeys(const CLI::App* app, const json& j, const std::string& where)
    {
        std::vector<std::string> names;
        for (const CLI::Option* opt : app->get_options()) {
            for (const auto& n : opt->get_lnames()) names.push_back(n);
            for (const auto& n : opt->get_snames()) names.push_back(n);
            if (opt->get_positional()) names.push_back(opt->get_name(true));
        }
        std::vector<std::string> subs;
        for (const CLI::App* sub : app->get_subcommands({})) subs.push_back(sub->get_name());
        for (auto it = j.begin(); it != j.end(); ++it) {
            const std::string& key = it.key();
            if (it->is_object() && std::count(subs.begin(), subs.end(), key)) {
                checkKeys(app->get_subcommand(key), *it, where + key + ".");
                continue;
            }
            if (std::count(names.begin(), names.end(), key)) continue;
            // The inputs' own provenance that vdb_csg / vdb_merge record: replays skip it.
            if (where.empty() && key == "sources") continue;
            std::vector<std::string> all = names;
            all.insert(all.end(), subs.begin(), subs.end());
            const std::string best = closestName(key, all);
            std::string msg = "unknown --params key '" + where + key + "'";
            if (!best.empty()) msg += " (did you mean '" + where + best + "'?)";
            throw CLI::ConversionError(msg);
        }
    }

    const CLI::App* mApp = nullptr;

    static json typedValue(const std::string& v)
    {
        if (v == "true") return true;
        if (v == "false") return false;
        try {
            size_t pos = 0;
            const long long i = std::stoll(v, &pos);
            if (pos == v.size()) return i;
            const double d = std::stod(v, &pos);
            if (pos == v.size()) return d;
        } catch (...) {}
        return v;
    }

    static std::string str(const json& v)
    {
        if (v.is_string()) return v.get<std::string>();
        if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
        return jsonText(v);
    }

    static bool isSubcommand(const CLI::App* app, const std::string& name)
    {
        if (!app) return false;
        for (const CLI::App* sub : app->get_subcommands({})) {
            if (sub->get_name() == name) return true;
        }
        return false;
    }

    // An object names a subcommand (its options follow), or is the value of a JSON option
    // (a skeleton, a blend), passed on as its text.
    static void collect(const CLI::App* app, const json& j, std::vector<std::string> parents,
                        std::vector<CLI::ConfigItem>& items)
    {
        for (auto it = j.begin(); it != j.end(); ++it) {
            if (it->is_object() && isSubcommand(app, it.key())) {
                auto p = parents;
                p.push_back(it.key());
                // Mark the subcommand itself so CLI11 selects it.
                CLI::ConfigItem sub;
                sub.parents = parents;
                sub.name = it.key();
                sub.inputs = {"true"};
                items.push_back(sub);
                collect(app->get_subcommand(it.key()), *it, p, items);
                continue;
            }
            if (it->is_null()) continue; // unset (the table's null default), as in provenance
            CLI::ConfigItem item;
            item.parents = parents;
            item.name = it.key();
            // A list of objects (edits), or an empty list (no edits), is one JSON option's text.
            const bool nested = it->is_array() &&
                (it->empty() || std::any_of(it->begin(), it->end(), [](const json& v) { return v.is_structured(); }));
            if (it->is_object() || nested) item.inputs.push_back(it->dump()); // a JSON option
            else if (it->is_array()) for (const auto& v : *it) item.inputs.push_back(str(v));
            else item.inputs.push_back(str(*it));
            items.push_back(item);
        }
    }};

} // namespace

std::shared_ptr<CLI::Config> makeConfigJson(CLI::App* app) { return std::make_shared<ConfigJson>(app); }

json appToJson(const CLI::App* app) { return ConfigJson::toJson(app, true); }

namespace {
// The heading of the rows that only set the resolution (ParamInfo::resolution).
constexpr const char* kResolutionGroup =
    "Resolution and extent (the same shape at any value: tune the look at a coarser "
    "--voxel-size, then bake it fine; the stage's other parameters change the look)";
} // namespace

void Tool::addParams(CLI::App& where, const SchemaBase& schema)
{
    for (const ParamInfo& info : schema.params()) {
        std::string help = info.help;
        if (!info.unit.empty()) help += " (" + info.unit + ")";
        if (!info.choices.empty()) {
            std::string list;
            for (const auto& c : info.choices) list += (list.empty() ? "" : "|") + c;
            help += "; " + list;
        } else if (info.type != ParamType::Bool && info.type != ParamType::Text &&
                   info.type != ParamType::Json &&
                   (std::isfinite(info.range.min) || std::isfinite(info.range.max))) {
            help += "; " + info.range.text();
        }
        Bound b{&schema, &info, nullptr, std::make_shared<std::vector<std::string>>(),
                std::make_shared<bool>(false)};
        if (info.type == ParamType::Bool) {
            b.option = where.add_flag("--" + info.name + ",!--no-" + info.name, *b.flag, help);
        } else {
            b.option = where.add_option("--" + info.name, *b.values, help);
            if (info.count > 1) b.option->delimiter(',');
            b.option->expected(int(info.count));
            // A JSON option's value is one word, even '[...]' (CLI11 splits those otherwise).
            if (info.type == ParamType::Json) b.option->allow_extra_args(false);
            static const char* const names[] = {"BOOL", "INT", "FLOAT", "TEXT", "INT", "FLOAT", "FILE"};
            std::string type = names[int(info.type)];
            for (size_t k = 1; k < info.count; ++k) type += std::string(",") + names[int(info.type)];
            b.option->type_name(type);
        }
        // An unset (null) default shows nothing, not the storage's empty "[]".
        b.option->default_str(info.defaultValue.is_null() ? std::string()
                                                          : cliText(info.defaultValue));
        if (info.resolution) b.option->group(kResolutionGroup);
        mBound.push_back(b);
    }
}

nlohmann::json Tool::givenParams(const SchemaBase& schema) const
{
    nlohmann::json j = nlohmann::json::object();
    for (const Bound& b : mBound) {
        if (b.schema != &schema || b.option->count() == 0) continue;
        const ParamInfo& info = *b.info;
        if (info.type == ParamType::Bool) {
            j[info.name] = *b.flag;
        } else if (info.type == ParamType::Ints || info.type == ParamType::Reals) {
            nlohmann::json list = nlohmann::json::array();
            for (const auto& v : *b.values) list.push_back(fromText(info.type, v));
            j[info.name] = list;
        } else if (info.type == ParamType::Json) {
            const std::string& text = b.values->back();
            const bool inline_ = !text.empty() && (text[0] == '{' || text[0] == '[');
            j[info.name] = inline_ ? parseJson(text, "--" + info.name) : nlohmann::json(text);
        } else {
            j[info.name] = fromText(info.type, b.values->back());
        }
    }
    return j;
}

std::string Tool::paramsJson() const
{
    return jsonText(appToJson(&mApp));
}

} // namespace cli
} // namespace rockvdb
