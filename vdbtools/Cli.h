// SPDX-License-Identifier: Apache-2.0
// rockvdb — the command-line conventions every vdb_* tool follows.
//
//   GNU long options (CLI11), --help with defaults and units, --version, -o/--output
//   ("-" = stdout), --params FILE.json (any option from JSON; command-line values win;
//   unknown keys are errors naming the closest option),
//   --seed, --voxel-size, --half-width, --threads, --quiet, a progress bar on stderr when it
//   is a terminal. Exit 0 on success, 1 on runtime errors, 2 on usage errors, 130 when
//   interrupted (Ctrl-C or SIGTERM; nothing written); every error is one line on stderr:
//   "<tool>: error: <message>".
#pragma once

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/Task.h>

#include <CLI/CLI.hpp>
#include <openvdb/util/NullInterrupter.h>

#include <nlohmann/json.hpp>

#include <array>
#include <functional>
#include <memory>
#include <string>

namespace rockvdb {
namespace cli {

/// @brief A Task's host on the command line: a progress bar on stderr (when it is a terminal
/// and not --quiet) that only goes up, labelled with the phase; cancelled by Ctrl-C (SIGINT)
/// or SIGTERM, after which the tool exits 130 having written nothing.
class TaskBar : public TaskHost
{
public:
    TaskBar(std::string tool, bool enabled) : mTool(std::move(tool)), mEnabled(enabled) {}
    ~TaskBar() override;
    /// @brief Clear the bar's line (before other messages); it stays usable.
    void clear();
    bool cancelled() override;
    void progress(const char* phase, double fraction) override;

private:
    std::string mTool;
    bool mEnabled;
    int mLast = -1;
    bool mShown = false;
};

class Tool
{
public:
    Tool(std::string name, std::string description);

    CLI::App& app() { return mApp; }
    const std::string& name() const { return mName; }

    /// @name Shared options (call the ones the tool needs before run()).
    /// @{
    /// @brief -o: required, its path ending in one of @a extensions (writes()).
    CLI::Option* addOutput(CLI::App& where, const std::string& help,
                           std::vector<std::string> extensions = {".vdb"});
    /// @brief --seed: the seed row (Schema.h seedRow) of a tool without a stage table.
    void addSeed(CLI::App& where);
    /// @brief An up-axis option for a mesh file a tool writes, its default and values from
    /// vdb_mesh's "up" row (meshSchema).
    CLI::Option* addUpAxis(CLI::App& where, const std::string& option, std::string& up,
                           const std::string& file);
    /// @brief One option per row of a stage's table, on @a where: --name, help with unit,
    /// range and default from the table (flags take --name / --no-name).
    void addParams(CLI::App& where, const SchemaBase& schema);
    /// @brief The options of a chunked, distributed bake on @a where (a stage with the
    /// `chunks` / `chunk` rows; call after addOutput): --plan prints the bake's whole box,
    /// estimates and split as JSON and bakes nothing (-o not needed); --local-workers /
    /// --scheduler hand the run to rockvdb.distributed (Dask), which bakes the chunks as
    /// tasks and merges them into -o; --chunk-memory, --chunk-dir and --keep-chunks shape it.
    void addDistribution(CLI::App& where);
    /// @brief --stats FILE: the run's statistics (a stage result's stats: counts, times,
    /// phases) as JSON, written with the other outputs.
    void addStats(CLI::App& where);
    /// @}

    /// @brief A stage's result, told: its report lines on stderr (unless --quiet) and its
    /// stats to --stats FILE. The main writes the grids.
    void finish(const StageResult& result) const;

    /// @brief Run a stage's entry point, @a entry(task), on a Task with the progress bar and
    /// Ctrl-C, then finish() its result and return it: a main's one call of its stage.
    template<typename Entry>
    auto stage(Entry&& entry) const
    {
        auto bar = taskBar();
        Task task(bar.get());
        auto result = entry(task);
        bar->clear();
        finish(result);
        return result;
    }

    /// @brief The values given for @a schema's rows, on the command line or by --params, as
    /// JSON for Schema::fromJson (which fills in the defaults and checks everything).
    nlohmann::json givenParams(const SchemaBase& schema) const;

    /// @brief The host of a stage's Task: progress bar and Ctrl-C.
    std::unique_ptr<TaskBar> taskBar() const;

    uint64_t seed() const { return mSeed; }
    const std::string& output() const { return mOutput; }
    bool quiet() const { return mQuiet; }

    /// @brief Parse, configure threads, run @a body, map exceptions to exit codes.
    int run(int argc, char** argv, const std::function<void()>& body);

    /// @brief Every option's value (defaults included) as a JSON object: the provenance.
    std::string paramsJson() const;


    /// @brief Informational line on stderr (suppressed by --quiet).
    void info(const std::string& line) const;

private:
    struct Bound
    {
        const SchemaBase* schema;
        const ParamInfo* info;
        CLI::Option* option;
        std::shared_ptr<std::vector<std::string>> values;
        std::shared_ptr<bool> flag;
    };

    std::string mName;
    CLI::App mApp;
    std::vector<Bound> mBound;
    uint64_t mSeed{}; ///< addSeed sets it from the seed row
    /// @brief exec /usr/bin/python3 -m rockvdb.distributed with this run's arguments.
    int distribute(const std::vector<std::string>& words);

    std::string mOutput, mStatsPath;
    CLI::Option* mOutputOption = nullptr;
    int mThreads = 0;
    bool mQuiet = false;
    // addDistribution: its options sit in one CLI11 group of mDistributionApp
    CLI::App* mDistributionApp = nullptr;
    bool mDistributable = false, mPlan = false, mKeepChunks = false;
    double mChunkMemoryGB = 0;
    int mLocalWorkers = 0;
    std::string mScheduler, mChunkDir;
};

/// @brief Bake with the task bar (Ctrl-C, progress), print statistics, stamp provenance (every
/// option's value) and write the surface (and the attribute grid, when baked) atomically to
/// tool.output(): vdb_primitive's bake.
BakeResult bakeAndWrite(const Tool& tool, const Field& field, const BakeSettings& settings);

/// @brief ValueError when two outputs of one run, given as (option, path), name the same file
/// (after following symbolic links) or both write to stdout ('-'): one would be lost. Empty
/// paths are outputs not asked for.
void distinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs);

/// @brief ValueError "the result is empty (no active voxels): <why>" when @a grid holds nothing:
/// an empty file with exit 0 would pass for a result down a pipeline.
void refuseEmpty(const openvdb::GridBase& grid, const std::string& why);

/// @brief True when @a path ends in one of @a extensions (as given, e.g. ".obj").
bool hasExtension(const std::string& path, std::initializer_list<const char*> extensions);

/// @brief The check of an option that writes one kind of file: its path must end in one of
/// @a extensions (any case), unless it has none, is '-' (stdout) or an existing device or
/// fifo. A name
/// that promises another format (`-o rock.obj` on a tool that writes a .vdb) is refused
/// before any work: one line naming the option, the path and what it writes, exit 2.
CLI::Validator writes(std::vector<std::string> extensions, const std::string& hint = "");

/// @brief Parse "x,y,z" style option values already split by CLI11 into a Vec3d.
Vec3d toVec3(const std::vector<double>& v, const char* what);

} // namespace cli
} // namespace rockvdb
