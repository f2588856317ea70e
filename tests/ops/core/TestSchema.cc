// SPDX-License-Identifier: Apache-2.0
// core/Schema and core/Task: the parameter tables every stage is built on, and the task that
// carries progress and the cancel.
#include <rockvdb/core/Error.h>
#include <rockvdb/core/Schema.h>
#include <rockvdb/core/StageResult.h>
#include <rockvdb/core/VdbIO.h>
#include <rockvdb/core/Task.h>

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

using namespace rockvdb;
using nlohmann::json;

namespace {

struct Toy
{
    Toy() { schema().reset(*this); }
    int n;
    double size;
    bool fill;
    std::string mode;
    std::array<double, 2> range;
    std::optional<std::array<double, 3>> axis;
    double spacing;

    static const Schema<Toy>& schema()
    {
        static const Schema<Toy> s = [] {
            Schema<Toy> t("toy", "A toy stage.");
            auto row = [](const char* name, ParamType type, json def, Range r, size_t count = 1) {
                ParamInfo p;
                p.name = name;
                p.type = type;
                p.defaultValue = def;
                p.range = r;
                p.count = count;
                p.help = "help";
                return p;
            };
            t.member(row("n", ParamType::Int, 5, Range::closed(3, 64)), &Toy::n);
            t.member(row("tile-size", ParamType::Real, 20.0, Range::above(0)), &Toy::size);
            t.member(row("fill", ParamType::Bool, true, Range::any()), &Toy::fill);
            ParamInfo mode = row("mode", ParamType::Text, "fast", Range::any());
            mode.choices = {"fast", "exact"};
            t.member(mode, &Toy::mode);
            t.member(row("range", ParamType::Reals, json::array({-1.0, 2.0}), Range::closed(-10, 10), 2),
                     &Toy::range);
            t.member(row("axis", ParamType::Reals, nullptr, Range::any(), 3), &Toy::axis);
            // (the derived default 0 lies outside the range: it stands for the rule)
            t.member(row("spacing", ParamType::Real, 0.0, Range::above(0)), &Toy::spacing);
            t.derived("spacing", "0.1 x tile-size", [](Toy& p) { p.spacing = 0.1 * p.size; });
            t.rule([](const Toy& p) {
                if (p.range[0] > p.range[1]) fail<ValueError>("toy: range needs min <= max");
                if (p.spacing >= p.size) fail<ValueError>("toy: spacing must be < tile-size");
            });
            return t;
        }();
        return s;
    }
};

std::string message(const json& j)
{
    try {
        Toy::schema().fromJson(j);
    } catch (const ValueError& e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(Schema, DefaultsComeFromTheTableAlone)
{
    const Toy t;
    EXPECT_EQ(t.n, 5);
    EXPECT_EQ(t.size, 20.0);
    EXPECT_TRUE(t.fill);
    EXPECT_EQ(t.mode, "fast");
    EXPECT_EQ(t.range[1], 2.0);
    EXPECT_FALSE(t.axis.has_value());
    // fromJson({}) and the default constructor agree, and toJson records every row.
    const json all = Toy::schema().toJson(Toy::schema().fromJson(json::object()));
    EXPECT_EQ(all, Toy::schema().toJson(t));
    EXPECT_EQ(all.size(), Toy::schema().params().size());
    EXPECT_TRUE(all.at("axis").is_null());
}

TEST(Schema, JsonRoundTripsEveryRow)
{
    const json j = {{"n", 7}, {"tile-size", 3.5}, {"fill", false}, {"mode", "exact"},
                    {"range", {0, 1}}, {"axis", {0, 0, 1}}};
    const Toy t = Toy::schema().fromJson(j);
    EXPECT_EQ(t.n, 7);
    EXPECT_FALSE(t.fill);
    ASSERT_TRUE(t.axis.has_value());
    EXPECT_EQ((*t.axis)[2], 1.0);
    const Toy back = Toy::schema().fromJson(Toy::schema().toJson(t));
    EXPECT_EQ(Toy::schema().toJson(back), Toy::schema().toJson(t));
}

TEST(Schema, MessagesNameOpParameterRangeAndValue)
{
    EXPECT_EQ(message({{"n", 100}}), "toy: n must be in [3, 64] (got 100)");
    EXPECT_EQ(message({{"n", 4.5}}), "toy: n must be an integer (got 4.5)");
    EXPECT_EQ(message({{"n", "5"}}), "toy: n must be an integer (got \"5\")");
    EXPECT_EQ(message({{"tile-size", 0}}), "toy: tile-size must be > 0 (got 0)");
    EXPECT_EQ(message({{"mode", "slow"}}), "toy: mode must be one of fast, exact (got 'slow')");
    EXPECT_EQ(message({{"range", {1}}}), "toy: range must be a list of 2 numbers (got [1])");
    EXPECT_EQ(message({{"range", {3, 1}}}), "toy: range needs min <= max");
    EXPECT_EQ(message({{"fill", 1}}), "toy: fill must be true or false (got 1)");
    // NaN never passes a range.
    EXPECT_NE(message({{"tile-size", std::nan("")}}), "");
    // Integral doubles are integers (JSON from other tools writes 5.0).
    EXPECT_EQ(Toy::schema().fromJson({{"n", 5.0}}).n, 5);
    // Wrong types are ParamTypeErrors (Python: TypeError as well as ValueError).
    EXPECT_THROW(Toy::schema().fromJson({{"n", "5"}}), ParamTypeError);
}

TEST(Schema, UnknownKeysSuggestTheClosestName)
{
    EXPECT_EQ(message({{"tile_size", 1}}), "toy: unknown parameter 'tile_size' (did you mean 'tile-size'?)");
    EXPECT_EQ(message({{"nn", 1}}), "toy: unknown parameter 'nn' (did you mean 'n'?)");
    EXPECT_EQ(message({{"zzzzzzzz", 1}}), "toy: unknown parameter 'zzzzzzzz'");
    EXPECT_EQ(closestName("voxle-size", {"voxel-size", "half-width"}), "voxel-size");
}

TEST(Schema, ValidateChecksMembersSetFromCpp)
{
    Toy t;
    t.n = 2;
    EXPECT_THROW(Toy::schema().validate(t), ValueError);
    t.n = 5;
    EXPECT_NO_THROW(Toy::schema().validate(t));
}

TEST(Schema, DerivedDefaultsAreRulesOfTheTable)
{
    // A row left at its default takes the rule's value; one given keeps it; the record (toJson,
    // what provenance replays) keeps the row as given, so a replay derives it again.
    const Toy given = Toy::schema().fromJson({{"tile-size", 30.0}});
    EXPECT_EQ(given.spacing, 0.0);
    EXPECT_EQ(Toy::schema().toJson(given)["spacing"], 0.0);
    EXPECT_DOUBLE_EQ(Toy::schema().derive(given).spacing, 3.0);
    EXPECT_EQ(Toy::schema().derive(Toy::schema().fromJson({{"spacing", 2.0}})).spacing, 2.0);
    // Rules see derived values: 0.1 x 0.5 passes "spacing < tile-size"; a given 1 does not.
    EXPECT_NO_THROW(Toy::schema().fromJson({{"tile-size", 0.5}}));
    EXPECT_EQ(message({{"tile-size", 0.5}, {"spacing", 1.0}}), "toy: spacing must be < tile-size");
    // Interfaces read the rule: describe() and the help.
    const json row = Toy::schema().describe()["params"][6];
    EXPECT_EQ(row["derived"], "0.1 x tile-size");
    EXPECT_EQ(row["help"], "help (0 = 0.1 x tile-size)");
    EXPECT_TRUE(Toy::schema().describe()["params"][0]["derived"].is_null());
    EXPECT_THROW(Schema<Toy>("t", "").derived("nope", "x", [](Toy&) {}), std::logic_error);
}

TEST(Schema, ADerivedRowsSentinelIsItsRuleNotAValue)
{
    // The default 0 stands for the rule, outside the row's range (> 0), which is what a user
    // may give: front-ends show the rule's value beside an Auto box, never the 0.
    EXPECT_NO_THROW(Toy::schema().fromJson({{"spacing", 0.0}}));
    EXPECT_EQ(message({{"spacing", -1.0}}), "toy: spacing must be > 0 (got -1.0)");
    const json values = Toy::schema().derivedValues({{"tile-size", 30.0}});
    EXPECT_DOUBLE_EQ(values["spacing"].get<double>(), 3.0);
    EXPECT_EQ(values["n"], 5); // every row, canonical
    EXPECT_DOUBLE_EQ(Toy::schema().derivedValues({{"spacing", 2.0}})["spacing"].get<double>(), 2.0);
    EXPECT_THROW(Toy::schema().derivedValues({{"n", 2}}), ValueError);
}

TEST(Schema, GroupsAndFileRowsForFrontEnds)
{
    Schema<Toy> s = Toy::schema();
    s.group("Surface", {"spacing", "fill"}).files({"mode"});
    const json rows = s.describe()["params"];
    EXPECT_EQ(rows[6]["group"], "Surface");
    EXPECT_EQ(rows[2]["group"], "Surface");
    EXPECT_EQ(rows[0]["group"], "Shape"); // the default group
    EXPECT_EQ(rows[3]["file"], true);
    EXPECT_EQ(rows[0]["file"], false);
    EXPECT_THROW(s.group("Surface", {"nope"}), std::logic_error);
    EXPECT_THROW(s.files({"nope"}), std::logic_error);
    // A resolution row is in Resolution unless its table says otherwise.
    EXPECT_EQ(voxelSizeRow(0.1).groupName(), "Resolution");
}

TEST(Schema, PreviewVoxelFollowsTheExtentWithinItsBounds)
{
    // kPreviewVoxelsAcross across the extent, never finer than the final voxel, never coarser
    // than kPreviewCoarsest of them.
    EXPECT_DOUBLE_EQ(previewVoxelSize(0.01, 2.0), 2.0 / kPreviewVoxelsAcross);  // a rock
    EXPECT_DOUBLE_EQ(previewVoxelSize(0.05, 1.0), 0.05);                         // small: final
    EXPECT_DOUBLE_EQ(previewVoxelSize(0.05, 1000.0), kPreviewCoarsest * 0.05);   // a big terrain
    EXPECT_THROW(previewVoxelSize(0.0, 1.0), ValueError);
    EXPECT_THROW(previewVoxelSize(0.05, -1.0), ValueError);
}

TEST(Schema, DescribeIsWhatInterfacesRead)
{
    const json d = Toy::schema().describe();
    EXPECT_EQ(d["op"], "toy");
    ASSERT_EQ(d["params"].size(), 7u);
    EXPECT_EQ(d["params"][1]["python"], "tile_size");
    EXPECT_EQ(d["params"][1]["range"], "> 0");
    EXPECT_EQ(d["params"][0]["range"], "in [3, 64]");
    EXPECT_EQ(d["params"][4]["default"], json::array({-1.0, 2.0}));
}

namespace {

struct Recorder : TaskHost
{
    std::atomic<bool> cancel{false};
    std::vector<double> seen;
    std::mutex m;
    bool cancelled() override { return cancel.load(); }
    void progress(const char*, double f) override
    {
        std::lock_guard<std::mutex> lock(m);
        seen.push_back(f);
    }
};

} // namespace

TEST(Task, ProgressOnlyGoesUpAcrossPhasesAndEndsAtOne)
{
    Recorder host;
    Task task(&host);
    task.phase("a", 0.25);
    std::vector<int> out(1000);
    parallelFor(task, out.size(), 7, [&](size_t i) { out[i] = int(i); });
    task.phase("b", 0.75);
    task.step(0.5);
    task.step(0.2); // a later report below the last one is not passed on
    task.done();
    ASSERT_FALSE(host.seen.empty());
    for (size_t i = 1; i < host.seen.size(); ++i) EXPECT_GT(host.seen[i], host.seen[i - 1]);
    EXPECT_DOUBLE_EQ(host.seen.back(), 1.0);
    EXPECT_NEAR(task.reported(), 1.0, 0.0);
    for (size_t i = 0; i < out.size(); ++i) ASSERT_EQ(out[i], int(i));
}

TEST(Task, PhasesAreTimedInTheOrderTheyRan)
{
    Task task;
    task.phase("first", 0.5);
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    task.phase("second", 0.5);
    task.done();
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    const auto phases = task.phases();
    ASSERT_EQ(phases.size(), 2u);
    EXPECT_EQ(phases[0].first, "first");
    EXPECT_EQ(phases[1].first, "second");
    EXPECT_GE(phases[0].second, 0.025);
    EXPECT_LT(phases[1].second, 0.025); // ends at done(), not when asked
    const nlohmann::json j = phasesJson(task);
    ASSERT_EQ(j.size(), 2u);
    EXPECT_EQ(j[1]["name"], "second");
}

TEST(StageResult, OneProvenanceOnEveryGridWithTheInputsMerged)
{
    initialize();
    StageResult r;
    auto a = openvdb::FloatGrid::create(), b = openvdb::FloatGrid::create();
    const nlohmann::json prov = stageProvenance({{"seed", 3}, {"size", 2.5}}, {{"from-tile", "t.tile"}});
    EXPECT_EQ(prov, (nlohmann::json{{"seed", 3}, {"size", 2.5}, {"from-tile", "t.tile"}}));
    stampResult(r, "vdb_test", {a, b}, prov);
    ASSERT_EQ(r.grids.size(), 2u);
    for (const auto& g : {a, b}) {
        const auto p = provenance(*g);
        ASSERT_TRUE(p);
        EXPECT_EQ(p->generator, "vdb_test");
        EXPECT_EQ(nlohmann::json::parse(p->params), prov);
    }
    EXPECT_EQ(r.provenance, prov);
}

TEST(Task, CancelStopsAParallelLoopEarly)
{
    Recorder host;
    Task task(&host);
    task.phase("loop", 1.0);
    std::atomic<size_t> done{0};
    EXPECT_THROW(parallelFor(task, 100000, 10, [&](size_t i) {
                     if (++done == 500) host.cancel = true;
                     (void)i;
                 }),
                 Interrupted);
    EXPECT_LT(done.load(), 100000u); // chunks after the cancel never ran
    EXPECT_THROW(task.check(), Interrupted);
}

// A body that throws must not cut short the nested TBB loops of the bodies still running:
// an exception out of tbb::parallel_for cancels the loop's task group, nested algorithms
// inherit that, and OpenVDB tools inside a body then return half done (the arches redistance
// segfaulted on Ctrl-C that way). parallelFor lets the running bodies finish, then rethrows.
TEST(Task, AFailingBodyLetsTheRunningNestedLoopsFinish)
{
    Task task;
    constexpr size_t kInner = 20000;
    std::atomic<bool> nestedStarted{false};
    std::mutex m;
    std::vector<size_t> innerCounts; // one per body whose nested loop ran
    try {
        parallelFor(task, 4, 1, [&](size_t i) {
            if (i == 0) {
                // Throw while another body is inside its nested loop (bounded wait: with one
                // thread there is none).
                const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
                while (!nestedStarted.load() && std::chrono::steady_clock::now() < until) std::this_thread::yield();
                throw ValueError("body 0 failed");
            }
            std::atomic<size_t> inner{0};
            tbb::parallel_for(tbb::blocked_range<size_t>(0, kInner, 64), [&](const tbb::blocked_range<size_t>& r) {
                nestedStarted.store(true);
                for (size_t k = r.begin(); k != r.end(); ++k) {
                    inner.fetch_add(1);
                    if (k % 64 == 0) std::this_thread::sleep_for(std::chrono::microseconds(20));
                }
            });
            std::lock_guard<std::mutex> lock(m);
            innerCounts.push_back(inner.load());
        });
        FAIL() << "the body's ValueError was not rethrown";
    } catch (const ValueError& e) {
        EXPECT_STREQ(e.what(), "body 0 failed");
    }
    for (size_t c : innerCounts) EXPECT_EQ(c, kInner); // every nested loop that started, whole
}

// Of two bodies failing while both run, the lower index's error is the one rethrown, even
// when the higher one throws first: the message does not depend on the scheduling.
TEST(Task, TheLowestFailingIndexIsRethrown)
{
    if (tbb::this_task_arena::max_concurrency() < 2) GTEST_SKIP() << "needs two threads";
    Task task;
    for (int rep = 0; rep < 10; ++rep) {
        std::atomic<bool> started0{false}, threw1{false};
        auto waitFor = [](std::atomic<bool>& flag) {
            const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(5);
            while (!flag.load() && std::chrono::steady_clock::now() < until) std::this_thread::yield();
            return flag.load();
        };
        try {
            parallelFor(task, 2, 1, [&](size_t i) {
                if (i == 0) {
                    started0.store(true);
                    waitFor(threw1);
                    throw ValueError("index 0");
                }
                waitFor(started0);
                threw1.store(true);
                throw ValueError("index 1");
            });
            FAIL();
        } catch (const ValueError& e) {
            if (!started0.load()) continue; // the two never overlapped (one thread took both)
            EXPECT_STREQ(e.what(), "index 0");
        }
    }
}

TEST(Task, InterrupterAdapterMapsPercentIntoThePhase)
{
    Recorder host;
    Task task(&host);
    task.phase("first", 0.5);
    task.phase("bake", 0.5);
    EXPECT_FALSE(task.interrupter()->wasInterrupted(50));
    EXPECT_NEAR(task.reported(), 0.75, 1e-12);
    host.cancel = true;
    EXPECT_TRUE(task.interrupter()->wasInterrupted());
}
