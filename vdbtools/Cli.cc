#include "Cli.h"

#include <rockvdb/core/Json.h>
#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Chunks.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Expression.h>
#include <rockvdb/core/VdbIO.h>

#include <nlohmann/json.hpp>
#include <openvdb/Exceptions.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <filesystem>
#include <iterator>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <sys/time.h>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <unistd.h>

namespace rockvdb {
namespace cli {

using nlohmann::json;

namespace {

// Ctrl-C / SIGTERM: the flag every Task checks at a coarse grain. A phase that cannot check
// (an OpenVDB tool without an interrupter, a file being read) is covered by a watchdog: if
// the process is still running 0.8 s after the signal (or at a second signal) it removes the
// temporary files written and not renamed yet, says so and exits 130 at once. Only
// async-signal-safe calls here.
std::atomic<bool> gSigint{false};
char gInterruptLine[512] = "interrupted\n";
size_t gInterruptLength = 12;

void hardExit()
{
    removePendingTemps();
    ssize_t ignored = ::write(STDERR_FILENO, gInterruptLine, gInterruptLength);
    (void)ignored;
    ::_exit(130);
}

extern "C" void onAlarm(int) { hardExit(); }

extern "C" void onSigint(int)
{
    if (gSigint.exchange(true)) hardExit();
    itimerval t{};
    t.it_value.tv_usec = 800000;
    ::setitimer(ITIMER_REAL, &t, nullptr);
}

void cancelWatchdog()
{
    itimerval t{};
    ::setitimer(ITIMER_REAL, &t, nullptr);
}

bool sigintSeen() { return gSigint.load(); }

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

TaskBar::~TaskBar() { clear(); }

void TaskBar::clear()
{
    if (mShown) {
        std::fprintf(stderr, "\r\033[K");
        std::fflush(stderr);
    }
    mShown = false;
}

bool TaskBar::cancelled() { return gSigint.load(); }

void TaskBar::progress(const char* phase, double fraction)
{
    if (!mEnabled) return;
    static std::mutex m;
    std::lock_guard<std::mutex> lock(m);
    const int percent = std::clamp(int(fraction * 100.0), 0, 100);
    if (percent <= mLast) return; // only up, whatever order threads report in
    mLast = percent;
    mShown = true; // (a clear() in between: drawn again at the next percent)
    const int w = 30, filled = percent * w / 100;
    std::fprintf(stderr, "\r\033[K%s: %s [%.*s%*s] %3d%%", mTool.c_str(), phase, filled,
                 "##############################", w - filled, "", percent);
    std::fflush(stderr);
}

Tool::Tool(std::string name, std::string description)
    : mName(std::move(name)), mApp(std::move(description), mName)
{
    mApp.set_version_flag("--version", std::string(mName) + " (rockvdb) " + version());
    mApp.config_formatter(std::make_shared<ConfigJson>(&mApp));
    mApp.set_config("--params", "", "Read options from a JSON file {\"option-name\": value, "
                                    "\"subcommand\": {...}}; command-line values win");
    mApp.add_option("--threads", mThreads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024))->capture_default_str();
    mApp.add_flag("-q,--quiet", mQuiet, "No progress bar or statistics on stderr");
    mApp.get_formatter()->column_width(34);
    mApp.option_defaults()->always_capture_default();
    mApp.fallthrough(); // parent options may follow a subcommand
}

CLI::Option* Tool::addOutput(CLI::App& where, const std::string& help)
{
    mOutputOption = where.add_option("-o,--output", mOutput, help)->required();
    return mOutputOption;
}

namespace {
// The option group of addDistribution's options; distribute() finds them by it.
constexpr const char* kClusterGroup = "Chunked and cluster bakes";
} // namespace

void Tool::addDistribution(CLI::App& where)
{
    mDistributable = true;
    mDistributionApp = &where;
    if (mOutputOption) mOutputOption->required(false); // (--plan writes none; run() checks)
    const size_t before = where.get_options().size();
    where.add_flag("--plan", mPlan,
                   "Print the bake's plan as JSON on stdout (its whole index box, estimated "
                   "bytes, the split into chunks that --chunk-memory or --chunks gives) and bake "
                   "nothing");
    where.add_option("--local-workers", mLocalWorkers,
                     "Bake the chunks on a local Dask cluster of this many worker processes "
                     "(rockvdb.distributed), then merge them into -o")
        ->check(CLI::Range(1, 4096));
    where.add_option("--scheduler", mScheduler,
                     "Bake the chunks on the Dask cluster at this address (tcp://host:8786; "
                     "workers need the same rockvdb and shared paths), then merge into -o");
    where.add_option("--chunk-memory", mChunkMemoryGB,
                     "With --plan or a cluster and no --chunks: the fewest chunks whose estimated "
                     "peak memory fits this many GB each")
        ->check(CLI::NonNegativeNumber);
    where.add_option("--chunk-dir", mChunkDir,
                     "Folder for the chunk files and manifest.json of a cluster run [default: "
                     "OUTPUT.chunks]; a rerun reuses the chunks whose checksums match");
    where.add_flag("--keep-chunks", mKeepChunks,
                   "Keep the chunk folder after merging (vdb_merge --manifest merges it again; "
                   "DCCs may load the chunks one by one)");
    const auto options = where.get_options();
    for (size_t i = before; i < options.size(); ++i) options[i]->group(kClusterGroup);
}

int Tool::distribute(const std::vector<std::string>& words)
{
    // The stage's own arguments go to every chunk as given. The driver's options (the cluster
    // group, the chunk rows, -o) are taken out, in each spelling CLI11 accepts (--name value,
    // --name=value, -o value, -oVALUE), and passed to the driver by their long names.
    CLI::App& app = *mDistributionApp;
    std::map<std::string, const CLI::Option*> driver;
    auto spell = [&](const CLI::Option* o) {
        if (!o) return;
        for (const auto& l : o->get_lnames()) driver["--" + l] = o;
        for (const auto& s : o->get_snames()) driver["-" + s] = o;
    };
    for (const CLI::Option* o : app.get_options()) {
        if (o->get_group() == kClusterGroup) spell(o);
    }
    spell(mOutputOption);
    const CLI::Option* chunkRow = app.get_option_no_throw(std::string("--") + ChunkParams::kChunkRow);
    spell(chunkRow);
    spell(app.get_option_no_throw(std::string("--") + ChunkParams::kChunksRow));
    std::vector<std::pair<const CLI::Option*, std::string>> given;
    std::vector<std::string> rest;
    for (size_t i = 1; i < words.size(); ++i) {
        const std::string& w = words[i];
        std::string key = w, value;
        bool glued = false;
        if (w.rfind("--", 0) == 0 && w.find('=') != std::string::npos) {
            key = w.substr(0, w.find('='));
            value = w.substr(key.size() + 1);
            glued = true;
        } else if (w.size() > 2 && w[0] == '-' && w[1] != '-') {
            key = w.substr(0, 2);
            value = w.substr(2);
            glued = true;
        }
        const auto it = driver.find(key);
        if (it == driver.end()) {
            rest.push_back(w);
            continue;
        }
        if (it->second->get_expected_min() == 0) continue; // a flag: the driver has its member
        if (!glued) value = i + 1 < words.size() ? words[++i] : "";
        given.emplace_back(it->second, value);
    }
    auto isGiven = [&](const CLI::Option* o) {
        return std::any_of(given.begin(), given.end(), [&](const auto& g) { return g.first == o; });
    };
    if (mOutput.empty()) fail<ValueError>("--output is required");
    if (std::count(rest.begin(), rest.end(), "-")) {
        fail<ValueError>("a cluster run reads its inputs from files every worker can open, not stdin");
    }
    if (isGiven(chunkRow)) {
        fail<ValueError>("--chunk names one chunk of a farm job; a cluster run (--local-workers, "
                         "--scheduler) bakes them all");
    }
    char exe[4096];
    const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof exe - 1);
    if (n <= 0) fail<IoError>("cannot find this executable (/proc/self/exe)");
    exe[n] = 0;
    const std::string bin = std::string(exe).substr(0, std::string(exe).rfind('/'));
    // The rockvdb package beside the tools: the build tree's python/, an install prefix's
    // site folder; else wherever the interpreter finds it (the default prefix, /usr/local).
    for (const std::string dir : {bin + "/../python", bin + "/../" ROCKVDB_PYTHON_SITE}) {
        if (::access((dir + "/rockvdb/distributed.py").c_str(), R_OK) == 0) {
            const char* old = std::getenv("PYTHONPATH");
            const std::string path = old && *old ? dir + ":" + old : dir;
            ::setenv("PYTHONPATH", path.c_str(), 1);
            break;
        }
    }
    std::vector<std::string> argv = {ROCKVDB_PYTHON, "-m", "rockvdb.distributed", "--tool", exe,
                                     "--output", mOutput};
    for (const auto& [option, value] : given) {
        if (option != mOutputOption) argv.insert(argv.end(), {"--" + option->get_lnames().front(), value});
    }
    if (mKeepChunks) argv.push_back("--keep-chunks");
    if (mQuiet) argv.push_back("--quiet");
    argv.push_back("--");
    argv.insert(argv.end(), rest.begin(), rest.end());
    std::vector<char*> args;
    for (auto& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    std::fflush(stderr);
    ::execv(ROCKVDB_PYTHON, args.data());
    fail<IoError>("cannot run ", ROCKVDB_PYTHON, " for the distributed bake: ", std::strerror(errno));
}

void Tool::addSeed(CLI::App& where)
{
    where.add_option("--seed", mSeed, "Random seed (same seed, same bits)")->capture_default_str();
}

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

std::unique_ptr<TaskBar> Tool::taskBar() const
{
    return std::make_unique<TaskBar>(mName, !mQuiet && ::isatty(STDERR_FILENO));
}

std::string Tool::paramsJson() const
{
    return jsonText(ConfigJson::toJson(&mApp, true));
}

void Tool::addStats(CLI::App& where)
{
    where.add_option("--stats", mStatsPath, "Also write the run's statistics (counts, times, "
                                            "phases) as JSON to this file ('-' = stdout)");
}

void Tool::finish(const StageResult& result) const
{
    for (const auto& line : result.report) info(line);
    if (!mStatsPath.empty()) writeFileAtomic(mStatsPath, result.stats.dump(2) + "\n");
}

void Tool::info(const std::string& line) const
{
    if (!mQuiet) std::cerr << mName << ": " << line << "\n";
}

void distinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs)
{
    std::vector<std::pair<std::string, std::string>> seen; // (canonical path, option)
    for (const auto& [option, path] : outputs) {
        if (path.empty()) continue;
        std::string key = path;
        if (path != "-") {
            std::error_code ec;
            const auto c = std::filesystem::weakly_canonical(std::filesystem::absolute(path, ec), ec);
            if (!ec) key = c.string();
        }
        for (const auto& [other, name] : seen) {
            if (other == key) {
                fail<ValueError>(name, " and ", option, path == "-" ? " both write to stdout ('-')"
                                 : " name the same file '" + path + "'", "; give them different paths");
            }
        }
        seen.emplace_back(key, option);
    }
}

void refuseEmpty(const openvdb::GridBase& grid, const std::string& why)
{
    if (grid.activeVoxelCount() == 0) fail<ValueError>("the result is empty (no active voxels): ", why);
}

// (for messages that name an option: only when the tool has it)
static bool hasOption(const CLI::App& app, const std::string& name)
{
    if (app.get_option_no_throw(name)) return true;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
        if (sub->get_option_no_throw(name)) return true;
    }
    return false;
}

