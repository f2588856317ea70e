// SPDX-License-Identifier: Apache-2.0
// rockvdb — Task: the interrupt and the progress of one long call, passed to every stage.
//
// A stage's entry point takes a Task and splits its work into phases ("voronoi", "level
// sets", "bake", ...), each a share of the whole. Inside a phase, work reports how far it got
// and checks for a cancel at a coarse grain: per batch of rocks, per leaf batch, per cluster,
// never per voxel. The host decides what a cancel is and where progress goes: the CLI's
// progress bar and SIGINT / SIGTERM flag, Python's signal check, nothing at all in tests.
//
//     task.phase("voronoi", 0.6);
//     parallelFor(task, rocks.size(), 8, [&](size_t i) { rocks[i] = makeRock(...); });
//     task.phase("bake", 0.4);
//     bake(field, settings, task.interrupter());
//
// Progress only goes up: overall = phase start + share · fraction, reported when it grows;
// done() reports 100%. A cancel throws Interrupted from step() / check(), and from
// parallelFor once its running chunks have finished (no exception leaves a TBB loop).
#pragma once

#include <rockvdb/core/Error.h>

#include <openvdb/util/NullInterrupter.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <atomic>
#include <chrono>
#include <cstddef>
#include <exception>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace rockvdb {

/// @brief Where a Task's progress goes and where its cancel comes from.
class TaskHost
{
public:
    virtual ~TaskHost() = default;
    /// @brief True once the user asked to stop. Called from any thread, at a coarse grain.
    virtual bool cancelled() = 0;
    /// @brief Overall progress in [0, 1], never decreasing; @a phase names the current one.
    /// Called from any thread (the host serialises its output).
    virtual void progress(const char* /*phase*/, double /*fraction*/) {}
};

class Task
{
public:
    /// A task nobody watches: never cancelled, no progress (tests, library use).
    Task() = default;
    explicit Task(TaskHost* host) : mHost(host) {}
    Task(const Task&) = delete;
    Task& operator=(const Task&) = delete;

    /// @brief Start the next phase, covering @a share of the whole (shares sum to <= 1).
    /// Checks for a cancel.
    void phase(const char* name, double share);

    /// @brief Progress @a fraction in [0, 1] of the current phase; throws Interrupted when
    /// cancelled. Thread-safe.
    void step(double fraction);

    /// @brief step() without the check: progress only. Thread-safe.
    void advance(double fraction);

    /// @brief Throw Interrupted when cancelled. Thread-safe.
    void check() const
    {
        if (cancelled()) throw Interrupted();
    }

    bool cancelled() const { return mHost && mHost->cancelled(); }

    /// @brief The whole task is finished: reports 100%.
    void done();

    /// @brief The current phase as an OpenVDB interrupter, for bake() and openvdb::tools:
    /// their percent maps into the phase, their cancel is this task's.
    openvdb::util::NullInterrupter* interrupter() { return &mAdapter; }

    /// @brief Overall progress reported so far, in [0, 1].
    double reported() const { return mReported.load(); }

    /// @brief The phases started so far, in order, with their wall-clock seconds (the last one
    /// until done(), or until now while it runs): an entry point's structure, reported in
    /// its stats whichever front-end called it.
    std::vector<std::pair<std::string, double>> phases() const;

private:
    void report(double overall);

    class Adapter : public openvdb::util::NullInterrupter
    {
    public:
        explicit Adapter(Task& t) : mTask(t) {}
        bool wasInterrupted(int percent = -1) override
        {
            if (percent >= 0) mTask.advance(percent / 100.0);
            return mTask.cancelled();
        }

    private:
        Task& mTask;
    };

    using Clock = std::chrono::steady_clock;

    TaskHost* mHost = nullptr;
    const char* mPhase = "";
    std::vector<std::pair<std::string, Clock::time_point>> mStarted; ///< phase() calls
    Clock::time_point mDone{};                                        ///< set by done()
    double mStart = 0, mShare = 0;
    std::atomic<double> mReported{0.0};
    std::mutex mReportMutex; ///< one report at a time: the host sees them in rising order
    Adapter mAdapter{*this};
};

/// @brief tbb::parallel_for over [0, n) in chunks of @a grain, calling @a body(i) for each
/// index, and the phase's progress advances with the count done. Results must not depend on
/// the chunking (write to slot i, never append).
///
/// Cooperative: no exception ever leaves the TBB loop. A cancel (checked between chunks) or
/// an exception from @a body only stops chunks not yet started; the running ones finish, then
/// the exception of the lowest index that threw is rethrown (of those that ran), or
/// Interrupted. Letting an exception out of tbb::parallel_for would cancel
/// the loop's task group, and with it every OpenVDB algorithm the running bodies have nested
/// inside (they inherit the cancellation): those return half done and their callers read
/// state that was never filled. That was a segfault on Ctrl-C in the arches redistance.
template<typename Body>
void parallelFor(Task& task, size_t n, size_t grain, const Body& body)
{
    task.check();
    std::atomic<bool> stop{false}, interrupted{false};
    std::atomic<size_t> finished{0};
    std::mutex failMutex;
    std::exception_ptr failure;
    size_t failedAt = n;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, grain == 0 ? 1 : grain),
        [&](const tbb::blocked_range<size_t>& r) {
            if (stop.load(std::memory_order_relaxed)) return;
            if (task.cancelled()) {
                interrupted.store(true);
                stop.store(true);
                return;
            }
            size_t i = r.begin();
            try {
                for (; i != r.end(); ++i) body(i);
            } catch (...) {
                std::lock_guard<std::mutex> lock(failMutex);
                if (!failure || i < failedAt) {
                    failure = std::current_exception();
                    failedAt = i;
                }
                stop.store(true);
                return;
            }
            const size_t now = finished.fetch_add(r.size()) + r.size();
            task.advance(double(now) / double(n));
        });
    if (failure) std::rethrow_exception(failure);
    if (interrupted.load()) throw Interrupted();
}

} // namespace rockvdb
