# SPDX-License-Identifier: Apache-2.0
"""usage: python3 peak.py REPORT.json CMD [ARG ...]

Run CMD (its stdout and stderr are this process's) and write {"rc": exit code or -signal,
"mb": CMD's peak resident MB} to REPORT.json. The peak is RUSAGE_CHILDREN's ru_maxrss read
here, in a small interpreter: Linux carries a process's high-water mark across exec, so a tool
forked straight from a large pytest process reports pytest's size, not its own."""
import json
import resource
import subprocess
import sys

rc = subprocess.call(sys.argv[2:])
mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
with open(sys.argv[1], "w") as f:
    json.dump({"rc": rc, "mb": mb}, f)
