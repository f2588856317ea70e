// SPDX-License-Identifier: Apache-2.0
#include "Task.h"

#include <algorithm>

namespace rockvdb {

void Task::phase(const char* name, double share)
{
    mStart = std::min(1.0, mStart + mShare);
    mShare = std::clamp(share, 0.0, 1.0 - mStart);
    mPhase = name;
    mStarted.emplace_back(name, Clock::now());
    report(mStart);
    check();
}

void Task::advance(double fraction)
{
    report(mStart + mShare * std::clamp(fraction, 0.0, 1.0));
}

void Task::step(double fraction)
{
    advance(fraction);
    check();
}

void Task::done()
{
    if (mDone == Clock::time_point{}) mDone = Clock::now();
    mStart = 1.0;
    mShare = 0.0;
    report(1.0);
}

std::vector<std::pair<std::string, double>> Task::phases() const
{
    std::vector<std::pair<std::string, double>> out;
    const Clock::time_point end = mDone == Clock::time_point{} ? Clock::now() : mDone;
    for (size_t i = 0; i < mStarted.size(); ++i) {
        const Clock::time_point until = i + 1 < mStarted.size() ? mStarted[i + 1].second : end;
        out.emplace_back(mStarted[i].first,
                         std::chrono::duration<double>(until - mStarted[i].second).count());
    }
    return out;
}

void Task::report(double overall)
{
    // Monotone across threads: only a value above the last one reported goes out, and the
    // check and the host's call happen under one lock. (A compare-and-swap alone let a thread
    // that won with a smaller value call the host after one that won with a larger value:
    // the TSan job's scheduling showed 0.117 then 0.111.) Reports come per chunk, not per
    // voxel, so the lock is uncontended in practice; the atomic keeps the common "nothing new"
    // case lock-free.
    if (overall <= mReported.load()) return;
    std::lock_guard<std::mutex> lock(mReportMutex);
    if (overall <= mReported.load()) return;
    mReported.store(overall);
    if (mHost) mHost->progress(mPhase, overall);
}

} // namespace rockvdb