int Tool::run(int argc, char** argv, const std::function<void()>& body)
{
    auto error = [&](const std::string& msg, int code) {
        std::string one = msg;
        for (auto& c : one) if (c == '\n') c = ' ';
        std::cerr << mName << ": error: " << one << "\n";
        return code;
    };
    // A --params file names its subcommand ({"tiles": {...}}): when the command line names
    // none, take the file's, so a file's own rockvdb:params replays with just
    // `tool --params FILE -o OUT`.
    std::vector<std::string> words(argv, argv + argc);
    auto isSubcommand = [&](const std::string& w) {
        for (const CLI::App* sub : mApp.get_subcommands({})) {
            if (sub->get_name() == w) return true;
        }
        return false;
    };
    if (!mApp.get_subcommands({}).empty()) {
        bool named = false;
        std::string paramsFile;
        for (size_t i = 1; i < words.size(); ++i) {
            if (isSubcommand(words[i])) named = true;
            if (words[i] == "--params" && i + 1 < words.size()) paramsFile = words[i + 1];
            if (words[i].rfind("--params=", 0) == 0) paramsFile = words[i].substr(9);
        }
        if (!named && !paramsFile.empty()) {
            std::ifstream in(paramsFile);
            const json j = parseJsonOrDiscarded(
                std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()));
            if (j.is_object()) {
                for (auto it = j.begin(); it != j.end(); ++it) {
                    if (it->is_object() && isSubcommand(it.key())) {
                        words.insert(words.begin() + 1, it.key());
                        break;
                    }
                }
            }
        }
    }
    std::vector<char*> args;
    for (auto& w : words) args.push_back(w.data());
    try {
        mApp.parse(int(args.size()), args.data());
    } catch (const CLI::CallForHelp& e) {
        return mApp.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return mApp.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return mApp.exit(e);
    } catch (const CLI::Success& e) {
        return mApp.exit(e);
    } catch (const CLI::ParseError& e) {
        return error(std::string(e.what()) + " (see --help)", 2);
    }
    if (mDistributable) {
        // Before any signal handling: the driver takes the process over.
        try {
            if (mLocalWorkers > 0 || !mScheduler.empty()) {
                if (mPlan) fail<ValueError>("--plan bakes nothing: drop --local-workers / --scheduler");
                return distribute(words);
            }
            if (!mPlan && mOutput.empty()) fail<ValueError>("--output is required");
            if (!mPlan && (mChunkMemoryGB > 0 || !mChunkDir.empty() || mKeepChunks)) {
                fail<ValueError>("--chunk-memory, --chunk-dir and --keep-chunks shape a cluster run "
                                 "(--local-workers or --scheduler) or a --plan");
            }
        } catch (const ValueError& e) {
            return error(std::string(e.what()) + " (see --help)", 2);
        } catch (const IoError& e) {
            return error(e.what(), 1);
        }
        if (mPlan) requestPlan(mChunkMemoryGB * 1e9);
    }
    {
        const bool tty = !mQuiet && ::isatty(STDERR_FILENO);
        const std::string line = (tty ? "\r\033[K" : "") + mName +
                                 ": error: interrupted; nothing written\n";
        gInterruptLength = std::min(line.size(), sizeof gInterruptLine);
        std::memcpy(gInterruptLine, line.data(), gInterruptLength);
    }
    std::signal(SIGALRM, onAlarm);
    std::signal(SIGINT, onSigint);
    std::signal(SIGTERM, onSigint);
    setCommitCheck(&sigintSeen);
    std::signal(SIGPIPE, SIG_IGN);
    try {
        initialize();
        if (!mOutput.empty()) requireWritable(mOutput);
        std::unique_ptr<tbb::global_control> threads;
        if (mThreads > 0) {
            threads = std::make_unique<tbb::global_control>(
                tbb::global_control::max_allowed_parallelism, size_t(mThreads));
        }
        {
            // Every output of the run lands together, after the work, or none does.
            OutputBatch outputs;
            body();
            outputs.commit();
        }
        // What went to stdout (vdb_info's report, a -o - stream) must have arrived: a full
        // disk or a closed pipe is an error, not a success.
        std::cout.flush();
        if (!std::cout || std::fflush(stdout) != 0) fail<IoError>("cannot write to stdout: ", std::strerror(errno));
        cancelWatchdog(); // a signal after the last write: the outputs are complete
        return 0;
    } catch (const PlanReady& plan) {
        std::cout << jsonText(plan.plan()) << "\n";
        std::cout.flush();
        return std::cout ? 0 : 1;
    } catch (const ValueError& e) {
        return error(e.what(), 2);
    } catch (const IoError& e) {
        return error(e.what(), 1);
    } catch (const Interrupted&) {
        cancelWatchdog();
        return error("interrupted; nothing written", 130);
    } catch (const std::bad_alloc&) {
        return error(std::string("out of memory; nothing written") +
                     (hasOption(mApp, "--voxel-size") ? " (try a larger --voxel-size)" : ""), 1);
    } catch (const openvdb::Exception& e) {
        return error(e.what(), 1);
    } catch (const std::exception& e) {
        return error(e.what(), 1);
    }
}

