// SPDX-License-Identifier: Apache-2.0
#include "CliDetail.h"

#include <rockvdb/core/VdbIO.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstring>
#include <sys/time.h>
#include <unistd.h>

namespace rockvdb {
namespace cli {

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

} // namespace

bool sigintSeen() { return gSigint.load(); }

void cancelWatchdog()
{
    itimerval t{};
    ::setitimer(ITIMER_REAL, &t, nullptr);
}

void installInterruptHandlers(const std::string& tool, bool clearLine)
{
    const std::string line = (clearLine ? "\r\033[K" : "") + tool +
                             ": error: interrupted; nothing written\n";
    gInterruptLength = std::min(line.size(), sizeof gInterruptLine);
    std::memcpy(gInterruptLine, line.data(), gInterruptLength);
    std::signal(SIGALRM, onAlarm);
    std::signal(SIGINT, onSigint);
    std::signal(SIGTERM, onSigint);
    setCommitCheck(&sigintSeen);
    std::signal(SIGPIPE, SIG_IGN);
}

} // namespace cli
} // namespace rockvdb
