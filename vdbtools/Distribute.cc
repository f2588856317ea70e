// SPDX-License-Identifier: Apache-2.0
#include "Cli.h"
#include "CliDetail.h"

#include <rockvdb/core/BakeParams.h>
#include <rockvdb/core/Error.h>

#include <algorithm>
#include <cstring>
#include <unistd.h>

namespace rockvdb {
namespace cli {

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

} // namespace cli
} // namespace rockvdb