BakeResult bakeAndWrite(const Tool& tool, const Field& field, const BakeSettings& settings)
{
    auto bar = tool.taskBar();
    Task task(bar.get());
    task.phase("bake", 1.0);
    BakeResult r = bake(field, settings, task.interrupter());
    task.check();
    task.done();
    bar->clear();
    char line[256];
    std::snprintf(line, sizeof line,
                  "%zu active voxels in %zu leaves; cull %.3f s, fill %.3f s, finish %.3f s%s",
                  r.stats.activeVoxels, r.stats.leaves, r.stats.cullSeconds, r.stats.fillSeconds,
                  r.stats.finishSeconds, r.stats.renormalized ? " (renormalised)" : "");
    tool.info(line);
    refuseEmpty(*r.surface, "the shape lies outside the baked region, or so far from the origin that its "
                            "voxel indices overflow (|coordinate| / voxel size must stay under 2^31)");
    const std::string params = tool.paramsJson();
    openvdb::GridCPtrVec grids;
    stampProvenance(*r.surface, tool.name(), params);
    grids.push_back(r.surface);
    if (r.attribute) {
        stampProvenance(*r.attribute, tool.name(), params);
        grids.push_back(r.attribute);
    }
    writeGrids(tool.output(), grids);
    return r;
}

bool hasExtension(const std::string& path, std::initializer_list<const char*> extensions)
{
    for (const char* ext : extensions) {
        const std::string e(ext);
        if (path.size() >= e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0) {
            return true;
        }
    }
    return false;
}

Vec3d toVec3(const std::vector<double>& v, const char* what)
{
    if (v.size() != 3) fail<ValueError>(what, " needs 3 comma-separated values (got ", v.size(), ")");
    return Vec3d(v[0], v[1], v[2]);
}

} // namespace cli
} // namespace rockvdb
