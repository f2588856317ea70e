# SPDX-License-Identifier: Apache-2.0
"""What the bench scripts share: the machine they ran on (ratios are the claim, but a table
says where it was measured) and their --runs option."""
import platform


def runs_option(argv, default=2):
    """(runs, the other arguments) from a command line holding an optional --runs N."""
    runs = default
    if "--runs" in argv:
        i = argv.index("--runs")
        runs = int(argv[i + 1])
        argv = argv[:i] + argv[i + 2:]
    return runs, argv


def cpu():
    """The CPU's model name (/proc/cpuinfo), or what platform knows."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"
