// SPDX-License-Identifier: Apache-2.0
#include "Cli.h"
#include "CliDetail.h"

#include <rockvdb/core/Chunks.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Json.h>
#include <rockvdb/core/Mesh.h>
#include <rockvdb/core/VdbIO.h>

#include <openvdb/Exceptions.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <unistd.h>

// The Tool itself: options every tool shares, run() (parsing, threads, outputs that land
// together, exit codes), and the small helpers of Cli.h. The other jobs: CliDetail.h.
namespace rockvdb {
namespace cli {

using nlohmann::json;

Tool::Tool(std::string name, std::string description)
    : mName(std::move(name)), mApp(std::move(description), mName)
{
    mApp.set_version_flag("--version", std::string(mName) + " (rockvdb) " + version());
    mApp.config_formatter(makeConfigJson(&mApp));
    mApp.set_config("--params", "", "Read options from a JSON file {\"option-name\": value, "
                                    "\"subcommand\": {...}}; command-line values win");
    mApp.add_option("--threads", mThreads, "Worker threads (0 = all cores)")
        ->check(CLI::Range(0, 1024))->capture_default_str();
    mApp.add_flag("-q,--quiet", mQuiet, "No progress bar or statistics on stderr");
    mApp.get_formatter()->column_width(34);
    mApp.option_defaults()->always_capture_default();
    mApp.fallthrough(); // parent options may follow a subcommand
}

CLI::Option* Tool::addOutput(CLI::App& where, const std::string& help,
                             std::vector<std::string> extensions)
{
    const bool vdb = extensions.size() == 1 && extensions[0] == ".vdb";
    mOutputOption = where.add_option("-o,--output", mOutput, help)->required()->check(
        writes(std::move(extensions), vdb ? "vdb_mesh turns a .vdb into .obj / .ply" : ""));
    return mOutputOption;
}

void Tool::addSeed(CLI::App& where)
{
    const ParamInfo row = seedRow();
    mSeed = row.defaultValue.get<uint64_t>();
    where.add_option("--" + row.name, mSeed, row.help)->capture_default_str();
}

CLI::Option* Tool::addUpAxis(CLI::App& where, const std::string& option, std::string& up,
                             const std::string& file)
{
    const ParamInfo& row = *meshSchema().find("up");
    up = row.defaultValue.get<std::string>();
    return where.add_option(option, up, "Up axis of " + file + ": z (rockvdb) or y (Blender's OBJ "
                                        "import default, Houdini)")
        ->check(CLI::IsMember(row.choices))->capture_default_str();
}

std::unique_ptr<TaskBar> Tool::taskBar() const
{
    return std::make_unique<TaskBar>(mName, !mQuiet && ::isatty(STDERR_FILENO));
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
    installInterruptHandlers(mName, !mQuiet && ::isatty(STDERR_FILENO));
    try {
        initialize();
        if (!mOutput.empty()) requireWritable(mOutput);
        if (!mStatsPath.empty()) {
            // (a main's own distinctOutputs names its other outputs)
            distinctOutputs({{"-o", mOutput}, {"--stats", mStatsPath}});
            requireWritable(mStatsPath);
        }
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

CLI::Validator writes(std::vector<std::string> extensions, const std::string& hint)
{
    std::string list;
    for (const auto& e : extensions) list += (list.empty() ? "" : " or ") + e;
    return CLI::Validator(
        [extensions, hint, list](std::string& path) -> std::string {
            if (path.empty() || path == "-") return {};
            std::error_code ec;
            const auto st = std::filesystem::status(path, ec);
            if (!ec && std::filesystem::exists(st) && !std::filesystem::is_regular_file(st)) {
                return {}; // a device or a fifo is written through; a folder is refused later
            }
            std::string ext = std::filesystem::path(path).extension().string();
            for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
            // A name without an extension promises no format (a pipeline's scratch file).
            if (ext.empty()) return {};
            for (const auto& e : extensions) if (ext == e) return {};
            return "'" + path + "' ends in " + ext + ", but this writes " + list +
                   (hint.empty() ? "" : " (" + hint + ")");
        },
        "", "writes " + list);
}

Vec3d toVec3(const std::vector<double>& v, const char* what)
{
    if (v.size() != 3) fail<ValueError>(what, " needs 3 comma-separated values (got ", v.size(), ")");
    return Vec3d(v[0], v[1], v[2]);
}

} // namespace cli
} // namespace rockvdb
