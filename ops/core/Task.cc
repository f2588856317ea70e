#include "Task.h"

#include <algorithm>

namespace rockvdb {

void Task::phase(const char* name, double share)
{
    mStart = std::min(1.0, mStart + mShare);
    mShare = std::clamp(share, 0.0, 1.0 - mStart);
    mPhase = name;
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
    mStart = 1.0;
    mShare = 0.0;
    report(1.0);
}

void Task::report(double overall)
{
    // Monotone across threads: only a value above the last one reported goes out.
    double last = mReported.load();
    while (overall > last) {
        if (mReported.compare_exchange_weak(last, overall)) {
            if (mHost) mHost->progress(mPhase, overall);
            return;
        }
    }
}

} // namespace rockvdb
