# SPDX-License-Identifier: Apache-2.0
"""What the bench scripts print about the machine they ran on (ratios are the claim, but a
table says where it was measured)."""
import platform


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
