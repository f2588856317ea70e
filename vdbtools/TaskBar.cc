// SPDX-License-Identifier: Apache-2.0
#include "Cli.h"
#include "CliDetail.h"

#include <algorithm>
#include <cstdio>
#include <mutex>

namespace rockvdb {
namespace cli {

TaskBar::~TaskBar() { clear(); }

void TaskBar::clear()
{
    if (mShown) {
        std::fprintf(stderr, "\r\033[K");
        std::fflush(stderr);
    }
    mShown = false;
}

bool TaskBar::cancelled() { return sigintSeen(); }

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

} // namespace cli
} // namespace rockvdb
